"""``ppo_gail_study``: the study's learner configured as the study describes it (§4.3, §5.2.1).

The study (Xia 2020) trains two networks apart, with ML-Agents' PPO + curiosity + GAIL:

- a *cleaning* network on the cleaning cell (``a320_cell``) with the rewards of Table 4.4, for 6 M steps;
- a *tracking* network on the tracking cell (``a320_tracking_cell``) with the rewards of Table 4.5, whose
  episode ends when the robot reaches the green exit landmark (or a bound), for 2 M steps;

both seeing only their lidar and velocity (Table 4.3; §4.3.2 rules out global coordinates), with the
hyperparameters of Tables 5.2 and 5.3, and GAIL fed by demonstrations of each task (§4.3.4). After training
the two alternate cell by cell (Fig. 4.15): ``policy.PPOGailStudy`` runs the pair.

``STUDY`` holds the study's values, each where the study states it, in this package's terms; the two
``TrainConfig`` of ``study_config`` are built from it, and ``differences.py`` compares it with them and with
``ppo_gail`` (our tuned variant, ``TrainConfig``'s defaults). Train a stage with
``python -m cabinbench.train --baseline ppo_gail_study --stage cleaning|tracking``.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

from cabinbench.baselines.ppo_gail.training.config import TrainConfig

STAGES = ("cleaning", "tracking")


@dataclass(frozen=True)
class Stated:
    """One value of the study: for both stages, or ``(cleaning, tracking)`` when ``per_stage``."""

    value: object
    source: str
    per_stage: bool = False

    def of(self, stage: str):
        return self.value[STAGES.index(stage)] if self.per_stage else self.value


STUDY: dict[str, Stated] = {
    # TrainConfig field (or key of its ``algorithm``): the study's value in this package's terms
    "layouts": Stated((["a320_cell"], ["a320_tracking_cell"]), "§4.3.2, Fig. 4.11", per_stage=True),
    "reward": Stated("paper", "Tables 4.4, 4.5"),
    "terminate_on_bound": Stated(True, "Table 4.5 and §4.3.3: reaching a bound ends the iteration"),
    "terminate_on_exit": Stated(
        (False, True), "Table 4.5: reaching the green landmark completes the iteration", per_stage=True
    ),
    "coverage_patch": Stated(0, "Table 4.3, §4.3.2: only rays and velocity"),
    "hidden_dims": Stated([512, 512], "Table 5.2: hidden_units 512, num_layers 2"),
    "obs_normalization": Stated(False, "Table 5.2: normalize FALSE"),
    "num_steps_per_env": Stated(128, "Table 5.2: time_horizon"),
    "buffer": Stated(2048, "Table 5.2: buffer_size, samples per update"),
    "mini_batch": Stated(128, "Table 5.2: batch_size"),
    "steps": Stated((6_000_000, 2_000_000), "Table 5.2: max_steps", per_stage=True),
    "learning_rate_schedule": Stated(
        "linear",
        "inferred: Table 5.2 gives the initial learning rate, and ML-Agents' default learning_rate_schedule "
        "decays it, epsilon and beta linearly to max_steps",
    ),
    "entropy_coef": Stated(0.01, "Table 5.2: beta"),
    "learning_rate": Stated(3.0e-4, "Table 5.2"),
    "clip_param": Stated(0.2, "Table 5.2: epsilon"),
    "lam": Stated(0.95, "Table 5.2: lambda"),
    "num_learning_epochs": Stated(3, "Table 5.2: num_epoch"),
    "gamma": Stated(0.99, "Table 5.3: gamma of every reward signal"),
    "value_per_signal": Stated(
        True, "ML-Agents' PPO: a value head per reward signal; the extrinsic one alone ends with the episode"
    ),
    "curiosity_form": Stated("mlagents", "§5.2.1: ML-Agents' curiosity reward signal"),
    "curiosity_strength": Stated(0.02, "Table 5.3"),
    "curiosity_encoding_size": Stated(256, "Table 5.3"),
    "curiosity_learning_rate": Stated(3.0e-4, "ML-Agents' default; Table 5.3 does not set it"),
    "gail_form": Stated("mlagents", "§5.2.1: ML-Agents' GAIL reward signal"),
    "gail_strength": Stated(0.3, "Table 5.3"),
    "gail_hidden_dims": Stated([128, 128], "Table 5.3: encoding_size 128 (ML-Agents: 2 layers of it)"),
    "gail_use_actions": Stated(False, "ML-Agents' default use_actions: false; Table 5.3 does not set it"),
    "gail_gradient_penalty": Stated(10.0, "ML-Agents' GAIL gradient penalty weight, fixed in its code"),
    "gail_learning_rate": Stated(3.0e-4, "ML-Agents' default; Table 5.3 does not set it"),
    "demo_episodes": Stated((34, 32), "§4.3.4, Figs. 4.16, 4.17: 34 and 32 episodes", per_stage=True),
    "observation_size": Stated(244, "Fig. 4.16: Vector Observation Size 244 (rays and velocity)"),
    "export": Stated("last", "§3.2: after training, TensorFlow generates the network files the brains test"),
}
"""The study's settings: the values it states, and the defaults of ML-Agents (the toolkit it trained with,
``mlagents.py``) for what it leaves to them. Those named like ``TrainConfig`` fields or ``ALGORITHM_KEYS``
make ``study_config``; ``differences.py`` compares them all, and lists what the study leaves unstated beside
them."""

ALGORITHM_KEYS = (
    "entropy_coef",
    "learning_rate",
    "clip_param",
    "lam",
    "num_learning_epochs",
    "gamma",
    "value_per_signal",
    "curiosity_form",
    "curiosity_strength",
    "curiosity_encoding_size",
    "curiosity_learning_rate",
    "gail_form",
    "gail_strength",
    "gail_hidden_dims",
    "gail_use_actions",
    "gail_gradient_penalty",
    "gail_learning_rate",
)
"""The settings of ``STUDY`` that are ``PPOCuriosityGail`` arguments (``TrainConfig.algorithm``)."""

UNSTATED = {
    # TrainConfig fields the study does not give, and what ppo_gail_study takes for them
    "random_start": False,  # the layout's start: a Unity scene spawns its agent where it was placed
    # A person's demonstrations vary: each episode from another pose, the path driven unsteadily. The
    # planner's are made so (the env's random start pose, DART noise on its executed actions).
    "demo_random_start": True,
    "demo_action_noise": 0.2,
    "min_action_std": 0.0,  # ML-Agents does not clamp the policy's std
    "save_interval": 25,  # a checkpoint every 51 200 steps: an interruption loses little
}

CHECKPOINT_CHOICE = {
    # The benchmark's protocol, where the study exported its last networks: a learner's checkpoint is chosen
    # on cabin-v1-val, here every 250 iterations (512 000 steps) of the cleaning stage's 2930. The tracking
    # stage's episodes end at the exit, which cabin-v1-val's single cells lack: it keeps its last checkpoint.
    "cleaning": {"validation_episodes": 10, "validation_interval": 250, "export": "best"},
    "tracking": {"validation_episodes": 0, "export": "last"},
}


def study_config(stage: str, **overrides) -> TrainConfig:
    """The ``TrainConfig`` of the study's cleaning or tracking training (``overrides`` on top)."""
    if stage not in STAGES:
        raise ValueError(f"unknown stage {stage!r}; choose one of {', '.join(STAGES)}")
    known = {field.name for field in dataclasses.fields(TrainConfig)}
    fields = {name: stated.of(stage) for name, stated in STUDY.items() if name in known}
    buffer = STUDY["buffer"].of(stage)
    fields["num_envs"] = buffer // fields["num_steps_per_env"]  # the study's buffer from envs' rollouts
    fields["num_mini_batches"] = buffer // STUDY["mini_batch"].of(stage)
    fields["iterations"] = math.ceil(STUDY["steps"].of(stage) / buffer)  # ML-Agents stops at max_steps
    algorithm = {name: STUDY[name].of(stage) for name in ALGORITHM_KEYS}
    return TrainConfig(
        **{
            "ablation": "ppo_gail",
            "algorithm": algorithm,
            **fields,
            **UNSTATED,
            **CHECKPOINT_CHOICE[stage],
            **overrides,
        }
    )


def stage_name(stage: str) -> str:
    """The name a stage's run, policy file and records go by: ``ppo_gail_study_cleaning`` ..."""
    return f"ppo_gail_study_{stage}"
