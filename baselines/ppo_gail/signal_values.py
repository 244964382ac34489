"""A value head per reward signal, as Unity ML-Agents' PPO trains its critic (``value_per_signal=True``).

ML-Agents gives the environment (extrinsic) reward, the curiosity reward and the GAIL reward a value head
each, on one shared network, and ends an episode differently per signal: the extrinsic value is zero after an
episode ends at a bound or the exit, while the curiosity and GAIL values are bootstrapped as if it went on
(their reward signals set ``use_terminal_states = False``; its policies' ``get_value_estimates``). The
advantage PPO optimises is the mean of the signals' GAE advantages, normalised over the rollout; the value
loss is the mean of the heads' losses.

It matters for ML-Agents' GAIL reward, -log(1 - D), which is positive at every step: one value of the summed
reward, zeroed at every end, prices reaching the exit at the discounted GAIL reward it forfeits (about
0.13 / (1 - 0.99) = 13 against the exit's +2), and a tracking network trained so never reached the exit
(docs/experiments.md, "Ending episodes under ML-Agents' GAIL reward").

rsl-rl's runner hands over the next episode's first observation at an end, not the last one, so a signal
that goes on is bootstrapped with the value of s_t, as rsl-rl bootstraps a time-out (where ML-Agents values
the episode's last observation).
"""

from __future__ import annotations

import torch
from rsl_rl.algorithms import PPO
from rsl_rl.models import MLPModel
from rsl_rl.storage import RolloutStorage

CRITIC_CLASS_NAME = "cabinbench.baselines.ppo_gail.signal_values:SignalValueCritic"


def signal_names(use_curiosity: bool, use_gail: bool) -> tuple[str, ...]:
    """The reward signals in the order of the critic's outputs: the extrinsic one first."""
    return ("extrinsic",) + ("curiosity",) * use_curiosity + ("gail",) * use_gail


class SignalValueCritic(MLPModel):
    """rsl-rl's MLP critic with ``num_values`` outputs, one per reward signal. rsl-rl's
    ``PPO.construct_algorithm`` asks every critic for one output (``output_dim``); this one gives
    ``num_values`` instead."""

    def __init__(self, obs, obs_groups, obs_set, output_dim: int, *, num_values: int, **model_cfg) -> None:
        super().__init__(obs, obs_groups, obs_set, num_values, **model_cfg)
        self.num_values = num_values


class SignalValues:
    """The per-signal rewards of a rollout and their returns, in the storage's ``values`` and ``returns``
    (widened here to [steps, envs, signals]); its ``advantages`` stay [steps, envs, 1], as PPO's surrogate
    loss reads them.

    Args:
        storage: The algorithm's rollout storage.
        signals: ``signal_names`` of the run, the critic's outputs.
        gamma, lam: PPO's discount and GAE lambda, shared by every signal (Table 5.3 gives each 0.99).
        normalise_advantages: Normalise the advantages over the rollout (ML-Agents does, over its buffer);
            False where PPO normalises them per mini-batch.
    """

    def __init__(
        self,
        storage: RolloutStorage,
        signals: tuple[str, ...],
        gamma: float,
        lam: float,
        normalise_advantages: bool = True,
    ) -> None:
        self.storage, self.signals, self.gamma, self.lam = storage, signals, gamma, lam
        self.normalise_advantages = normalise_advantages
        shape = (storage.num_transitions_per_env, storage.num_envs, len(signals))
        storage.values = torch.zeros(shape, device=storage.device)
        storage.returns = torch.zeros(shape, device=storage.device)
        self.rewards = torch.zeros(shape, device=storage.device)
        """Each signal's reward per step, with the value its episode's end bootstraps."""

    @classmethod
    def for_algorithm(cls, algorithm: PPO, signals: tuple[str, ...]) -> SignalValues:
        """The signal values of ``algorithm``'s storage, with its discount, lambda and advantage
        normalisation; its critic must give one value per signal (``SignalValueCritic``)."""
        if getattr(algorithm.critic, "num_values", None) != len(signals):
            raise ValueError(f"value_per_signal needs a SignalValueCritic of {len(signals)} values")
        normalise = not algorithm.normalize_advantage_per_mini_batch
        return cls(algorithm.storage, signals, algorithm.gamma, algorithm.lam, normalise)

    def record(
        self,
        step: int,
        rewards: dict[str, torch.Tensor],
        values: torch.Tensor,
        dones: torch.Tensor,
        extras: dict,
    ) -> None:
        """Store step ``step``'s ``rewards`` (one [envs] tensor per signal) and bootstrap the episodes that
        ended: every signal at a time-out (``extras["time_outs"]``, as rsl-rl's ``PPO`` does), the curiosity
        and GAIL signals at any end, with ``values`` of s_t ([envs, signals])."""
        timed_out = extras.get("time_outs", torch.zeros_like(dones)).bool()
        ended = dones.bool()
        goes_on = torch.stack([timed_out if name == "extrinsic" else ended for name in self.signals], 1)
        bootstrap = self.gamma * values * goes_on
        self.rewards[step].copy_(torch.stack([rewards[name] for name in self.signals], 1) + bootstrap)

    def of(self, signal: str) -> torch.Tensor:
        """The rewards of ``signal``, [steps, envs, 1]: a view, which writes change."""
        index = self.signals.index(signal)
        return self.rewards[..., index : index + 1]

    def compute_returns(self, last_values: torch.Tensor) -> None:
        """GAE per signal over the rollout (``last_values``: of the observation after it, [envs,
        signals]); the storage's advantages are the signals' mean, normalised over the rollout when
        ``normalise_advantages``."""
        storage = self.storage
        advantage = torch.zeros_like(last_values)
        next_values = last_values
        for step in reversed(range(storage.num_transitions_per_env)):
            not_done = 1.0 - storage.dones[step].float()
            delta = self.rewards[step] + not_done * self.gamma * next_values - storage.values[step]
            advantage = delta + not_done * self.gamma * self.lam * advantage
            storage.returns[step] = advantage + storage.values[step]
            next_values = storage.values[step]
        advantages = (storage.returns - storage.values).mean(dim=-1, keepdim=True)
        if self.normalise_advantages:
            advantages = (advantages - advantages.mean()) / (advantages.std() + 1e-8)
        storage.advantages = advantages
