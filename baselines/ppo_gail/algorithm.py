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
``make_train_cfg``.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor

import torch
import torch.nn as nn
import torch.nn.functional as F
from cabinbench.baselines.ppo_gail.demonstrations import load_demonstrations
from rsl_rl.algorithms import PPO
from rsl_rl.models import MLPModel
from rsl_rl.modules import MLP
from rsl_rl.storage import RolloutStorage
from tensordict import TensorDict

# ----------------------------------------------------------------------------------------------------
# Configuration
# ----------------------------------------------------------------------------------------------------

ALGORITHM_CLASS_NAME = "cabinbench.baselines.ppo_gail.algorithm:PPOCuriosityGail"

ABLATIONS = {
    "ppo": {"use_curiosity": False, "use_gail": False},
    "ppo_icm": {"use_curiosity": True, "use_gail": False},
    "ppo_gail_only": {"use_curiosity": False, "use_gail": True},
    "ppo_gail": {"use_curiosity": True, "use_gail": True},
}
"""The study's ablations: which reward signals are added to PPO."""
REWARD_SIGNALS = tuple(ABLATIONS["ppo_gail"])  # ("use_curiosity", "use_gail")

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
All reward signals share the one discount ``gamma``: rsl-rl's storage holds a single reward stream."""


# ----------------------------------------------------------------------------------------------------
# Intrinsic Curiosity Module
# ----------------------------------------------------------------------------------------------------


class RunningStd(nn.Module):
    """Running standard deviation of a scalar stream (parallel-variance update of Chan et al.).

    Updates are in-place on the buffers: the runner collects rollouts under ``torch.inference_mode``, and
    in-place updates keep the buffers ordinary tensors that can later be saved, loaded and used outside
    inference mode.
    """

    def __init__(self) -> None:
        super().__init__()
        # float64: the sample count grows past the integers float32 represents exactly.
        self.register_buffer("count", torch.zeros((), dtype=torch.float64))
        self.register_buffer("mean", torch.zeros((), dtype=torch.float64))
        self.register_buffer("var", torch.ones((), dtype=torch.float64))

    def update(self, values: torch.Tensor) -> None:
        """Fold a batch of values into the running mean and variance."""
        if values.numel() == 0:
            return
        values = values.double()
        batch_count = values.numel()
        batch_mean = values.mean()
        batch_var = values.var(unbiased=False)
        total = self.count + batch_count
        delta = batch_mean - self.mean
        sum_sq = (
            self.var * self.count
            + batch_var * batch_count
            + delta.square() * self.count * batch_count / total
        )
        self.mean.copy_(self.mean + delta * batch_count / total)
        self.var.copy_(sum_sq / total)
        self.count.copy_(total)

    @property
    def std(self) -> torch.Tensor:
        """The running standard deviation as float32."""
        return self.var.sqrt().float()


class IntrinsicCuriosityModule(nn.Module):
    """Intrinsic Curiosity Module (Pathak et al. 2017, §2.2; the study's Eq. 4.23-4.28).

    - Feature encoder phi(s).
    - Inverse model g(phi(s_t), phi(s_t+1)) -> a_hat_t, loss L_I = ||a_hat_t - a_t||^2 (continuous actions:
      squared error instead of the paper's cross-entropy over discrete actions).
    - Forward model f(phi(s_t), a_t) -> phi_hat(s_t+1), loss L_F = 1/2 ||phi_hat(s_t+1) - phi(s_t+1)||^2.
    - Surprise 1/2 ||phi_hat(s_t+1) - phi(s_t+1)||^2, the intrinsic reward before scaling by eta.

    The encoder is trained by both losses, as in Pathak's reference implementation; the (1 - beta) weight on
    the inverse loss keeps phi informative about the action instead of collapsing to what is easy to predict.
    """

    def __init__(
        self,
        observation_dim: int,
        action_dim: int,
        encoding_size: int,
        hidden_dims: Sequence[int],
        activation: str = "elu",
    ) -> None:
        super().__init__()
        self.encoder = MLP(observation_dim, encoding_size, hidden_dims, activation)
        self.forward_model = MLP(encoding_size + action_dim, encoding_size, hidden_dims, activation)
        self.inverse_model = MLP(2 * encoding_size, action_dim, hidden_dims, activation)
        # The raw surprise scales with the size and drift of the learned features, which are arbitrary.
        # Dividing it by its running std keeps the reward in units of "typical surprise", so that
        # curiosity_strength means the same thing across environments and over training (as the RND reward
        # normalisation of Burda et al. 2018 does).
        self.surprise_std = RunningStd()

    def losses(
        self, states: torch.Tensor, actions: torch.Tensor, next_states: torch.Tensor
    ) -> tuple[torch.Tensor, torch.Tensor]:
        """Return the batch means of the forward loss L_F and the inverse loss L_I."""
        features = self.encoder(states)
        next_features = self.encoder(next_states)
        predicted_next_features = self.forward_model(torch.cat([features, actions], dim=-1))
        predicted_actions = self.inverse_model(torch.cat([features, next_features], dim=-1))
        forward_loss = 0.5 * (predicted_next_features - next_features).square().sum(dim=-1).mean()
        inverse_loss = (predicted_actions - actions).square().sum(dim=-1).mean()
        return forward_loss, inverse_loss

    @torch.no_grad()
    def normalized_surprise(
        self, states: torch.Tensor, actions: torch.Tensor, next_states: torch.Tensor, valid: torch.Tensor
    ) -> torch.Tensor:
        """Surprise of each transition divided by its running std; zero where ``valid`` is False.

        ``valid`` marks transitions whose ``next_states`` really follow ``states``. For an environment that is
        done, the runner hands over the first observation of the next episode, whose prediction error is
        meaningless; it is neither rewarded nor counted in the running std.
        """
        next_features = self.encoder(next_states)
        predicted_next_features = self.forward_model(torch.cat([self.encoder(states), actions], dim=-1))
        surprise = 0.5 * (predicted_next_features - next_features).square().sum(dim=-1)
        self.surprise_std.update(surprise[valid])
        return surprise / self.surprise_std.std.clamp_min(1e-8) * valid


