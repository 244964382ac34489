"""Batched team env for training a shared policy: every robot of every team env is one row of the batch.

## Description

``num_envs`` PettingZoo team envs (:class:`~cabinbench.envs.team_env.TeamCoverageEnv`) of ``n_agents``
(K) robots each, stepped in one call. The batch has ``num_envs * K`` rows, robot ``k`` of env ``i``
at row ``i * K + k``: one policy, shared by all robots, acts on each row's own observation
(decentralised execution), and rsl-rl trains it as if every robot were an env of its own. Env ``i``
runs ``layout[i % len(layout)]`` and is seeded ``seed + i`` at its first reset; a finished env is
reset from its own generator (no new seed), so a batch replays exactly from its seed.

## Action Space

``[num_envs * K, 2]`` in [-1, 1], row ``i * K + k`` the action of ``robot_k`` of env ``i``
(linear, angular; clipped; NaN or infinity raise ``ValueError``).

## Observation Space

``observations``: ``[num_envs * K, D]`` float32, each row that robot's own observation, exactly the
team env's (and the single-robot env's) layout (:mod:`cabinbench.sim.observation`): its lidar, the
team's uncleaned floor around it (``coverage_patch``) and its velocity. **What a robot sees of
the others**: only what its lidar returns. A ray that hits another robot carries the ``robot``
tag (and its distance); the patch shows the floor the others have cleaned as clean. It never sees
their poses, actions or observations.

``states``: ``[num_envs * K, S + K]`` float32, for a centralised critic (MAPPO's agent-specific
global state): the env's PettingZoo ``state()`` (every robot's normalised pose and velocity, team
coverage, cells cleared, current cell, elapsed time and the goal markers reached; see the team
env) followed by a one-hot of the row's robot index, so the critic knows which robot's return it
values. The policy never sees it.

## Rewards

``[num_envs * K]``: each robot's own reward from the team env's preset, for teams
(:mod:`cabinbench.sim.rewards`). With ``coverage`` (the trainer's default): 10 × (the robot's newly
covered fraction of the coverable area + ``team_weight`` × the team's newly covered fraction), -0.1
per contact with an obstacle *or another robot*, -1 per bound contact, -0.005 per step, +1 to every
robot when the team clears a cell, +0.5 per exit it reaches. The shared terms (team coverage, cells)
make it a team reward; the own terms keep each robot's credit.

## Episode End

All K rows of an env end together: ``terminated`` when the team meets the layout's success
criterion, ``truncated`` after ``max_steps`` (the team env's ``max_cycles``; default the layout's).
The env is then reset and its rows hold the new episode's first observations.

## Arguments

``layout`` (a name, path or :class:`~cabinbench.layouts.model.Layout`, or a list of them), ``num_envs``
(team envs), ``n_agents`` (K), ``seed``, ``max_steps``, and the team env's keyword arguments
(``protocol``, ``reward``, lidar and patch settings, ``team_weight``, ``random_start``).
"""

from __future__ import annotations

import numpy as np
import torch
from tensordict import TensorDict

from cabinbench.envs.batched import EpisodeLog, RslRlVecEnv
from cabinbench.envs.coverage_env import checked_action, checked_count, observation_config
from cabinbench.envs.team_env import TeamCoverageEnv


