"""PPO + curiosity (ICM) + GAIL baseline as an rsl-rl 5.5.1 algorithm (see ``algorithm.py``)."""

from cabinbench.baselines.ppo_gail.algorithm import ABLATIONS, PPOCuriosityGail, make_train_cfg
from cabinbench.baselines.ppo_gail.demonstrations import DemonstrationError, load_demonstrations

__all__ = ["ABLATIONS", "DemonstrationError", "PPOCuriosityGail", "load_demonstrations", "make_train_cfg"]
