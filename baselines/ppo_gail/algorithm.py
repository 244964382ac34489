"""PPO + curiosity (ICM) + GAIL as an rsl-rl 5.5.1 algorithm.

This is the learning baseline of the study: PPO whose reward is shaped by two learned signals,

- an intrinsic curiosity reward from an Intrinsic Curiosity Module (Pathak et al. 2017; the study's Eq.
  4.23-4.28),
- an imitation reward from a GAIL discriminator trained on expert demonstrations (Ho & Ermon 2016; the study's
  §4.2.7).

It is a subclass of rsl-rl's ``PPO`` and plugs into the unmodified ``OnPolicyRunner`` through the algorithm
hooks the runner calls:

- ``process_env_step``: adds the curiosity and GAIL rewards of the transition (s_t, a_t, s_t+1) to the
  environment reward before PPO stores it (and before PPO's time-out bootstrapping, which does not care
  about the order);
- ``update``: trains the ICM and the discriminator on the rollout just collected, then runs the PPO update;
- ``save`` / ``load``: add the ICM and discriminator weights and optimiser states to the checkpoint dict.

The four ablations of the study are this one class with different flags, see ``ABLATIONS`` and
``runner_config.make_train_cfg``; ``reward_models`` holds the ICM and the discriminator.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor

import torch
from cabinbench.baselines.ppo_gail.demonstrations import load_demonstrations
from cabinbench.baselines.ppo_gail.mlagents import MlAgentsCuriosity, MlAgentsDiscriminator
from cabinbench.baselines.ppo_gail.normalisers import update_normalisers_once
from cabinbench.baselines.ppo_gail.reward_models import (
    CuriosityModel,
    GailDiscriminator,
    IntrinsicCuriosityModule,
)
from cabinbench.baselines.ppo_gail.signal_values import SignalValues, signal_names
from rsl_rl.algorithms import PPO
from rsl_rl.models import MLPModel
from rsl_rl.storage import RolloutStorage
from tensordict import TensorDict

# ----------------------------------------------------------------------------------------------------
# Configuration
# ----------------------------------------------------------------------------------------------------

ABLATIONS = {
    "ppo": {"use_curiosity": False, "use_gail": False},
    "ppo_icm": {"use_curiosity": True, "use_gail": False},
    "ppo_gail_only": {"use_curiosity": False, "use_gail": True},
    "ppo_gail": {"use_curiosity": True, "use_gail": True},
}
"""The study's ablations: which reward signals are added to PPO."""
REWARD_SIGNALS = tuple(ABLATIONS["ppo_gail"])  # ("use_curiosity", "use_gail")

FORMS = ("ours", "mlagents")
"""How the curiosity and the GAIL reward are computed: ours (``reward_models.py``) or Unity ML-Agents'
(``mlagents.py``), which the study ran."""

ACTION_LIMIT = 1.0
"""Actions are in [-1, 1] (the demonstration schema; the environment clips). PPO samples from an unbounded
Gaussian, so agent actions are clipped to this range before the ICM and the discriminator see them: they must
see the action that was executed, and an out-of-range action would let the discriminator spot the agent
trivially."""

STUDY_PPO = {
    "gamma": 0.99,
    "lam": 0.95,
    "clip_param": 0.2,
    "entropy_coef": 0.01,
    "learning_rate": 3.0e-4,
    "num_learning_epochs": 3,
}
"""PPO hyperparameters of the study (Table 5.2/5.3). ``make_train_cfg`` uses rsl-rl's "fixed" learning-rate
schedule, which keeps the study's initial 3e-4 (rsl-rl's default "adaptive" schedule would move it to track a
target KL); the study's ML-Agents decayed it linearly, which ``TrainConfig.learning_rate_schedule`` does.
All reward signals share the one discount ``gamma``, as Table 5.3 gives each 0.99."""


# ----------------------------------------------------------------------------------------------------
# The algorithm
# ----------------------------------------------------------------------------------------------------


