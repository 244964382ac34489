"""The memory of a recurrent actor (rsl-rl's ``RNNModel``: normaliser, RNN, MLP head) in a policy file: the
``memory`` entry of the ``cabinbench-policy/1`` format (``baselines.ppo_gail.policy``), whose ``actor`` is
then the MLP head on the RNN's output, and the plain-torch ``Memory`` that runs it (``recurrent.PPOLstm``)."""

from __future__ import annotations

import torch
import torch.nn as nn

RNN_TYPES = {"lstm": nn.LSTM, "gru": nn.GRU}


def memory_entry(model, normalizer: dict | None) -> dict:
    """The ``memory`` entry of a policy file of rsl-rl's recurrent ``model``, whose observation ``normalizer``
    (or None) feeds its RNN."""
    rnn = model.rnn.rnn
    return {
        "rnn_type": "lstm" if isinstance(rnn, nn.LSTM) else "gru",
        "input_size": int(model.obs_dim),
        "hidden_size": int(rnn.hidden_size),
        "num_layers": int(rnn.num_layers),
        "state_dict": {key: value.detach().cpu().clone() for key, value in rnn.state_dict().items()},
        "obs_normalizer": normalizer,
    }


class Memory(nn.Module):
    """Normaliser + RNN of a ``memory`` entry. ``forward(observation [1, D], state) -> (latent [1, H],
    state)``; ``state`` None is the zero state of an episode's start (rsl-rl's reset)."""

    def __init__(self, entry: dict) -> None:
        super().__init__()
        self.rnn = RNN_TYPES[entry["rnn_type"]](
            entry["input_size"], entry["hidden_size"], entry["num_layers"]
        )
        self.rnn.load_state_dict(entry["state_dict"], strict=True)
        normalizer = entry["obs_normalizer"]
        self.mean = normalizer["mean"].reshape(1, -1) if normalizer else None
        self.std = normalizer["std"].reshape(1, -1) + normalizer["eps"] if normalizer else None

    def forward(self, observation: torch.Tensor, state):
        if self.mean is not None:
            observation = (observation - self.mean) / self.std
        latent, state = self.rnn(observation.unsqueeze(0), state)
        return latent.squeeze(0), state
