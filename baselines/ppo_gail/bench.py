"""Seconds per training iteration of each ablation, split into env, rollout and update.

``python -m cabinbench.bench`` finds this through the trainer (``bench_iteration`` beside ``main`` in
``cli.py``). Each of ``VARIANTS`` trains ``iterations`` iterations after ``warmup`` ones, in one process,
taking turns (see ``bench_iteration``), on every core this process may use (``TrainConfig.workers``):

- ``env``: the batched env's ``step`` (physics, lidar, coverage patch, rewards);
- ``rollout``: rsl-rl's collection time, the env included (plus the policy's actions, the curiosity and
  GAIL rewards, the rollout storage);
- ``update``: rsl-rl's learning time (returns, then the PPO, ICM and discriminator epochs).
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

from cabinbench.baselines.ppo_gail.algorithm import ABLATIONS
from cabinbench.baselines.ppo_gail.training.config import TrainConfig
from cabinbench.baselines.ppo_gail.training.loop import build_runner
from cabinbench.baselines.ppo_gail.training.metrics import TrainingLog

SHAPING_EPOCHS_1 = {**TrainConfig().algorithm, "shaping_epochs": 1}
SMALL_ICM = {"curiosity_encoding_size": 128, "curiosity_hidden_dims": [128]}
COARSE_PATCH = {"coverage_patch": 16, "coverage_patch_cell": 0.25}
VARIANTS = {
    **{ablation: {"ablation": ablation} for ablation in ABLATIONS},
    "ppo_gail_one_core": {"ablation": "ppo_gail", "workers": 1},
    "ppo_gail_shaping_epochs_1": {"ablation": "ppo_gail", "algorithm": SHAPING_EPOCHS_1},
    "ppo_gail_small_icm": {"ablation": "ppo_gail", "algorithm": {**TrainConfig().algorithm, **SMALL_ICM}},
    "ppo_gail_coarse_patch": {"ablation": "ppo_gail", **COARSE_PATCH},
    "ppo_gail_cheaper": {
        "ablation": "ppo_gail",
        "algorithm": {**SHAPING_EPOCHS_1, **SMALL_ICM},
        **COARSE_PATCH,
    },
}
"""What is timed: each ablation's default (shipped) configuration; ``ppo_gail`` on one core, for what the
second core buys; and ``ppo_gail`` with settings that train faster and change what it learns, none of them
adopted (docs/experiments.md, "What a training iteration costs"): its ICM and discriminator trained one epoch
an iteration instead of PPO's three (see also "One epoch of the ICM and the discriminator"), an ICM of 128
units instead of 256, the coarse 16 x 16 patch of 0.25 m cells, and the three together (trained on
cabin-v1-val, it scored below the defaults' seed spread)."""


class _TimedEnv:
    """The training env, timing its ``step``; everything else passes through."""

    def __init__(self, env) -> None:
        self.env, self.seconds = env, 0.0

    def step(self, actions):
        started = time.perf_counter()
        result = self.env.step(actions)
        self.seconds += time.perf_counter() - started
        return result

    def __getattr__(self, name):
        return getattr(self.env, name)


class _TimedLog(TrainingLog):
    """The training log, keeping rsl-rl's collection and learning times of every iteration."""

    def __init__(self, *args) -> None:
        super().__init__(*args)
        self.times: list[tuple[float, float]] = []

    def log(self, *, collect_time, learn_time, **values) -> None:
        self.times.append((collect_time, learn_time))
        super().log(collect_time=collect_time, learn_time=learn_time, **values)


def bench_iteration(iterations: int = 3, warmup: int = 1) -> dict[str, dict[str, float]]:
    """``{variant: {"env": s, "rollout": s, "update": s, "total": s}}``: seconds of each variant's
    fastest timed iteration. The variants take turns, one iteration each, so that a machine whose load
    drifts slows them alike; the fastest of the turns is the one the neighbours disturbed least."""
    with tempfile.TemporaryDirectory() as folder:  # the GAIL variants of one patch share its demonstrations
        timed = {}
        for name, settings in VARIANTS.items():
            config = TrainConfig(**settings, validation_episodes=0)
            demonstrations = Path(folder) / f"patch_{config.coverage_patch}_{config.coverage_patch_cell}"
            demonstrations.mkdir(exist_ok=True)
            runner, _ = build_runner(config, demonstrations)
            runner.env = _TimedEnv(runner.env)
            runner.logger = _TimedLog(config.num_envs, config.num_envs * config.num_steps_per_env)
            timed[name] = (runner, [])
        for turn in range(warmup + iterations):
            for runner, iterations_timed in timed.values():
                env_before = runner.env.seconds
                runner.learn(num_learning_iterations=1)
                rollout, update = runner.logger.times[-1]
                if turn >= warmup:
                    iterations_timed.append(
                        {
                            "env": runner.env.seconds - env_before,
                            "rollout": rollout,
                            "update": update,
                            "total": rollout + update,
                        }
                    )
        for runner, _ in timed.values():
            runner.env.close()
    return {
        name: min(iterations_timed, key=lambda seconds: seconds["total"])
        for name, (_, iterations_timed) in timed.items()
    }
