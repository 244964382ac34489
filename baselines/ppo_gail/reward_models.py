"""The two learned reward signals of ``PPOCuriosityGail`` (``algorithm.py``) in our form: the Intrinsic
Curiosity Module (Pathak et al. 2017; the study's Eq. 4.23-4.28) and the GAIL discriminator (Ho & Ermon 2016;
the study's §4.2.7), with the running std that keeps the curiosity reward in units of typical surprise.
``mlagents.py`` holds the forms of Unity ML-Agents, which the study ran.

A curiosity module offers ``encoder``, ``losses``, ``loss_multiplier`` and ``reward(states, actions,
next_states, valid, strength, features=None, next_features=None)`` (the features: the encoder's, where the
caller has them); a discriminator ``losses``, ``loss_noise``, ``reward(states, actions)`` (before the
strength) and ``centred_reward``."""

from __future__ import annotations

from collections.abc import Sequence

import torch
import torch.nn as nn
import torch.nn.functional as F
from rsl_rl.modules import MLP


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


class CuriosityModel(nn.Module):
    """What every curiosity module shares: an ``encoder`` phi(s), a ``forward_model`` f(phi(s_t), a_t) ->
    phi_hat(s_t+1) and an ``inverse_model`` g(phi(s_t), phi(s_t+1)) -> a_hat_t, set by the subclass, and
    the losses of Pathak et al. (2017) on them. A subclass says how the surprise becomes a reward
    (``reward``) and by how much the algorithm multiplies its loss (``loss_multiplier``)."""

    loss_multiplier = 1.0
    """The algorithm minimises ``loss_multiplier * ((1 - beta) L_I + beta L_F)``."""

    def losses(
        self, states: torch.Tensor, actions: torch.Tensor, next_states: torch.Tensor
    ) -> tuple[torch.Tensor, torch.Tensor]:
        """Return the batch means of the forward loss L_F = 1/2 ||phi_hat(s_t+1) - phi(s_t+1)||^2 and the
        inverse loss L_I = ||a_hat_t - a_t||^2 (continuous actions: squared error instead of the paper's
        cross-entropy over discrete actions)."""
        features = self.encoder(states)
        next_features = self.encoder(next_states)
        predicted_next_features = self.forward_model(torch.cat([features, actions], dim=-1))
        predicted_actions = self.inverse_model(torch.cat([features, next_features], dim=-1))
        forward_loss = 0.5 * (predicted_next_features - next_features).square().sum(dim=-1).mean()
        inverse_loss = (predicted_actions - actions).square().sum(dim=-1).mean()
        return forward_loss, inverse_loss

    def surprise(
        self,
        states: torch.Tensor,
        actions: torch.Tensor,
        next_states: torch.Tensor,
        features: torch.Tensor | None = None,
        next_features: torch.Tensor | None = None,
    ) -> torch.Tensor:
        """1/2 ||phi_hat(s_t+1) - phi(s_t+1)||^2 of each transition, shape [B]. ``features`` and
        ``next_features``: phi(s_t) and phi(s_t+1) where the caller has them already (None: encoded here)."""
        if next_features is None:
            next_features = self.encoder(next_states)
        if features is None:
            features = self.encoder(states)
        predicted_next_features = self.forward_model(torch.cat([features, actions], dim=-1))
        return 0.5 * (predicted_next_features - next_features).square().sum(dim=-1)


class IntrinsicCuriosityModule(CuriosityModel):
    """Intrinsic Curiosity Module (Pathak et al. 2017, §2.2; the study's Eq. 4.23-4.28), ours: its surprise
    divided by its running std.

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

    @torch.no_grad()
    def reward(
        self,
        states: torch.Tensor,
        actions: torch.Tensor,
        next_states: torch.Tensor,
        valid: torch.Tensor,
        strength: float,
        features: torch.Tensor | None = None,
        next_features: torch.Tensor | None = None,
    ) -> torch.Tensor:
        """``strength`` times the surprise of each transition divided by its running std; zero where
        ``valid`` is False (``features``, ``next_features``: as for ``surprise``).

        ``valid`` marks transitions whose ``next_states`` really follow ``states``. For an environment that is
        done, the runner hands over the first observation of the next episode, whose prediction error is
        meaningless; it is neither rewarded nor counted in the running std.
        """
        surprise = self.surprise(states, actions, next_states, features, next_features)
        self.surprise_std.update(surprise[valid])
        return strength * (surprise / self.surprise_std.std.clamp_min(1e-8) * valid)


class GailDiscriminator(nn.Module):
    """GAIL discriminator D(s, a) = sigmoid(logit(s, a)) (Ho & Ermon 2016; the study's §4.2.7).

    Trained to output 1 on expert pairs and 0 on agent pairs (Ho & Ermon use the opposite labels; only the
    sign of the reward depends on it). The reward is the logit, log D - log(1 - D): positive where the agent
    looks like the expert, negative where it does not. The more common -log(1 - D) is always positive, i.e. a
    bonus for every step survived, and episodes here end on success, so it would teach the agent not to
    finish. The flip side: where an episode can end in failure (a crash), a mostly negative GAIL reward makes
    ending early attractive unless the environment penalises the failure.
    """

    centred_reward = True
    """The algorithm subtracts the rollout's mean reward (``PPOCuriosityGail.compute_returns``)."""

    def __init__(
        self, observation_dim: int, action_dim: int, hidden_dims: Sequence[int], activation: str = "elu"
    ):
        super().__init__()
        self.network = MLP(observation_dim + action_dim, 1, hidden_dims, activation)

    def loss_noise(self, batch_size: int) -> None:
        """The random numbers ``losses`` needs for a batch: none (the R1 penalty is taken at the expert
        samples)."""
        return None

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
        noise: None = None,
    ) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        """Return the BCE loss, the gradient penalty and the classification accuracy on one batch
        (``noise``: what ``loss_noise`` drew, nothing).

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
