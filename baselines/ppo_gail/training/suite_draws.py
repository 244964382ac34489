"""Which layouts of its suite a training run on a suite (``TrainConfig.suite``) trained on, reconstructed
from its ``config.json`` without re-running it.

The batched training envs (:class:`~cabinbench.envs.batch_engine.BatchedEnv`) seed env ``i`` with
``first_env_seed + i`` and reset each from its own generator, and a suite env's reset draws only the
layout and the start pose (:class:`~cabinbench.envs.suite_env.TeamSuiteEnv`; without lidar noise an
episode's steps draw nothing). So each env's sequence of layouts is fixed by the seed, whatever the policy
did. Only where an env is in that sequence after ``iterations * num_steps_per_env`` steps depends on the
policy: an episode ends at the layout's step limit or earlier, on success. Playing every episode to its
step limit is the slowest an env can go through its sequence, so the episodes that begin within the run's
steps then began in the real run too: :func:`layouts_trained_on` returns those, a lower bound (episodes
that ended early made room for more, which only the run itself knew)."""

from __future__ import annotations

import argparse
import json
import sys
from collections import Counter
from pathlib import Path

from cabinbench.baselines.ppo_gail.training.config import TrainConfig

from cabinbench.envs.settings import EnvSettings
from cabinbench.envs.suite_env import SUITE_SETTINGS, TeamSuiteEnv
from cabinbench.layouts.suites import get_suite


def env_draws(config: TrainConfig, env_index: int):
    """Training env ``env_index``'s episodes, in order, as (layout name, step limit): its suite env
    reset as the batch resets it, the first time with the seed ``config.first_env_seed + env_index``."""
    settings = EnvSettings.of(SUITE_SETTINGS, config.env_kwargs)
    if settings.lidar_noise > 0:
        raise ValueError(
            "with lidar noise an episode's steps draw from the generator: its draws depend on them"
        )
    env = TeamSuiteEnv(config.suite, None, 1, settings)
    env.begin_episode(config.first_env_seed + env_index)
    while True:
        yield env.layout.name, env.max_steps
        env.begin_episode()


def layouts_trained_on(config: dict) -> Counter:
    """{layout name: episodes begun on it} of the suite training run of ``config`` (a ``config.json``'s
    dict), counting the episodes every env began for certain (see the module docstring): a lower bound
    on each count, exact when no episode ended before its step limit."""
    run = TrainConfig.from_dict(config)
    if not run.suite:
        raise ValueError(f"a run on layouts {run.layouts}, not on a suite: it trained on those")
    steps = run.iterations * run.num_steps_per_env  # each env's, over the run
    begun = Counter()
    for env_index in range(run.num_envs):
        start = 0
        for name, limit in env_draws(run, env_index):
            if start >= steps:
                break
            begun[name] += 1
            start += limit
    return begun


def training_sample(configs: list[dict], size: int) -> list[str]:
    """The first ``size`` layouts every run of ``configs`` (``config.json`` dicts) trained on for certain:
    a suite run's in the suite's order (the generator draws its layouts independently by index, so these
    are a random sample of them), a run on layouts its layouts."""
    runs = [TrainConfig.from_dict(config) for config in configs]
    if not runs:
        return []
    if any(run.suite != runs[0].suite for run in runs):
        raise ValueError(f"runs on different suites: {sorted({str(run.suite) for run in runs})}")
    if not runs[0].suite:
        return [name for name in runs[0].layouts if all(name in run.layouts for run in runs)][:size]
    trained = [layouts_trained_on(config) for config in configs]
    names = get_suite(runs[0].suite).layout_names
    return [name for name in names if all(name in begun for begun in trained)][:size]


def shared_envs(configs: list[dict]) -> int:
    """How many training envs every run of ``configs`` seeded alike: env ``i`` of a run is seeded
    ``first_env_seed + i``, so runs from before ``disjoint_env_seeds`` with neighbouring seeds share most
    of their envs' generators, and on a suite their layouts."""
    runs = [TrainConfig.from_dict(config) for config in configs]
    if not runs:
        return 0
    first = max(run.first_env_seed for run in runs)
    return max(0, min(run.first_env_seed + run.num_envs for run in runs) - first)


def main(argv: list[str] | None = None) -> int:
    """Print how many of the suite's first layouts hold :func:`training_sample` of the given runs: the
    ``--layouts K`` of ``python -m cabinbench.run --suite ...`` that plays all of it."""
    parser = argparse.ArgumentParser(
        prog="python -m cabinbench.baselines.ppo_gail.training.suite_draws", description=main.__doc__
    )
    parser.add_argument("--layouts", type=int, default=30, help="the sample's size (default 30)")
    parser.add_argument("configs", nargs="+", type=Path, help="config.json of each training run")
    args = parser.parse_args(argv)
    configs = []
    for path in args.configs:
        try:
            configs.append(json.loads(path.read_text(encoding="utf-8")))
        except (OSError, ValueError) as error:
            print(f"error: {path}: not a training run's config.json ({error})", file=sys.stderr)
            return 2
    sample = training_sample(configs, args.layouts)
    suite = configs[0].get("suite")
    if not suite or len(sample) < args.layouts:
        print(
            f"error: {args.configs[0]}: the runs share {len(sample)} layouts of a suite for certain, "
            f"not {args.layouts}; give a smaller --layouts",
            file=sys.stderr,
        )
        return 2
    print(get_suite(suite).layout_names.index(sample[-1]) + 1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
