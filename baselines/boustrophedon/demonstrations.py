"""Demonstrations for GAIL: the ``Boustrophedon`` planner run in the env, its (observation, action)
pairs saved.

``record_demonstrations`` saves ``observations`` [N, D] float32, ``actions`` [N, 2] float32,
``episode`` [N] int32 and ``observation_config`` (JSON of the env's ``observation_config``: the
settings that shape the observation) to an ``.npz``.
"""

from __future__ import annotations

import json

import numpy as np
from cabinbench.baselines.boustrophedon.baseline import Boustrophedon

from cabinbench.agents import EpisodeContext, exact_action


def record_demonstrations(
    layout: str,
    episodes: int,
    path: str,
    seed: int = 0,
    action_noise: float = 0.0,
    n_agents: int = 1,
    **env_kwargs,
) -> dict:
    """Run the planner for ``episodes`` episodes and save (observation, action) pairs to ``path``.
    Returns a summary (steps, mean coverage, success rate).

    With ``n_agents`` > 1 the team planner runs in the PettingZoo team env (one planner per robot,
    each told its seat) and every robot's pairs are recorded, robot after robot at each step: the
    demonstrations of a shared team policy. ``env_kwargs`` are the env's (the team env's for a team;
    ``max_steps`` is its step limit either way).

    With ``action_noise`` > 0 the env executes the planner's action plus Gaussian noise of that
    std (clipped to [-1, 1]), while the planner's own action is what is recorded (DART, Laskey et
    al. 2017). The planner follows its path from the pose it finds, so each episode drifts off the
    path differently and records how the expert gets back: demonstrations that cover the states
    around the path. Without noise, the planner in the deterministic env repeats one trajectory
    in every episode."""
    from cabinbench.envs.coverage_env import observation_config
    from cabinbench.episodes import make_env
    from cabinbench.layouts.resolve import load_layout

    protocol = env_kwargs.pop("protocol", "sequential")
    env = make_env(load_layout(layout), protocol, n_agents, env_kwargs)
    observations, actions, episode_of, records = [], [], [], []
    for episode in range(episodes):
        observation, info = env.reset(seed=seed + episode)
        noise = np.random.default_rng([seed, episode])
        planners = {agent: Boustrophedon() for agent in env.agents}
        team_start = np.array([info[agent]["pose"] for agent in env.agents])
        for index, (agent, planner) in enumerate(planners.items()):
            context = EpisodeContext(
                env.unwrapped.layout,
                protocol,
                seed + episode,
                agent=index,
                n_agents=n_agents,
                env_config=env_kwargs,
                observation_layout=env.unwrapped.observation_layout,
                team_start=team_start,
            )
            planner.reset(context, observation[agent], info[agent])
        while env.agents:
            executed = {}
            for agent, planner in planners.items():
                action = np.clip(exact_action(planner, observation[agent], info[agent]), -1, 1)
                observations.append(observation[agent])
                actions.append(action)
                episode_of.append(episode)
                executed[agent] = action + noise.normal(0.0, action_noise, 2) if action_noise > 0 else action
            observation, _, _, _, info = env.step(executed)
        records.append(env.episode_record)
    np.savez_compressed(
        path,
        observations=np.array(observations, dtype=np.float32),
        actions=np.array(actions, dtype=np.float32),
        episode=np.array(episode_of, dtype=np.int32),
        observation_config=np.array(json.dumps(observation_config(env_kwargs, len(observations[0])))),
    )
    return {
        "steps": len(actions),
        "coverage": float(np.mean([r["coverage"] for r in records])),
        "success": float(np.mean([r["success"] for r in records])),
    }