class PPOCuriosityGail(PPO):
    """PPO whose reward is shaped by an ICM curiosity reward and a GAIL imitation reward.

    The reward PPO optimises for the transition (s_t, a_t, s_t+1) is

        r_t = r_env + curiosity_strength * surprise_t / std(surprise)
                    + gail_strength * (logit D(s_t, a_t) - mean logit)

    where the mean is over the rollout (``compute_returns``): the logit is negative wherever the discriminator
    tells the agent from the expert, nearly everywhere while it learns, so uncentred it pays the agent to end
    its episodes early. Centred, it ranks the agent's actions without paying it to live or to die (measured:
    docs/experiments.md, "GAIL reward centring"). That is the "ours" form of both terms; with
    ``curiosity_form="mlagents"`` / ``gail_form="mlagents"`` they are ML-Agents' (``mlagents.py``):
    ``clip(curiosity_strength * surprise_t, 0, 1) + gail_strength * -log(1 - D(s_t) + 1e-7)``.

    Either term is switched off by ``use_curiosity`` / ``use_gail``. Both modules see the concatenated
    observation groups of the actor (the policy observation, which is also what the demonstrations record), or
    the ``shaping_columns`` of it. The runner's logged episode reward stays the environment reward, so the
    ablations remain comparable.

    Args:
        actor, critic, storage: As for rsl-rl's ``PPO`` (built by ``PPO.construct_algorithm``).
        use_curiosity: Add the ICM curiosity reward.
        use_gail: Add the GAIL reward; requires ``expert_demonstrations``.
        curiosity_form: "ours" (``IntrinsicCuriosityModule``) or "mlagents" (``MlAgentsCuriosity``).
        curiosity_strength: eta, the scale of the curiosity reward (ours: of the std-normalised one).
        curiosity_forward_weight: beta, the ICM loss is (1 - beta) L_I + beta L_F (times the module's
            ``loss_multiplier``).
        curiosity_encoding_size: Size of the ICM feature vector phi(s).
        curiosity_hidden_dims: Hidden layers of our ICM's encoder, forward and inverse models (ML-Agents'
            are fixed, see ``mlagents.py``).
        curiosity_learning_rate: Adam learning rate of the ICM.
        gail_form: "ours" (``GailDiscriminator``) or "mlagents" (``MlAgentsDiscriminator``).
        gail_strength: Scale of the GAIL reward.
        gail_hidden_dims: Hidden layers of the discriminator.
        gail_use_actions: The discriminator sees the action beside the observation; ours always does,
            ML-Agents' by default not (the study's ``ppo_gail_study`` sets False).
        gail_gradient_penalty: Weight of the gradient penalty: ours the R1 penalty on expert samples, 1,
            lower than the 5-10 of least-squares discriminators (AMP), whose outputs are smaller than BCE
            logits (docs/experiments.md); ML-Agents' its WGAN-GP penalty, 10 (``GAIL_GRADIENT_PENALTY``).
        gail_learning_rate: Adam learning rate of the discriminator.
        expert_demonstrations: ``.npz`` files, see ``demonstrations.load_demonstrations``.
        expected_observation_config: The environment's observation layout; demonstrations recorded with
            another layout are rejected.
        shaping_columns: The columns of the policy observation that the ICM and the discriminator see
            (None: all of it). Training leaves out the coverage patch: the expert's patches show its own
            sweep, which the discriminator would tell from the agent's by the patch alone, whatever the
            agent does.
        shaping_epochs: Epochs of the ICM and discriminator updates per iteration, over PPO's mini-batches
            (None: PPO's ``num_learning_epochs``).
        shaping_update_threads: Threads that train the ICM and the discriminator while PPO trains (the
            other cores' work; torch runs its kernels outside Python's lock): with one, the ICM trains in
            it and the discriminator after PPO, which balances the two cores (docs/experiments.md); with two,
            each in a thread of its own; 0: all in turn. The results do not change: every random draw of
            their updates is made before PPO's, in the order of the sequential update, and each module
            only reads the rollout and writes its own weights.
        value_per_signal: A value head per reward signal, the extrinsic value alone zeroed where an episode
            ends, as ML-Agents' PPO has it (``signal_values.py``); False: one value of the summed reward.
        ppo_kwargs: Passed to ``PPO`` (gamma, lam, learning_rate, ..., device, multi_gpu_cfg).
    """

    def __init__(
        self,
        actor: MLPModel,
        critic: MLPModel,
        storage: RolloutStorage,
        *,
        use_curiosity: bool = True,
        use_gail: bool = True,
        curiosity_form: str = "ours",
        curiosity_strength: float = 0.02,
        curiosity_forward_weight: float = 0.2,
        curiosity_encoding_size: int = 256,
        curiosity_hidden_dims: Sequence[int] = (256,),
        curiosity_learning_rate: float = 3.0e-4,
        gail_form: str = "ours",
        gail_strength: float = 0.3,
        gail_hidden_dims: Sequence[int] = (128, 128),
        gail_use_actions: bool = True,
        gail_gradient_penalty: float = 1.0,
        gail_learning_rate: float = 3.0e-4,
        expert_demonstrations: Sequence[str | os.PathLike] = (),
        expected_observation_config: dict | str | None = None,
        shaping_columns: Sequence[int] | None = None,
        shaping_epochs: int | None = None,
        shaping_update_threads: int = 0,
        value_per_signal: bool = False,
        **ppo_kwargs,
    ) -> None:
        """Build PPO and the enabled reward modules (the arguments: see the class docstring)."""
        super().__init__(actor, critic, storage, **ppo_kwargs)
        update_normalisers_once(self._raw_actor, self._raw_critic)
        if self.is_multi_gpu and (use_curiosity or use_gail):
            raise NotImplementedError(
                "PPOCuriosityGail does not synchronise the ICM and discriminator across GPUs."
            )

        for name, form in (("curiosity_form", curiosity_form), ("gail_form", gail_form)):
            if form not in FORMS:
                raise ValueError(f"{name} must be one of {', '.join(FORMS)}, got {form!r}")
        if gail_form == "ours" and not gail_use_actions:
            raise ValueError('gail_use_actions=False needs gail_form="mlagents": our D(s, a) sees the action')
        self.curiosity_strength = curiosity_strength
        self.curiosity_forward_weight = curiosity_forward_weight
        self.gail_strength = gail_strength
        self.gail_gradient_penalty = gail_gradient_penalty
        self.shaping_epochs = self.num_learning_epochs if shaping_epochs is None else shaping_epochs
        if self.shaping_epochs < 1:
            raise ValueError(f"shaping_epochs must be positive, got {shaping_epochs}")

        self.shaping_columns = (
            None if shaping_columns is None else torch.as_tensor(shaping_columns, device=self.device)
        )
        # (observations, their shaping part, its ICM encoding) of the last step's s_t+1: the next step's s_t
        self._encoded_next_states: tuple[TensorDict, torch.Tensor, torch.Tensor] | None = None
        self.curiosity: CuriosityModel | None = None
        if use_curiosity:
            self._build_curiosity(
                curiosity_form, curiosity_encoding_size, curiosity_hidden_dims, curiosity_learning_rate
            )
        self.discriminator: GailDiscriminator | MlAgentsDiscriminator | None = None
        if use_gail:
            if not expert_demonstrations:
                raise ValueError("use_gail=True needs expert_demonstrations (a list of .npz files).")
            self._load_demonstrations(expert_demonstrations, expected_observation_config)
            action_dim = self.storage.actions.shape[-1]
            self.discriminator = (
                GailDiscriminator(self._shaping_dim, action_dim, gail_hidden_dims)
                if gail_form == "ours"
                else MlAgentsDiscriminator(self._shaping_dim, action_dim, gail_hidden_dims, gail_use_actions)
            ).to(self.device)
            self.discriminator_optimizer = torch.optim.Adam(
                self.discriminator.parameters(), lr=gail_learning_rate
            )
            self.gail_rewards = torch.zeros(self._rollout_shape, device=self.device)
        self.signal_values: SignalValues | None = None
        if value_per_signal:  # ML-Agents' critic
            self.signal_values = SignalValues.for_algorithm(self, signal_names(use_curiosity, use_gail))
        shaping_modules = (self.curiosity is not None) + (self.discriminator is not None)
        self.threaded_updates = min(shaping_update_threads, shaping_modules)
        self.shaping_threads = _update_threads(self.threaded_updates)

    @property
    def _observation_dim(self) -> int:
        """Size of the actor's observation groups together (what the demonstrations record)."""
        return sum(self.storage.observations[group].shape[-1] for group in self._raw_actor.obs_groups)

    @property
    def _shaping_dim(self) -> int:
        """Size of what the ICM and the discriminator see of an observation."""
        return self._observation_dim if self.shaping_columns is None else len(self.shaping_columns)

    @property
    def _rollout_shape(self) -> tuple[int, int]:
        return (self.storage.num_transitions_per_env, self.storage.num_envs)

    def _build_curiosity(
        self, form: str, encoding_size: int, hidden_dims: Sequence[int], learning_rate: float
    ) -> None:
        action_dim = self.storage.actions.shape[-1]
        self.curiosity = (
            IntrinsicCuriosityModule(self._shaping_dim, action_dim, encoding_size, hidden_dims)
            if form == "ours"
            else MlAgentsCuriosity(self._shaping_dim, action_dim, encoding_size)
        ).to(self.device)
        self.curiosity_optimizer = torch.optim.Adam(self.curiosity.parameters(), lr=learning_rate)
        # s_t+1 of each stored transition; RolloutStorage keeps only s_t. Allocated here, outside the
        # runner's inference mode, so the buffer can be used for training.
        self.next_states = torch.zeros(*self._rollout_shape, self._shaping_dim, device=self.device)
        self.curiosity_rewards = torch.zeros(self._rollout_shape, device=self.device)

    def _load_demonstrations(
        self,
        expert_demonstrations: Sequence[str | os.PathLike],
        expected_observation_config: dict | str | None,
    ) -> None:
        """The expert's (observation, action) pairs, the observations restricted to ``shaping_columns``."""
        expert_observations, expert_actions = load_demonstrations(
            expert_demonstrations,
            self._observation_dim,
            self.storage.actions.shape[-1],
            expected_observation_config,
        )
        self.expert_observations = self._shaping_part(expert_observations.to(self.device))
        self.expert_actions = expert_actions.to(self.device)

    # --- Rollout --------------------------------------------------------------------------------------------

    def process_env_step(
        self, obs: TensorDict, rewards: torch.Tensor, dones: torch.Tensor, extras: dict[str, torch.Tensor]
    ) -> None:
        """Add the curiosity and GAIL rewards of this step, then let PPO record the transition.

        ``self.transition`` still holds s_t and a_t, recorded by ``act``; ``obs`` is s_t+1 except for
        environments that are done, whose ``obs`` is already the first observation of their next episode. The
        curiosity reward depends on s_t+1 and is therefore zero for done environments; the GAIL reward depends
        only on (s_t, a_t).
        """
        step = self.storage.step
        # s_t is the previous step's s_t+1 (the same observations, done envs' included): its shaping part and
        # encoding are reused, which gives the same numbers as computing them again
        previous = self._encoded_next_states
        reused = previous is not None and previous[0] is self.transition.observations
        states = previous[1] if reused else self._shaping_observation(self.transition.observations)
        actions = self.transition.actions.clamp(-ACTION_LIMIT, ACTION_LIMIT)
        # not modified in place: the runner logs the environment reward after this call
        signal_rewards = {"extrinsic": rewards}

        if self.curiosity is not None:
            next_states = self._shaping_observation(obs)
            features = previous[2] if reused else self.curiosity.encoder(states)
            next_features = self.curiosity.encoder(next_states)
            self._encoded_next_states = (obs, next_states, next_features)
            not_done = dones == 0
            curiosity_rewards = self.curiosity.reward(
                states, actions, next_states, not_done, self.curiosity_strength, features, next_features
            )
            self.next_states[step].copy_(next_states)
            self.curiosity_rewards[step].copy_(curiosity_rewards)
            signal_rewards["curiosity"] = curiosity_rewards

        if self.discriminator is not None:
            gail_rewards = self.gail_strength * self.discriminator.reward(states, actions)
            self.gail_rewards[step].copy_(gail_rewards)
            signal_rewards["gail"] = gail_rewards

        if self.signal_values is not None:  # the returns read its rewards, bootstrapped; PPO stores the rest
            self.signal_values.record(step, signal_rewards, self.transition.values, dones, extras)
            signal_rewards = {"extrinsic": rewards}
            extras = {key: value for key, value in extras.items() if key != "time_outs"}
        super().process_env_step(obs, sum(signal_rewards.values()), dones, extras)

    def compute_returns(self, obs: TensorDict) -> None:
        if self.discriminator is not None and self.discriminator.centred_reward:  # see the class docstring
            rewards = self.storage.rewards if self.signal_values is None else self.signal_values.of("gail")
            rewards -= self.gail_rewards.mean()
        if self.signal_values is None:
            return super().compute_returns(obs)
        self.signal_values.compute_returns(self.critic(obs).detach())

    # --- Learning -------------------------------------------------------------------------------------------

    def update(self) -> dict[str, float]:
        """Train the ICM and the discriminator on the collected rollout, and run the PPO update.

        Returns PPO's losses plus ``curiosity_forward``, ``curiosity_inverse``, ``curiosity_reward`` and
        ``gail_discriminator``, ``gail_gradient_penalty``, ``gail_accuracy``, ``gail_reward`` (rewards: mean
        per step) for the enabled modules; the runner logs them all under ``Loss/``.
        """
        self._encoded_next_states = None  # the ICM's weights change
        shaping_updates: list[Callable[[], dict[str, float]]] = []
        if self.curiosity is not None or self.discriminator is not None:
            states = self._shaping_observation(self.storage.observations).flatten(0, 1)
            actions = self.storage.actions.flatten(0, 1).clamp(-ACTION_LIMIT, ACTION_LIMIT)
        # The mini-batches are drawn here, before PPO draws its own, so threads give the same updates.
        if self.curiosity is not None:
            # Transitions into a reset observation carry no information about the dynamics.
            not_done = (self.storage.dones == 0).flatten()
            curiosity_data = (states[not_done], actions[not_done], self.next_states.flatten(0, 1)[not_done])
            curiosity_batches = [
                batch
                for _ in range(self.shaping_epochs)
                for batch in self._shuffled_batches(int(not_done.sum()))
            ]
            curiosity_reward = self.curiosity_rewards.mean().item()
            shaping_updates.append(
                lambda: (
                    self.update_curiosity(*curiosity_data, curiosity_batches)
                    | {"curiosity_reward": curiosity_reward}
                )
            )
        if self.discriminator is not None:
            agent_batches, expert_batches, loss_noises = [], [], []
            for _ in range(self.shaping_epochs):
                for batch in self._shuffled_batches(states.shape[0]):
                    agent_batches.append(batch)
                    expert_batches.append(
                        torch.randint(self.expert_observations.shape[0], (batch.numel(),), device=self.device)
                    )
                    loss_noises.append(self.discriminator.loss_noise(batch.numel()))
            gail_reward = self.gail_rewards.mean().item()
            shaping_updates.append(
                lambda: (
                    self.update_discriminator(states, actions, agent_batches, expert_batches, loss_noises)
                    | {"gail_reward": gail_reward}
                )
            )

        if self.shaping_threads:  # the first (the ICM, the heaviest) in threads, the others after PPO
            threaded = self.threaded_updates
            beside = [self.shaping_threads.submit(update) for update in shaping_updates[:threaded]]
            shaping_updates = [future.result for future in beside] + shaping_updates[threaded:]
        ppo_losses = super().update()  # it reads what the shaping updates read, and writes none of it
        extra_losses = {}
        for shaping_update in shaping_updates:  # of a thread: its result, once it is done
            extra_losses |= shaping_update()
        return ppo_losses | extra_losses

    def update_curiosity(
        self,
        states: torch.Tensor,
        actions: torch.Tensor,
        next_states: torch.Tensor,
        batches: Sequence[torch.Tensor],
    ) -> dict[str, float]:
        """Minimise (1 - beta) L_I + beta L_F (Pathak et al. 2017, Eq. 7) times the module's
        ``loss_multiplier``, one optimiser step per mini-batch of ``batches`` (transitions' indices)."""
        forward_losses, inverse_losses = [], []
        for batch in batches:
            forward_loss, inverse_loss = self.curiosity.losses(
                states[batch], actions[batch], next_states[batch]
            )
            beta = self.curiosity_forward_weight
            loss = self.curiosity.loss_multiplier * ((1.0 - beta) * inverse_loss + beta * forward_loss)
            self.curiosity_optimizer.zero_grad()
            loss.backward()
            self.curiosity_optimizer.step()
            forward_losses.append(forward_loss.item())
            inverse_losses.append(inverse_loss.item())
        return {"curiosity_forward": _mean(forward_losses), "curiosity_inverse": _mean(inverse_losses)}

    def update_discriminator(
        self,
        states: torch.Tensor,
        actions: torch.Tensor,
        batches: Sequence[torch.Tensor],
        expert_batches: Sequence[torch.Tensor],
        loss_noises: Sequence[torch.Tensor | None],
    ) -> dict[str, float]:
        """Train D to tell expert pairs (label 1) from the agent's (label 0), one optimiser step per agent
        mini-batch of ``batches``, each paired with the expert pairs of ``expert_batches`` (as many) and the
        random numbers of ``loss_noises`` (the discriminator's ``loss_noise``)."""
        bce_losses, penalties, accuracies = [], [], []
        for batch, expert, noise in zip(batches, expert_batches, loss_noises, strict=True):
            bce, gradient_penalty, accuracy = self.discriminator.losses(
                states[batch],
                actions[batch],
                self.expert_observations[expert],
                self.expert_actions[expert],
                noise,
            )
            loss = bce + self.gail_gradient_penalty * gradient_penalty
            self.discriminator_optimizer.zero_grad()
            loss.backward()
            self.discriminator_optimizer.step()
            bce_losses.append(bce.item())
            penalties.append(gradient_penalty.item())
            accuracies.append(accuracy.item())
        return {
            "gail_discriminator": _mean(bce_losses),
            "gail_gradient_penalty": _mean(penalties),
            "gail_accuracy": _mean(accuracies),
        }

    # --- Checkpoints ----------------------------------------------------------------------------------------

    def save(self) -> dict:
        """PPO's checkpoint dict plus the ICM and discriminator weights and optimiser states.

        Everything added is a state dict of tensors and plain numbers, so the checkpoint loads with
        ``torch.load(..., weights_only=True)``.
        """
        saved = super().save()
        if self.curiosity is not None:
            saved["curiosity_state_dict"] = self.curiosity.state_dict()
            saved["curiosity_optimizer_state_dict"] = self.curiosity_optimizer.state_dict()
        if self.discriminator is not None:
            saved["discriminator_state_dict"] = self.discriminator.state_dict()
            saved["discriminator_optimizer_state_dict"] = self.discriminator_optimizer.state_dict()
        return saved

    def load(self, loaded_dict: dict, load_cfg: dict | None, strict: bool) -> bool:
        """Load what ``save`` wrote. ``load_cfg`` takes the keys of ``PPO.load`` plus ``curiosity`` and
        ``discriminator`` (each loads weights and optimiser state); ``None`` loads everything."""
        load_iteration = super().load(loaded_dict, load_cfg, strict)
        self._encoded_next_states = None
        if self.curiosity is not None and (load_cfg is None or load_cfg.get("curiosity")):
            self.curiosity.load_state_dict(loaded_dict["curiosity_state_dict"], strict=strict)
            self.curiosity_optimizer.load_state_dict(loaded_dict["curiosity_optimizer_state_dict"])
        if self.discriminator is not None and (load_cfg is None or load_cfg.get("discriminator")):
            self.discriminator.load_state_dict(loaded_dict["discriminator_state_dict"], strict=strict)
            self.discriminator_optimizer.load_state_dict(loaded_dict["discriminator_optimizer_state_dict"])
        return load_iteration

    # --- Helpers --------------------------------------------------------------------------------------------

    def _shaping_observation(self, obs: TensorDict) -> torch.Tensor:
        """What the ICM and D see of an observation: the actor's observation groups concatenated (the
        observation the demonstrations record), restricted to ``shaping_columns``."""
        return self._shaping_part(torch.cat([obs[group] for group in self._raw_actor.obs_groups], dim=-1))

    def _shaping_part(self, observations: torch.Tensor) -> torch.Tensor:
        return observations if self.shaping_columns is None else observations[..., self.shaping_columns]

    def _shuffled_batches(self, num_samples: int) -> tuple[torch.Tensor, ...]:
        """One epoch's mini-batches: shuffled indices split into PPO's number of mini-batches."""
        return torch.randperm(num_samples, device=self.device).chunk(self.num_mini_batches)


def _update_threads(count: int) -> ThreadPoolExecutor | None:
    """``count`` threads (None for 0) that run torch on as many threads as this one: torch's thread count
    holds for the thread that set it, and a new thread would run its kernels on OpenMP's default of every
    core, spinning against PPO's (3x slower on 2 cores)."""
    if not count:
        return None
    return ThreadPoolExecutor(count, initializer=torch.set_num_threads, initargs=(torch.get_num_threads(),))


def _mean(values: list[float]) -> float:
    """Arithmetic mean of per-mini-batch losses, for logging."""
    return sum(values) / len(values)
