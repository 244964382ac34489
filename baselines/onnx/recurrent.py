"""A recurrent actor (``ppo_lstm``: normaliser, LSTM or GRU, MLP head) as the ``onnx`` baseline runs it: its
memory's state an input and an output of the model, so that onnxruntime carries it from step to step.

    observation [batch, D], hidden [layers, batch, H] (, cell [layers, batch, H] for an LSTM)
        -> action_mean [batch, A], hidden_out (, cell_out)

The state starts at zero at each episode, as rsl-rl's does at a reset and ``PPOLstm`` does (``state`` None).
"""

from __future__ import annotations

import torch
import torch.nn as nn
from cabinbench.baselines.ppo_gail.memory import Memory


class RecurrentActor(nn.Module):
    """``Memory`` and the actor's head of a read recurrent policy file, with the state passed in and out."""

    def __init__(self, policy: dict):
        super().__init__()
        self.memory = Memory(policy["memory"]).eval()
        self.head = policy["network"]
        self.lstm = isinstance(self.memory.rnn, nn.LSTM)

    @property
    def state_names(self) -> list[str]:
        return ["hidden", "cell"] if self.lstm else ["hidden"]

    def forward(self, observation: torch.Tensor, hidden: torch.Tensor, cell: torch.Tensor | None = None):
        latent, state = self.memory(observation, (hidden, cell) if self.lstm else hidden)
        return (self.head(latent), *(state if self.lstm else (state,)))

    def example_state(self) -> tuple[torch.Tensor, ...]:
        """A zero state for one robot: the start of an episode."""
        rnn = self.memory.rnn
        return tuple(torch.zeros(rnn.num_layers, 1, rnn.hidden_size) for _ in self.state_names)
