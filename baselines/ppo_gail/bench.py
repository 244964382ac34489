"""Seconds per training iteration of each ablation, split into env, rollout and update.

``python -m cabinbench.bench`` finds this through the trainer (``bench_iteration`` beside ``main`` in
``cli.py``). Each ablation trains ``iterations`` iterations of its default (shipped) configuration after
``warmup`` ones, in one process, taking turns (see ``bench_iteration``):

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
from cabinbench.baselines.ppo_gail.training import TrainConfig, TrainingLog, build_runner


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
    """``{ablation: {"env": s, "rollout": s, "update": s, "total": s}}``: seconds of each ablation's
    fastest timed iteration. The ablations take turns, one iteration each, so that a machine whose load
    drifts slows them alike; the fastest of the turns is the one the neighbours disturbed least."""
    with tempfile.TemporaryDirectory() as folder:  # one folder: the GAIL ablations share the demonstrations
        timed = {}
        for ablation in ABLATIONS:
            config = TrainConfig(ablation=ablation, validation_episodes=0)
            runner, _ = build_runner(config, Path(folder))
            runner.env = _TimedEnv(runner.env)
            runner.logger = _TimedLog(config.num_envs, config.num_envs * config.num_steps_per_env)
            timed[ablation] = (runner, [])
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
        ablation: min(iterations_timed, key=lambda seconds: seconds["total"])
        for ablation, (_, iterations_timed) in timed.items()
    }
