"""Seconds per training iteration of each ablation, split into env, rollout and update.

``python -m cabinbench.bench`` finds this through the trainer (``bench_iteration`` beside ``main`` in
``cli.py``). Each ablation trains ``iterations`` iterations of its default (shipped) configuration after
``warmup`` ones, in one process, and the mean over the timed iterations is reported:

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
from cabinbench.baselines.ppo_gail.training import TrainConfig, TrainingLog, make_runner


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
    """``{ablation: {"env": s, "rollout": s, "update": s, "iteration": s}}``, seconds per iteration."""
    figures = {}
    with tempfile.TemporaryDirectory() as folder:  # one folder: the GAIL ablations share the demonstrations
        for ablation in ABLATIONS:
            config = TrainConfig(ablation=ablation, validation_episodes=0)
            runner, _ = make_runner(config, Path(folder))
            runner.env = env = _TimedEnv(runner.env)
            runner.logger = log = _TimedLog(config.num_envs, config.num_envs * config.num_steps_per_env)
            runner.learn(num_learning_iterations=warmup)
            env.seconds = 0.0
            runner.learn(num_learning_iterations=iterations)
            rollout = sum(collect for collect, _ in log.times[warmup:]) / iterations
            update = sum(learn for _, learn in log.times[warmup:]) / iterations
            figures[ablation] = {
                "env": env.seconds / iterations,
                "rollout": rollout,
                "update": update,
                "iteration": rollout + update,
            }
    return figures
