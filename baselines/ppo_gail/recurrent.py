"""``ppo_lstm``: PPO whose actor remembers instead of seeing a map. It observes lidar and velocity only (no
coverage patch, no pose) and carries an LSTM state from step to step; trained by ``RecurrentTrainConfig``
(``baselines.ppo_gail.training.config``), its policy file holds a ``memory`` (``baselines.ppo_gail.memory``).
"""

from __future__ import annotations

import os

import numpy as np
import torch
from cabinbench.baselines.ppo_gail.memory import Memory
from cabinbench.baselines.ppo_gail.policy import LearnedPolicy, PolicyFileError

from cabinbench.agents import EpisodeContext


class PPOLstm(LearnedPolicy):
    """PPO with an LSTM memory on lidar and velocity only (the module docstring). The hidden state
    goes on from one ``act`` to the next and starts from zero at ``reset``, as in training. Config as
    ``LearnedPolicy``'s (``checkpoint``, ``stochastic``)."""

    name = ablation = "ppo_lstm"

    def __init__(self, checkpoint: str | os.PathLike | None = None, stochastic: bool = True) -> None:
        super().__init__(checkpoint, stochastic)
        try:
            self.memory = Memory(self.policy["memory"]).eval()
        except (KeyError, TypeError, ValueError, RuntimeError) as error:
            raise PolicyFileError(
                f"{self.path}: malformed recurrent policy file ({type(error).__name__}: {error})."
            ) from None
        self.state = None

    def reset(self, context: EpisodeContext, observation: np.ndarray, info: dict) -> None:
        super().reset(context, observation, info)
        self.state = None

    def mean_action(self, observation: torch.Tensor) -> torch.Tensor:
        latent, self.state = self.memory(observation, self.state)
        return self.policy["network"](latent)
