"""Which layouts of its suite a training run on a suite (``TrainConfig.suite``) trained on, reconstructed
from its ``config.json`` without re-running it.

The batched training envs (:class:`~cabinbench.envs.batch_engine.BatchedEnv`) seed env ``i`` with
``seed + i`` and reset each from its own generator, and a suite env's reset draws only the layout and the
start pose (:class:`~cabinbench.envs.suite_env.TeamSuiteEnv`; without lidar noise an episode's steps draw
nothing). So each env's sequence of layouts is fixed by the seed, whatever the policy did. Only where an
env is in that sequence after ``iterations * num_steps_per_env`` steps depends on the policy: an episode
ends at the layout's step limit or earlier, on success. Playing every episode to its step limit is the
slowest an env can go through its sequence, so the episodes that begin within the run's steps then began
in the real run too: :func:`layouts_trained_on` returns those, a lower bound (episodes that ended early
made room for more, which only the run itself knew)."""

from __future__ import annotations

from collections import Counter

from cabinbench.baselines.ppo_gail.training.config import TrainConfig

from cabinbench.envs.settings import EnvSettings
from cabinbench.envs.suite_env import SUITE_SETTINGS, TeamSuiteEnv


def env_draws(config: TrainConfig, env_index: int):
    """Training env ``env_index``'s episodes, in order, as (layout name, step limit): its suite env
    reset as the batch resets it, the first time with the seed ``config.seed + env_index``."""
    settings = EnvSettings.of(SUITE_SETTINGS, config.env_kwargs)
    if settings.lidar_noise > 0:
        raise ValueError(
            "with lidar noise an episode's steps draw from the generator: its draws depend on them"
        )
    env = TeamSuiteEnv(config.suite, None, 1, settings)
    env.begin_episode(config.seed + env_index)
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
