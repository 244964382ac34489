"""``ppo_lstm``: PPO whose actor remembers instead of seeing a map. It observes lidar and velocity only (no
coverage patch, no pose) and carries an LSTM state from step to step; trained by ``RecurrentTrainConfig``
(``baselines.ppo_gail.training.config``), its policy file holds a ``memory`` (``baselines.ppo_gail.memory``).
"""

from __future__ import annotations

from cabinbench.baselines.ppo_gail.policy import LearnedPolicy


class PPOLstm(LearnedPolicy):
    """PPO with an LSTM memory on lidar and velocity only (the module docstring). The hidden state goes on
    from one ``act`` to the next and starts from zero at ``reset``, as in training (``networks.Inference``).
    Config as ``LearnedPolicy``'s (``checkpoint``, ``stochastic``)."""

    name = ablation = "ppo_lstm"
