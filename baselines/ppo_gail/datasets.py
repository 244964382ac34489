"""Demonstrations as a person records them, published as datasets: many varied episodes of the expert (the
boustrophedon planner), each from another start pose, its path perturbed, over several cells; not one
trajectory repeated.

Each episode starts at a pose of the start cell drawn by its seed (the env's ``random_start``), and the env
executes the planner's action plus Gaussian noise (``action_noise``, clipped to [-1, 1]) while the planner's
own action is recorded (DART, Laskey et al. 2017): the planner follows its path from wherever the noise
left the robot, so every episode drifts differently and shows how the expert gets back.

Two formats:

- one robot: a Minari dataset (``write_minari_dataset``; ``minari.load_dataset(dataset_id)`` reads it).
  Each episode's ``observations`` [T+1, D] float32 (the last one the episode's end), ``actions`` [T, 2]
  float32 (the planner's, in [-1, 1]), ``rewards`` [T] (the env's ``reward`` preset), ``terminations`` and
  ``truncations`` [T]; its ``seed`` is the env's reset seed, from which the start pose follows. The
  dataset's description names the layout of each run of episodes.
- teams, and one robot too: an ``.npz`` (``record_team_npz``) with the keys

  - ``observations`` float32 [N, D] and ``actions`` float32 [N, 2]: one row per robot and step, the robots
    of a step in seat order, then the next step;
  - ``episode`` int32 [N]: the episode of the row, numbered over the whole file;
  - ``agent`` int32 [N]: the robot's seat (0 to ``n_agents`` - 1);
  - ``episode_layout`` str [E]: the layout of each episode;
  - ``n_agents`` int 0-d: robots per team;
  - ``observation_config`` str 0-d: JSON of the env's observation settings.

  Its ``observations``, ``actions``, ``episode`` and ``observation_config`` are the schema of
  ``demonstrations.load_demonstrations``, so the file is GAIL's demonstrations as it is.

``scripts/record_demonstrations.py`` records both.
"""

from __future__ import annotations

import json
import os
import tempfile
import warnings
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from cabinbench.agents import EpisodeContext

DEFAULT_ACTION_NOISE = 0.2
"""Std of the noise on the executed actions: the planner's path visibly perturbed, every cell still
cleaned."""


def record_minari_episodes(
    layouts: Sequence[str],
    episodes: int,
    seed: int = 0,
    action_noise: float = DEFAULT_ACTION_NOISE,
    **env_kwargs,
) -> list:
    """``episodes`` varied episodes of one robot on each of ``layouts``, as Minari ``EpisodeBuffer``s (ids
    in order; episode ``i`` of a layout reset with seed ``seed + i``). ``env_kwargs`` are the env's
    (``CoverageEnv``; ``random_start`` is on unless given)."""
    from minari.data_collector import EpisodeBuffer

    buffers = []
    for layout in layouts:
        for index in range(episodes):
            steps = _planner_episode(layout, seed + index, action_noise, env_kwargs)
            buffers.append(EpisodeBuffer(id=len(buffers), seed=seed + index, **steps))
    return buffers


def _planner_episode(layout: str, seed: int, action_noise: float, env_kwargs: dict) -> dict:
    """One episode of the planner in ``CoverageEnv``: its observations, recorded actions, rewards,
    terminations and truncations as arrays."""
    from cabinbench.baselines.boustrophedon import Boustrophedon

    from cabinbench.envs.coverage_env import CoverageEnv

    settings = {"random_start": True, **env_kwargs}
    env = CoverageEnv(layout, **settings)
    observation, info = env.reset(seed=seed)
    planner = Boustrophedon()
    context = EpisodeContext(
        env.unwrapped.layout,
        "sequential",
        seed,
        env_config=settings,
        observation_layout=env.unwrapped.observation_layout,
    )
    planner.reset(context, observation, info)
    noise = np.random.default_rng([seed, 0])
    recorded = {
        "observations": [observation],
        "actions": [],
        "rewards": [],
        "terminations": [],
        "truncations": [],
    }
    terminated = truncated = False
    while not (terminated or truncated):
        action = np.clip(planner.act(observation, info), -1, 1).astype(np.float32)
        executed = np.clip(action + noise.normal(0.0, action_noise, 2), -1, 1) if action_noise > 0 else action
        observation, reward, terminated, truncated, info = env.step(executed)
        for key, value in zip(recorded, (observation, action, reward, terminated, truncated), strict=True):
            recorded[key].append(value)
    env.close()
    return {key: np.array(values) for key, values in recorded.items()}


