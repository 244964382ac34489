"""PPO + curiosity (ICM) + GAIL baseline as an rsl-rl 5.5.1 algorithm (see ``algorithm.py``)."""

from cabinbench.baselines.ppo_gail.algorithm import ABLATIONS, PPOCuriosityGail
from cabinbench.baselines.ppo_gail.demonstrations import DemonstrationError, load_demonstrations
from cabinbench.baselines.ppo_gail.runner_config import make_train_cfg

__all__ = ["ABLATIONS", "DemonstrationError", "PPOCuriosityGail", "load_demonstrations", "make_train_cfg"]
