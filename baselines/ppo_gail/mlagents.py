"""The curiosity and GAIL reward signals as Unity ML-Agents computes them: the toolkit the study trained with
(§5.2.1: its PPO trainer, "curiosity" and "gail" reward signals, TensorBoard summaries).

Read from ML-Agents' TensorFlow trainers (``mlagents/trainers/components/reward_signals/{curiosity,gail}/``,
the releases of 2019-2020, the study's time) and checked against its later PyTorch port
(``mlagents/trainers/torch_entities/components/reward_providers/``), which computes the same:

- curiosity: an encoder of two ``encoding_size`` swish layers, forward and inverse models of one 256-unit
  swish layer; loss ``10 * (0.2 L_F + 0.8 L_I)``; reward ``clip(strength * 1/2 ||phi_hat - phi||^2, 0, 1)``,
  the raw forward error (no running-std rescale), zero before the module's first update;
- GAIL: a discriminator D(s) = sigmoid(...) of two swish hidden layers on the observation only (its default
  ``use_actions: false``); loss ``-mean(log(D(expert) + eps) + log(1 - D(agent) + eps))`` plus 10 times the
  WGAN-GP penalty ``mean((||grad D(x_hat)|| - 1)^2)`` at ``x_hat = u * expert + (1 - u) * agent``, u uniform
  per input element (Gulrajani et al. 2017); reward ``-log(1 - D(s) + eps)``, eps = 1e-7, always positive
  and not centred, zero before the first update.

``PPOCuriosityGail(curiosity_form="mlagents", gail_form="mlagents")`` uses them; ``reward_models.py`` holds
ours and the interface both follow.
"""

from __future__ import annotations

from collections.abc import Sequence

import torch
import torch.nn as nn
from cabinbench.baselines.ppo_gail.reward_models import CuriosityModel
from rsl_rl.modules import MLP

CURIOSITY_MODEL_UNITS = 256
"""Units of the forward and inverse models' hidden layer (fixed in ML-Agents' code)."""
CURIOSITY_FORWARD_WEIGHT = 0.2
"""ML-Agents' beta: its curiosity loss is ``10 * (0.2 L_F + 0.8 L_I)``."""
GAIL_GRADIENT_PENALTY = 10.0
"""ML-Agents' weight of the GAIL gradient penalty (fixed in its code)."""
EPSILON = 1e-7
"""ML-Agents' guard of the GAIL logarithms and of the gradient norm."""


def _swish_layers(sizes: Sequence[int]) -> list[nn.Module]:
    """Dense layers between consecutive ``sizes``, each followed by swish (ML-Agents' hidden layers)."""
    layers: list[nn.Module] = []
    for size_in, size_out in zip(sizes[:-1], sizes[1:], strict=True):
        layers += [nn.Linear(size_in, size_out), nn.SiLU()]
    return layers


class MlAgentsCuriosity(CuriosityModel):
    """ML-Agents' curiosity module: phi is two swish layers of ``encoding_size`` (its vector-observation
    encoder), f and g one swish layer of 256 then a linear output. Its loss is 10 times Pathak's, and its
    reward the raw forward error times the strength, clipped to [0, 1]."""

    loss_multiplier = 10.0

    def __init__(self, observation_dim: int, action_dim: int, encoding_size: int) -> None:
        super().__init__()
        self.encoder = nn.Sequential(*_swish_layers([observation_dim, encoding_size, encoding_size]))
        units = CURIOSITY_MODEL_UNITS
        self.forward_model = nn.Sequential(
            *_swish_layers([encoding_size + action_dim, units]), nn.Linear(units, encoding_size)
        )
        self.inverse_model = nn.Sequential(
            *_swish_layers([2 * encoding_size, units]), nn.Linear(units, action_dim)
        )
        # ML-Agents pays no curiosity before the module's first update (its ``has_updated``).
        self.register_buffer("has_updated", torch.zeros((), dtype=torch.bool))

    def losses(
        self, states: torch.Tensor, actions: torch.Tensor, next_states: torch.Tensor
    ) -> tuple[torch.Tensor, torch.Tensor]:
        """Pathak's losses (``CuriosityModel.losses``); computing them marks the module as trained."""
        self.has_updated.fill_(True)
        return super().losses(states, actions, next_states)

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
        """``clip(strength * surprise, 0, 1)`` of each transition; zero where ``valid`` is False (its next
        observation is a reset's) and before the first update (``features``, ``next_features``: as for
        ``surprise``)."""
        surprise = self.surprise(states, actions, next_states, features, next_features)
        return (strength * surprise * self.has_updated).clamp(0.0, 1.0) * valid


