"""The networks a policy file's actor is rebuilt into, in plain torch (no rsl-rl import): ``Actor``, rsl-rl's
normaliser + MLP as trained, and ``Inference``, what a baseline acts with (and what the file's ONNX twin
exports), in the precision of the file's ``inference`` entry (``baselines.ppo_gail.policy``)."""

from __future__ import annotations

import copy

import torch
import torch.nn as nn
from cabinbench.baselines.ppo_gail.memory import rnn

PRECISIONS = {"float32": torch.float32, "float64": torch.float64}

ACTIVATIONS = {
    # rsl-rl's activation names (rsl_rl.utils.resolve_nn_activation)
    "elu": nn.ELU,
    "selu": nn.SELU,
    "relu": nn.ReLU,
    "crelu": nn.CELU,
    "lrelu": nn.LeakyReLU,
    "tanh": nn.Tanh,
    "sigmoid": nn.Sigmoid,
    "softplus": nn.Softplus,
    "gelu": nn.GELU,
    "swish": nn.SiLU,
    "mish": nn.Mish,
    "identity": nn.Identity,
}


class Actor(nn.Module):
    """Observation normaliser + MLP, the deterministic part of rsl-rl's ``MLPModel`` with a Gaussian head.

    ``forward(observations [B, D]) -> mean actions [B, A]`` (not clipped). The layers are an ``nn.Sequential``
    named like rsl-rl's ``MLP`` (Linear, activation, Linear, ..., Linear), so rsl-rl's state dict loads as it
    is.
    """

    def __init__(
        self,
        observation_size: int,
        action_size: int,
        hidden_dims,
        activation: str = "elu",
        normalizer: dict | None = None,
    ) -> None:
        super().__init__()
        if activation not in ACTIVATIONS:
            raise ValueError(f"unknown activation {activation!r}; known: {', '.join(ACTIVATIONS)}")
        sizes = [observation_size, *hidden_dims]
        layers: list[nn.Module] = []
        for size_in, size_out in zip(sizes[:-1], sizes[1:]):
            layers += [nn.Linear(size_in, size_out), ACTIVATIONS[activation]()]
        layers.append(nn.Linear(sizes[-1], action_size))
        self.mlp = nn.Sequential(*layers)
        self.normalize = normalizer is not None
        self.eps = float(normalizer["eps"]) if normalizer else 0.0
        # Shapes [1, D] and the formula (x - mean) / (std + eps) are rsl-rl's, so results match to the bit.
        self.register_buffer("mean", torch.zeros(1, observation_size))
        self.register_buffer("std", torch.ones(1, observation_size))
        if normalizer:
            self.mean.copy_(normalizer["mean"].reshape(1, -1))
            self.std.copy_(normalizer["std"].reshape(1, -1))

    def forward(self, observations: torch.Tensor) -> torch.Tensor:
        if self.normalize:
            observations = (observations - self.mean) / (self.std + self.eps)
        return self.mlp(observations)


class Inference(nn.Module):
    """What a read policy file's actor computes for one robot, in the precision of its ``inference`` entry:
    observation normaliser, a recurrent actor's RNN (``memory.rnn``), MLP. ``forward(observation [B, D],
    *state) -> (mean action [B, A], *state)``: the observation in ``dtype``, the mean action float32 (rounded
    from float64 in float64), the RNN's state (``state_names``: hidden (, cell) [L, B, H]; none for an MLP)
    passed in and out, from ``initial_state()`` on. This module is the file's ONNX twin too
    (``baselines.onnx.export``).

    In float32 it computes what ``Actor`` and rsl-rl's recurrent actor compute, bit for bit. In float64 its
    ELU is ``Float64Elu`` and its RNN a ``WrittenOutRNN``, which onnxruntime runs in float64 too."""

    def __init__(self, policy: dict) -> None:
        super().__init__()
        self.dtype = PRECISIONS[policy["inference"]]
        mlp = policy["network"].mlp
        if self.dtype == torch.float64:
            mlp = nn.Sequential(
                *(Float64Elu() if isinstance(layer, nn.ELU) else copy.deepcopy(layer) for layer in mlp)
            )
        self.mlp = mlp.to(self.dtype)
        memory = policy.get("memory")
        self.rnn = rnn(memory, self.dtype) if memory else None
        self.state_names = (
            [] if not memory else ["hidden", "cell"] if memory["rnn_type"] == "lstm" else ["hidden"]
        )
        self.state_size = (memory["num_layers"], 1, memory["hidden_size"]) if memory else ()
        self.observation_size = memory["input_size"] if memory else policy["actor"]["observation_size"]
        normalizer = memory["obs_normalizer"] if memory else policy["obs_normalizer"]
        self.normalize = normalizer is not None
        if normalizer:  # std + eps summed here: torch's exporter rounds a Python float to float32
            self.register_buffer("mean", normalizer["mean"].reshape(1, -1).to(self.dtype))
            self.register_buffer(
                "divisor", normalizer["std"].reshape(1, -1).to(self.dtype) + normalizer["eps"]
            )

    def initial_state(self) -> tuple[torch.Tensor, ...]:
        """The zero state of an episode's start for one robot, as rsl-rl's reset leaves it."""
        return tuple(torch.zeros(self.state_size, dtype=self.dtype) for _ in self.state_names)

    def forward(self, observation: torch.Tensor, hidden=None, cell=None) -> tuple[torch.Tensor, ...]:
        if self.normalize:
            observation = (observation - self.mean) / self.divisor
        state = ()
        if self.rnn is not None:
            latent, state = self.rnn(observation.unsqueeze(0), hidden if cell is None else (hidden, cell))
            observation, state = latent.squeeze(0), state if isinstance(state, tuple) else (state,)
        return (self.mlp(observation).to(torch.float32), *state)


class Float64Elu(nn.Module):
    """ELU as ``where(x > 0, x, exp(x) - 1)``: onnxruntime's CPU provider has no float64 Elu."""

    def forward(self, values: torch.Tensor) -> torch.Tensor:
        return torch.where(values > 0, values, torch.exp(values) - 1)