def write_minari_dataset(dataset_id: str, layouts: Sequence[str], episodes: int, seed: int = 0, **options):
    """Record ``record_minari_episodes(layouts, episodes, seed, **options)`` as the Minari dataset
    ``dataset_id`` (in ``MINARI_DATASETS_PATH``, by default ``~/.minari/datasets``); return it. Its env spec
    is ``CabinBench/Coverage-v0`` on the first layout with the recording's settings
    (``dataset.recover_environment()``)."""
    import gymnasium
    import minari

    buffers = record_minari_episodes(layouts, episodes, seed, **options)
    noise = options.pop("action_noise", DEFAULT_ACTION_NOISE)
    env = gymnasium.make("CabinBench/Coverage-v0", layout=layouts[0], **{"random_start": True, **options})
    runs = "; ".join(
        f"episodes {index * episodes}-{(index + 1) * episodes - 1}: {layout}"
        for index, layout in enumerate(layouts)
    )
    with warnings.catch_warnings():
        # a project, no person to write to, and no public repository to link
        warnings.filterwarnings("ignore", message="`(author_email|code_permalink)` is set to None")
        return minari.create_dataset_from_buffers(
            dataset_id,
            buffers,
            env=env.spec,
            eval_env=env.spec,
            algorithm_name="boustrophedon planner, DART noise",
            author="cabinbench",
            description=(
                "CabinBench coverage demonstrations of one robot: the boustrophedon planner from random "
                f"start poses, its executed actions perturbed by Gaussian noise of std {noise} (its own "
                f"recorded). Env settings {json.dumps(options, sort_keys=True)}. {runs}."
            ),
        )


def record_team_npz(
    path: str | os.PathLike,
    layouts: Sequence[str],
    episodes: int,
    n_agents: int,
    seed: int = 0,
    action_noise: float = DEFAULT_ACTION_NOISE,
    **env_kwargs,
) -> dict:
    """Record ``episodes`` varied team episodes on each of ``layouts`` (the team planner, one per robot, as
    ``boustrophedon.record_demonstrations`` runs it) into one ``.npz`` of the module's team format; return
    its steps and the mean coverage."""
    from cabinbench.baselines.boustrophedon import record_demonstrations

    parts, coverages = [], []
    with tempfile.TemporaryDirectory() as folder:
        for index, layout in enumerate(layouts):
            part = Path(folder) / f"{index}.npz"
            summary = record_demonstrations(
                layout,
                episodes,
                str(part),
                seed=seed,
                action_noise=action_noise,
                n_agents=n_agents,
                **{"random_start": True, **env_kwargs},
            )
            coverages.append(summary["coverage"])
            with np.load(part) as data:
                parts.append({key: data[key] for key in data.files})
    np.savez_compressed(path, **_team_arrays(parts, layouts, episodes, n_agents))
    return {"steps": sum(len(part["actions"]) for part in parts), "coverage": float(np.mean(coverages))}


def _team_arrays(parts: list[dict], layouts: Sequence[str], episodes: int, n_agents: int) -> dict:
    """The team format's arrays from the per-layout recordings (rows robot after robot at each step)."""
    episode = np.concatenate([part["episode"] + index * episodes for index, part in enumerate(parts)])
    # every robot acts at every step, so a row's seat is its place in its step
    agent = np.concatenate([np.arange(len(part["episode"])) % n_agents for part in parts])
    return {
        "observations": np.concatenate([part["observations"] for part in parts]),
        "actions": np.concatenate([part["actions"] for part in parts]),
        "episode": episode.astype(np.int32),
        "agent": agent.astype(np.int32),
        "episode_layout": np.array([layout for layout in layouts for _ in range(episodes)]),
        "n_agents": np.array(n_agents),
        "observation_config": parts[0]["observation_config"],
    }