class MlAgentsDiscriminator(nn.Module):
    """ML-Agents' GAIL discriminator D = sigmoid(network(x)), x the observation, or the observation and the
    action with ``use_actions`` (ML-Agents appends the done flag too; this one does not), the network
    ``hidden_dims`` swish layers and a linear output. The expert is labelled 1."""

    centred_reward = False
    """The algorithm adds the reward as it is: -log(1 - D) is positive, as ML-Agents pays it."""

    def __init__(
        self, observation_dim: int, action_dim: int, hidden_dims: Sequence[int], use_actions: bool = False
    ) -> None:
        super().__init__()
        self.use_actions = use_actions
        self.input_dim = observation_dim + (action_dim if use_actions else 0)
        self.network = MLP(self.input_dim, 1, hidden_dims, "swish")
        self.register_buffer("has_updated", torch.zeros((), dtype=torch.bool))

    def inputs(self, states: torch.Tensor, actions: torch.Tensor) -> torch.Tensor:
        """What D sees of (s, a): s, or s and a with ``use_actions``."""
        return torch.cat([states, actions], dim=-1) if self.use_actions else states

    def estimate(self, inputs: torch.Tensor) -> torch.Tensor:
        """D of each row of ``inputs``, shape [B]: how much it believes the row is the expert's."""
        return torch.sigmoid(self.network(inputs)).squeeze(-1)

    @torch.no_grad()
    def reward(self, states: torch.Tensor, actions: torch.Tensor) -> torch.Tensor:
        """-log(1 - D + eps) of each pair, before the strength; zero before the first update."""
        return -torch.log(1.0 - self.estimate(self.inputs(states, actions)) + EPSILON) * self.has_updated

    def loss_noise(self, batch_size: int) -> torch.Tensor:
        """The interpolation weights u of a batch's gradient penalty, uniform in [0, 1) per input element:
        drawn before the update (with PPO's draws) so that training in threads draws the same numbers."""
        return torch.rand(batch_size, self.input_dim, device=self.has_updated.device)

    def losses(
        self,
        agent_states: torch.Tensor,
        agent_actions: torch.Tensor,
        expert_states: torch.Tensor,
        expert_actions: torch.Tensor,
        noise: torch.Tensor,
    ) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        """Return the discriminator loss, the gradient penalty (unweighted) and the accuracy on one batch of
        agent and expert pairs (as many of each), the penalty at ``noise * expert + (1 - noise) * agent``.
        Computing them marks the module as trained."""
        self.has_updated.fill_(True)
        agent_inputs = self.inputs(agent_states, agent_actions)
        expert_inputs = self.inputs(expert_states, expert_actions)
        agent_estimate = self.estimate(agent_inputs)
        expert_estimate = self.estimate(expert_inputs)
        loss = -(torch.log(expert_estimate + EPSILON) + torch.log(1.0 - agent_estimate + EPSILON)).mean()
        accuracy = 0.5 * ((expert_estimate > 0.5).float().mean() + (agent_estimate < 0.5).float().mean())
        return loss, self.gradient_penalty(agent_inputs, expert_inputs, noise), accuracy.detach()

    def gradient_penalty(
        self, agent_inputs: torch.Tensor, expert_inputs: torch.Tensor, noise: torch.Tensor
    ) -> torch.Tensor:
        """mean((||grad_x D(x_hat)|| - 1)^2) at x_hat = noise * expert + (1 - noise) * agent; the norm is
        sqrt(sum g^2 + eps), whose gradient stays finite at a zero gradient (ML-Agents' PyTorch form)."""
        mixed = (noise * expert_inputs + (1.0 - noise) * agent_inputs).detach().requires_grad_(True)
        (gradient,) = torch.autograd.grad(self.estimate(mixed).sum(), mixed, create_graph=True)
        norm = (gradient.square().sum(dim=-1) + EPSILON).sqrt()
        return (norm - 1.0).square().mean()