# ----------------------------------------------------------------------------------------------------
# GAIL discriminator
# ----------------------------------------------------------------------------------------------------


class GailDiscriminator(nn.Module):
    """GAIL discriminator D(s, a) = sigmoid(logit(s, a)) (Ho & Ermon 2016; the study's §4.2.7).

    Trained to output 1 on expert pairs and 0 on agent pairs (Ho & Ermon use the opposite labels; only the
    sign of the reward depends on it). The reward is the logit, log D - log(1 - D): positive where the agent
    looks like the expert, negative where it does not. The more common -log(1 - D) is always positive, i.e. a
    bonus for every step survived, and episodes here end on success, so it would teach the agent not to
    finish. The flip side: where an episode can end in failure (a crash), a mostly negative GAIL reward makes
    ending early attractive unless the environment penalises the failure.
    """

    def __init__(
        self, observation_dim: int, action_dim: int, hidden_dims: Sequence[int], activation: str = "elu"
    ):
        super().__init__()
        self.network = MLP(observation_dim + action_dim, 1, hidden_dims, activation)

    def logits(self, states: torch.Tensor, actions: torch.Tensor) -> torch.Tensor:
        """Return logit(s, a) = log D(s, a) - log(1 - D(s, a)), shape [B]."""
        return self.network(torch.cat([states, actions], dim=-1)).squeeze(-1)

    @torch.no_grad()
    def reward(self, states: torch.Tensor, actions: torch.Tensor) -> torch.Tensor:
        """Return the unscaled GAIL reward log D - log(1 - D) of each pair."""
        return self.logits(states, actions)

    def losses(
        self,
        agent_states: torch.Tensor,
        agent_actions: torch.Tensor,
        expert_states: torch.Tensor,
        expert_actions: torch.Tensor,
    ) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        """Return the BCE loss, the gradient penalty and the classification accuracy on one batch.

        The gradient penalty is the zero-centred R1 penalty E_expert ||grad_(s,a) logit||^2 (Mescheder et al.
        2018). It keeps the discriminator from becoming arbitrarily sharp around the expert data, which would
        make the reward a cliff that carries no gradient information for the policy.
        """
        expert_inputs = torch.cat([expert_states, expert_actions], dim=-1).requires_grad_(True)
        expert_logits = self.network(expert_inputs).squeeze(-1)
        agent_logits = self.logits(agent_states, agent_actions)
        bce = F.binary_cross_entropy_with_logits(
            expert_logits, torch.ones_like(expert_logits)
        ) + F.binary_cross_entropy_with_logits(agent_logits, torch.zeros_like(agent_logits))
        (input_gradient,) = torch.autograd.grad(expert_logits.sum(), expert_inputs, create_graph=True)
        gradient_penalty = input_gradient.square().sum(dim=-1).mean()
        accuracy = 0.5 * ((expert_logits > 0).float().mean() + (agent_logits < 0).float().mean())
        return bce, gradient_penalty, accuracy.detach()


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
    docs/experiments.md, "GAIL reward centring").

    Either term is switched off by ``use_curiosity`` / ``use_gail``. Both modules see the concatenated
    observation groups of the actor (the policy observation, which is also what the demonstrations record), or
    the ``shaping_columns`` of it. The runner's logged episode reward stays the environment reward, so the
    ablations remain comparable.
    """

    def __init__(
        self,
        actor: MLPModel,
        critic: MLPModel,
        storage: RolloutStorage,
        *,
        use_curiosity: bool = True,
        use_gail: bool = True,
        curiosity_strength: float = 0.02,
        curiosity_forward_weight: float = 0.2,
        curiosity_encoding_size: int = 256,
        curiosity_hidden_dims: Sequence[int] = (256,),
        curiosity_learning_rate: float = 3.0e-4,
        gail_strength: float = 0.3,
        gail_hidden_dims: Sequence[int] = (128, 128),
        gail_gradient_penalty: float = 1.0,
        gail_learning_rate: float = 3.0e-4,
        expert_demonstrations: Sequence[str | os.PathLike] = (),
        expected_observation_config: dict | str | None = None,
        shaping_columns: Sequence[int] | None = None,
        shaping_epochs: int | None = None,
        shaping_update_threads: bool = False,
        **ppo_kwargs,
    ) -> None:
        """Build PPO and the enabled reward modules.

        Args:
            actor, critic, storage: As for rsl-rl's ``PPO`` (built by ``PPO.construct_algorithm``).
            use_curiosity: Add the ICM curiosity reward.
            use_gail: Add the GAIL reward; requires ``expert_demonstrations``.
            curiosity_strength: eta, the scale of the (std-normalised) curiosity reward.
            curiosity_forward_weight: beta, the ICM loss is (1 - beta) L_I + beta L_F.
            curiosity_encoding_size: Size of the ICM feature vector phi(s).
            curiosity_hidden_dims: Hidden layers of the ICM encoder, forward and inverse models.
            curiosity_learning_rate: Adam learning rate of the ICM.
            gail_strength: Scale of the GAIL reward.
            gail_hidden_dims: Hidden layers of the discriminator.
            gail_gradient_penalty: Weight of the R1 gradient penalty on expert samples; lower than the 5-10
                of least-squares discriminators (AMP), whose outputs are smaller than BCE logits
                (docs/experiments.md).
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
            shaping_update_threads: Train the ICM and the discriminator each in a thread of its own while
                PPO trains (the other cores' work; torch runs its kernels outside Python's lock). The results
                do not change: every random draw of their updates is made before PPO's, in the order of the
                sequential update, and each module only reads the rollout and writes its own weights.
            ppo_kwargs: Passed to ``PPO`` (gamma, lam, learning_rate, ..., device, multi_gpu_cfg).
        """
        super().__init__(actor, critic, storage, **ppo_kwargs)
        if self.is_multi_gpu and (use_curiosity or use_gail):
            raise NotImplementedError(
                "PPOCuriosityGail does not synchronise the ICM and discriminator across GPUs."
            )

        self.curiosity_strength = curiosity_strength
        self.curiosity_forward_weight = curiosity_forward_weight
        self.gail_strength = gail_strength
        self.gail_gradient_penalty = gail_gradient_penalty
        self.shaping_epochs = self.num_learning_epochs if shaping_epochs is None else shaping_epochs
        if self.shaping_epochs < 1:
            raise ValueError(f"shaping_epochs must be positive, got {shaping_epochs}")

        observation_dim = sum(storage.observations[group].shape[-1] for group in self._raw_actor.obs_groups)
        self.shaping_columns = (
            None if shaping_columns is None else torch.as_tensor(shaping_columns, device=self.device)
        )
        shaping_dim = observation_dim if shaping_columns is None else len(shaping_columns)
        action_dim = storage.actions.shape[-1]
        rollout_shape = (storage.num_transitions_per_env, storage.num_envs)

        self.curiosity: IntrinsicCuriosityModule | None = None
        if use_curiosity:
            self.curiosity = IntrinsicCuriosityModule(
                shaping_dim, action_dim, curiosity_encoding_size, curiosity_hidden_dims
            ).to(self.device)
            self.curiosity_optimizer = torch.optim.Adam(
                self.curiosity.parameters(), lr=curiosity_learning_rate
            )
            # s_t+1 of each stored transition; RolloutStorage keeps only s_t. Allocated here, outside the
            # runner's inference mode, so the buffer can be used for training.
            self.next_states = torch.zeros(*rollout_shape, shaping_dim, device=self.device)
            self.curiosity_rewards = torch.zeros(rollout_shape, device=self.device)

        self.discriminator: GailDiscriminator | None = None
        if use_gail:
            if not expert_demonstrations:
                raise ValueError("use_gail=True needs expert_demonstrations (a list of .npz files).")
            expert_observations, expert_actions = load_demonstrations(
                expert_demonstrations, observation_dim, action_dim, expected_observation_config
            )
            self.expert_observations = self._shaping_part(expert_observations.to(self.device))
            self.expert_actions = expert_actions.to(self.device)
            self.discriminator = GailDiscriminator(shaping_dim, action_dim, gail_hidden_dims).to(self.device)
            self.discriminator_optimizer = torch.optim.Adam(
                self.discriminator.parameters(), lr=gail_learning_rate
            )
            self.gail_rewards = torch.zeros(rollout_shape, device=self.device)

        shaping_modules = (self.curiosity is not None) + (self.discriminator is not None)
        self.shaping_threads = (
            ThreadPoolExecutor(shaping_modules) if shaping_update_threads and shaping_modules else None
        )

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
        states = self._shaping_observation(self.transition.observations)
        actions = self.transition.actions.clamp(-ACTION_LIMIT, ACTION_LIMIT)
        # not modified in place: the runner logs the environment reward after this call
        shaped_rewards = rewards

        if self.curiosity is not None:
            next_states = self._shaping_observation(obs)
            not_done = dones == 0
            curiosity_rewards = self.curiosity_strength * self.curiosity.normalized_surprise(
                states, actions, next_states, not_done
            )
            self.next_states[step].copy_(next_states)
            self.curiosity_rewards[step].copy_(curiosity_rewards)
            shaped_rewards = shaped_rewards + curiosity_rewards

        if self.discriminator is not None:
            gail_rewards = self.gail_strength * self.discriminator.reward(states, actions)
            self.gail_rewards[step].copy_(gail_rewards)
            shaped_rewards = shaped_rewards + gail_rewards

        super().process_env_step(obs, shaped_rewards, dones, extras)

    def compute_returns(self, obs: TensorDict) -> None:
        if self.discriminator is not None:
            self.storage.rewards -= self.gail_rewards.mean()  # centred: see the class docstring
        super().compute_returns(obs)

    # --- Learning -------------------------------------------------------------------------------------------

    def update(self) -> dict[str, float]:
        """Train the ICM and the discriminator on the collected rollout, and run the PPO update.

        Returns PPO's losses plus ``curiosity_forward``, ``curiosity_inverse``, ``curiosity_reward`` (mean per
        step) and ``gail_discriminator``, ``gail_gradient_penalty``, ``gail_accuracy``, ``gail_reward`` (mean
        per step) for the enabled modules; the runner logs them all under ``Loss/``.
        """
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
            agent_batches, expert_batches = [], []
            for _ in range(self.shaping_epochs):
                for batch in self._shuffled_batches(states.shape[0]):
                    agent_batches.append(batch)
                    expert_batches.append(
                        torch.randint(self.expert_observations.shape[0], (batch.numel(),), device=self.device)
                    )
            gail_reward = self.gail_rewards.mean().item()
            shaping_updates.append(
                lambda: (
                    self.update_discriminator(states, actions, agent_batches, expert_batches)
                    | {"gail_reward": gail_reward}
                )
            )

        if self.shaping_threads:
            beside = [self.shaping_threads.submit(shaping_update) for shaping_update in shaping_updates]
            shaping_updates = [future.result for future in beside]
        ppo_losses = super().update()  # it reads what the shaping updates read, and writes none of it
        extra_losses = {}
        for shaping_update in shaping_updates:  # with threads: their results, once they are done
            extra_losses |= shaping_update()
        return ppo_losses | extra_losses

    def update_curiosity(
        self,
        states: torch.Tensor,
        actions: torch.Tensor,
        next_states: torch.Tensor,
        batches: Sequence[torch.Tensor],
    ) -> dict[str, float]:
        """Minimise (1 - beta) L_I + beta L_F (Pathak et al. 2017, Eq. 7), one optimiser step per mini-batch
        of ``batches`` (indices of the transitions)."""
        forward_losses, inverse_losses = [], []
        for batch in batches:
            forward_loss, inverse_loss = self.curiosity.losses(
                states[batch], actions[batch], next_states[batch]
            )
            beta = self.curiosity_forward_weight
            loss = (1.0 - beta) * inverse_loss + beta * forward_loss
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
    ) -> dict[str, float]:
        """Train D to tell expert pairs (label 1) from the agent's (label 0), one optimiser step per agent
        mini-batch of ``batches``, each paired with the expert pairs of ``expert_batches`` (as many)."""
        bce_losses, penalties, accuracies = [], [], []
        for batch, expert in zip(batches, expert_batches, strict=True):
            bce, gradient_penalty, accuracy = self.discriminator.losses(
                states[batch], actions[batch], self.expert_observations[expert], self.expert_actions[expert]
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


def _mean(values: list[float]) -> float:
    """Arithmetic mean of per-mini-batch losses, for logging."""
    return sum(values) / len(values)


# ----------------------------------------------------------------------------------------------------
# Runner configuration
# ----------------------------------------------------------------------------------------------------


def make_train_cfg(
    variant: str = "ppo_gail",
    *,
    expert_demonstrations: str | os.PathLike | Sequence[str | os.PathLike] = (),
    expected_observation_config: dict | str | None = None,
    num_steps_per_env: int = 64,
    num_mini_batches: int = 4,
    learning_rate: float = STUDY_PPO["learning_rate"],
    schedule: str = "fixed",
    hidden_dims: Sequence[int] = (64, 64),
    activation: str = "elu",
    init_noise_std: float = 1.0,
    obs_normalization: bool = True,
    obs_groups: dict[str, list[str]] | None = None,
    save_interval: int = 50,
    **algorithm_kwargs,
) -> dict:
    """Build the rsl-rl 5.5.1 ``train_cfg`` for ``OnPolicyRunner(env, train_cfg, log_dir, device)``.

    Args:
        variant: One of ``ABLATIONS``: "ppo", "ppo_icm", "ppo_gail_only" or "ppo_gail".
        expert_demonstrations: ``.npz`` file(s); needed by the GAIL variants.
        expected_observation_config: The environment's observation layout, checked against the demonstrations.
        num_steps_per_env: Rollout length per environment and iteration.
        num_mini_batches: Mini-batches per epoch (PPO, ICM and discriminator alike).
        learning_rate: PPO learning rate (study: 3e-4).
        schedule: "fixed" keeps ``learning_rate``; rsl-rl's "adaptive" adjusts it to a target KL.
        hidden_dims, activation: Actor and critic MLPs; small by default because training runs on a CPU.
        init_noise_std: Initial std of the Gaussian policy.
        obs_normalization: Normalise actor and critic inputs with running statistics.
        obs_groups: rsl-rl observation sets; by default actor and critic both see the "policy" group.
        save_interval: Checkpoint every this many iterations (when the runner has a log_dir).
        algorithm_kwargs: Further ``PPOCuriosityGail``/``PPO`` arguments, e.g. ``curiosity_strength=0.05``,
            ``gail_strength=0.1``, ``gamma=0.995``; they override the study defaults.

    Returns:
        A plain dict (strings, numbers, lists), so it can be logged or stored as JSON.
    """
    if variant not in ABLATIONS:
        raise ValueError(f"Unknown variant '{variant}'; choose one of {sorted(ABLATIONS)}.")
    if ABLATIONS[variant].keys() & algorithm_kwargs.keys():
        raise ValueError("Choose the reward signals with `variant`, not with use_curiosity/use_gail.")
    if isinstance(expert_demonstrations, (str, os.PathLike)):
        expert_demonstrations = [expert_demonstrations]
    algorithm = {
        "class_name": ALGORITHM_CLASS_NAME,
        **ABLATIONS[variant],
        **STUDY_PPO,
        "learning_rate": learning_rate,
        "schedule": schedule,
        "num_mini_batches": num_mini_batches,
        "expert_demonstrations": [str(path) for path in expert_demonstrations],
        "expected_observation_config": expected_observation_config,
        **algorithm_kwargs,
    }
    model = {
        "class_name": "MLPModel",
        "hidden_dims": list(hidden_dims),
        "activation": activation,
        "obs_normalization": obs_normalization,
    }
    return {
        "num_steps_per_env": num_steps_per_env,
        "save_interval": save_interval,
        "obs_groups": obs_groups or {"actor": ["policy"], "critic": ["policy"]},
        "algorithm": algorithm,
        "actor": {
            **model,
            "distribution_cfg": {"class_name": "GaussianDistribution", "init_std": init_noise_std},
        },
        "critic": model,
    }
