"""Demonstrations for GAIL: the ``Boustrophedon`` planner run in the env, its (observation, action)
pairs saved.

``record_demonstrations`` saves ``observations`` [N, D] float32, ``actions`` [N, 2] float32,
``episode`` [N] int32 and ``observation_config`` (JSON of the env's ``observation_config``: the
settings that shape the observation) to an ``.npz``.
"""

from __future__ import annotations

import json

import numpy as np

from cabinbench.agents import EpisodeContext

from .baseline import Boustrophedon


def record_demonstrations(
    layout: str, episodes: int, path: str, seed: int = 0, action_noise: float = 0.0, **env_kwargs
) -> dict:
    """Run the planner for ``episodes`` episodes and save (observation, action) pairs to ``path``.
    Returns a summary (steps, mean coverage, success rate).

    With ``action_noise`` > 0 the env executes the planner's action plus Gaussian noise of that
    std (clipped to [-1, 1]), while the planner's own action is what is recorded (DART, Laskey et
    al. 2017). The planner follows its path from the pose it finds, so each episode drifts off the
    path differently and records how the expert gets back: demonstrations that cover the states
    around the path. Without noise, the planner in the deterministic env repeats one trajectory
    in every episode."""
    from cabinbench.envs.coverage_env import CoverageEnv

    env = CoverageEnv(layout, **env_kwargs)
    observations, actions, episode_of, records = [], [], [], []
    for episode in range(episodes):
        observation, info = env.reset(seed=seed + episode)
        noise = np.random.default_rng([seed, episode])
        planner = Boustrophedon()
        context = EpisodeContext(
            env.layout, env.world.protocol, seed + episode, observation_layout=env.observation_layout
        )
        planner.reset(context, observation, info)
        done = False
        while not done:
            action = np.clip(planner.act(observation, info), -1, 1)
            observations.append(observation)
            actions.append(action)
            episode_of.append(episode)
            executed = action + noise.normal(0.0, action_noise, 2) if action_noise > 0 else action
            observation, _, terminated, truncated, info = env.step(executed)
            done = terminated or truncated
        records.append(info["episode_record"])
    np.savez_compressed(
        path,
        observations=np.array(observations, dtype=np.float32),
        actions=np.array(actions, dtype=np.float32),
        episode=np.array(episode_of, dtype=np.int32),
        observation_config=np.array(json.dumps(env.observation_config)),
    )
    return {
        "steps": len(actions),
        "coverage": float(np.mean([r["coverage"] for r in records])),
        "success": float(np.mean([r["success"] for r in records])),
    }