class BatchedTeamEnv:
    """See the module docstring. ``step`` returns (observations, rewards, terminated, truncated,
    finished) like :class:`~cabinbench.envs.batched.BatchedCoverageEnv`, ``finished`` listing (env
    index, team episode record) for every env whose episode ended on this step."""

    def __init__(
        self,
        layout="full_cabin",
        num_envs: int = 8,
        n_agents: int = 2,
        seed: int = 0,
        max_steps: int | None = None,
        **env_kwargs,
    ):
        names = list(layout) if isinstance(layout, (list, tuple)) else [layout]
        self.n_agents, self.num_teams = n_agents, checked_count(num_envs, "num_envs")
        self.num_envs = num_envs * n_agents  # rows: what rsl-rl calls envs
        self.envs = [
            TeamCoverageEnv(
                names[index % len(names)],
                n_agents=n_agents,
                max_cycles=max_steps,
                record_in_info=False,
                **env_kwargs,
            )
            for index in range(num_envs)
        ]
        example = self.envs[0]
        self.layout_names = sorted({env.layout.name for env in self.envs[: len(names)]})
        self.max_steps_per_env = [env.max_cycles for env in self.envs for _ in range(n_agents)]
        self.observation_layout = example.observation_layout
        self.observation_size = example.observation_space("robot_0").shape[0]
        self.observation_config = observation_config(env_kwargs, self.observation_size)
        self.state_size = example.state_space.shape[0] + n_agents
        self.observations = np.zeros((self.num_envs, self.observation_size), dtype=np.float32)
        self.states = np.zeros((self.num_envs, self.state_size), dtype=np.float32)
        self.states[:, -n_agents:] = np.tile(np.eye(n_agents, dtype=np.float32), (num_envs, 1))
        self.log = EpisodeLog([seed + index for index in range(num_envs)])
        for index, env in enumerate(self.envs):
            self._write(index, env.reset(seed=seed + index)[0])

    def _write(self, index: int, observations: dict) -> None:
        """Env ``index``'s rows: each robot's observation and the env's state."""
        rows = slice(index * self.n_agents, (index + 1) * self.n_agents)
        env = self.envs[index]
        self.observations[rows] = [observations[agent] for agent in env.possible_agents]
        self.states[rows, : -self.n_agents] = env.state()

    def step(self, actions):
        if isinstance(actions, torch.Tensor):
            actions = actions.detach().cpu()
        actions = checked_action(actions, (self.num_envs, 2)).reshape(self.num_teams, self.n_agents, 2)
        rewards = np.zeros(self.num_envs, dtype=np.float32)
        terminated = np.zeros(self.num_envs, dtype=np.bool_)
        truncated = np.zeros(self.num_envs, dtype=np.bool_)
        finished = []
        for index, env in enumerate(self.envs):
            rows = slice(index * self.n_agents, (index + 1) * self.n_agents)
            observations, reward, ended, cut, _ = env.step(dict(zip(env.possible_agents, actions[index])))
            rewards[rows] = [reward[agent] for agent in env.possible_agents]
            terminated[rows], truncated[rows] = ended["robot_0"], cut["robot_0"]
            if ended["robot_0"] or cut["robot_0"]:
                finished.append((index, env.episode_record))
                self.log.resetting(index, env)
                observations = env.reset()[0]
            else:
                self.log.acted(index, actions[index])
            self._write(index, observations)
        # copies: callers keep the tensors of earlier steps
        return (
            torch.from_numpy(self.observations.copy()),
            torch.from_numpy(rewards),
            torch.from_numpy(terminated),
            torch.from_numpy(truncated),
            finished,
        )

    def episodes(self) -> list[tuple[dict, np.ndarray]]:
        """Each team env's episode in play (:class:`~cabinbench.envs.batched.EpisodeLog`): (generator
        state, (steps, K, 2) actions)."""
        return self.log.episodes((self.n_agents, 2))

    def restore(self, episodes: list[tuple[dict, np.ndarray]]) -> torch.Tensor:
        """Replay ``episodes`` (as :meth:`episodes` returns them) into the team envs; returns the
        observations."""
        for index, (env, episode) in enumerate(zip(self.envs, episodes, strict=True)):
            actions = self.log.rewind(index, env, episode, (self.n_agents, 2))
            observations = env.reset()[0]
            for action in actions:
                observations, _, ended, cut, _ = env.step(dict(zip(env.possible_agents, action)))
                if ended["robot_0"] or cut["robot_0"]:
                    raise EpisodeLog.replay_ended(f"team env {index}")
                self.log.acted(index, action)
            self._write(index, observations)
        return torch.from_numpy(self.observations.copy())

    def close(self) -> None:
        for env in self.envs:
            env.close()


class RslRlTeamVecEnv(RslRlVecEnv):
    """``rsl_rl.env.VecEnv`` over a :class:`BatchedTeamEnv`: the observation groups ``policy`` (each
    robot's own observation) and ``state`` (the centralised critic's input, see the module
    docstring). ``extras["log"]`` averages the team records of the episodes that ended."""

    def __init__(self, batched: BatchedTeamEnv):
        super().__init__(batched)
        self.cfg["n_agents"] = batched.n_agents

    def _with_state(self, observations: TensorDict) -> TensorDict:
        observations["state"] = torch.from_numpy(self.env.states.copy())
        return observations

    def get_observations(self) -> TensorDict:
        return self._with_state(super().get_observations())

    def step(self, actions: torch.Tensor):
        observations, rewards, dones, extras = super().step(actions)
        return self._with_state(observations), rewards, dones, extras
