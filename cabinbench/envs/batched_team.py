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
criterion, ``truncated`` after ``max_steps`` (default the layout's).
The env is then reset and its rows hold the new episode's first observations.

## Arguments

``layout`` (a name, path or :class:`~cabinbench.layouts.model.Layout`, or a list of them), ``num_envs``
(team envs), ``n_agents`` (K), ``seed``, ``num_workers`` (as the single-robot batch's: the same
results on any number of processes), and the team env's settings
(:class:`~cabinbench.envs.settings.EnvSettings`: ``protocol``, ``reward``, lidar and patch settings,
``max_steps``, ``team_weight``, ``random_start`` ...).

## Implementation

The batch engine (:mod:`cabinbench.envs.batch_engine`) with K robots per env and the state rows,
as :class:`~cabinbench.envs.batched.BatchedCoverageEnv` is with one robot.
"""

from __future__ import annotations

import torch
from tensordict import TensorDict

from cabinbench.envs.batch_engine import BatchedEnv
from cabinbench.envs.batched import RslRlVecEnv
from cabinbench.envs.settings import EnvSettings


class BatchedTeamEnv(BatchedEnv):
    """See the module docstring. ``step`` returns (observations, rewards, terminated, truncated,
    finished) like :class:`~cabinbench.envs.batched.BatchedCoverageEnv`, ``finished`` listing (env
    index, team episode record) for every env whose episode ended on this step; ``states`` holds the
    critic's rows. :meth:`episodes` gives each team env's actions as (steps, K, 2)."""

    def __init__(
        self,
        layout="full_cabin",
        num_envs: int = 8,
        n_agents: int = 2,
        seed: int = 0,
        num_workers: int = 1,
        settings: EnvSettings | None = None,
        **overrides,
    ):
        settings = EnvSettings.of(settings, overrides)
        super().__init__(
            layout, num_envs, n_agents, seed, num_workers, None, True, (n_agents, 2), settings, True
        )
        self.state_size = self.batch.state_size


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
