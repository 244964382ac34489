"""Multi-robot coverage env (PettingZoo ``ParallelEnv``).

K disc robots clean one airline-cabin layout together: one pymunk space, one shared coverage
raster. Each robot sees only its own lidar and velocity, exactly as in the single-robot env
(:mod:`cabinbench.envs.coverage_env`); the other robots show up in its lidar with the tag
``robot``. ``state()`` gives a global view for centralised critics. Create it with
``cabinbench.parallel_env(...)``; ``cabinbench.env(...)`` is the same env in AEC form.

**Agents**: ``robot_0`` … ``robot_{K-1}``; ``robot_0`` starts at the layout's start pose, the
others at the nearest free spots of the start cell (deterministic, at least a robot diameter plus
5 cm apart). With ``random_start`` every reset draws the K poses from its seed instead (random
free spots of the start cell as far apart, uniform headings). Asking for more robots than the
start cell holds raises ``ValueError``.

**Action** (per agent): ``Box(-1, 1, (2,), float32)`` = (linear, angular), scaled by the robot's
``max_speed`` and ``max_turn_rate``. Out-of-range values are clipped; NaN or infinite values
raise ``ValueError``. An agent whose action is missing from the dict (or ``None``) stands still
for that step: it does not move, turn or clean, but it still collides and is still rewarded.

**Observation** (per agent): ``Box(float32, (6 * n_rays + coverage_patch² + 2,))``, the single
env's observation of that robot, laid out as ``env.observation_layout`` (part name → slice;
R = ``n_rays``, P = ``coverage_patch``):

| Index            | Part               | Observation                                                 |
|------------------|--------------------|-------------------------------------------------------------|
| 6r … 6r + 5      | ``lidar``          | ray r: distance / range, one-hot of the hit's tag           |
| 6R … 6R + P² - 1 | ``coverage_patch`` | only if P > 0: the team's uncleaned floor around the robot  |
| 6R + P², + 1     | ``velocity``       | forward speed / ``max_speed``, turn rate / ``max_turn_rate`` |

The lidar part is ray-major (the shipped policies' order), so it is one slice, not the design's
``lidar_distance`` and ``lidar_tags``: see :mod:`cabinbench.envs.coverage_env` and
:mod:`cabinbench.sim.observation`.

What a robot sees of the others: only what its lidar returns (a ray that hits a robot carries the
``robot`` tag and its distance) and, with a patch, the floor they cleaned shown as clean. Never
their poses, actions or observations: a policy acting on one robot's observation runs unchanged on
every robot (decentralised execution; :mod:`cabinbench.envs.batched_team` trains one that way).

**State** (``state()``, ``state_space``): ``Box(float32, (6 * K + 4 + n_goals,))``. Per robot,
in agent order: x and y normalised by the layout's extent to [0, 1], cos and sin of the heading,
forward speed / ``max_speed`` and turn rate / ``max_turn_rate`` (clipped to [-1, 1]). Then the
team coverage, the fraction of cells cleared, current cell / number of cells, steps /
``max_cycles``, and one reached flag (0 or 1) per goal marker of the layout.

**Reward** (per agent, :func:`cabinbench.sim.rewards.reward` on that robot's events):

- ``paper`` (seed Tables 4.4/4.5, for teams): +0.5 per goal marker this robot reached, -0.3 per
  contact with an obstacle or another robot, -10 per bound contact, -0.01 per step, +2 for
  reaching an exit; on a step in which the team clears a cell every robot's reward is *set* to 3.
- ``coverage`` (dense): 10 × (this robot's newly covered fraction of the coverable area +
  ``team_weight`` × the team's newly covered fraction, own area included), -0.1 per contact,
  -1 per bound contact, -0.005 per step, +1 per cell the team clears (paid to every robot),
  +0.5 per exit reached.

Both mix a team reward (cells cleared, and with ``coverage`` the team's new area) with the robot's
own terms (its area, its contacts), so each robot is credited for its part of the team's work.

**Episode end**: every agent is terminated when the team meets the layout's success criterion
(``sequential``: every cell cleared; ``open``: coverage ≥ the layout's ``success_coverage``);
every agent is truncated after ``max_cycles`` steps. Agents are never removed one by one: all
leave ``agents`` together on the last step, and ``step`` after that raises until ``reset``.
Each step is 0.1 simulated seconds.

**Info** (per agent): that robot's own ``path_length``, ``collisions`` (obstacle contacts),
``robot_collisions`` (contacts with other robots), ``bound_violations`` and ``pose`` = (x, y,
heading) (for planners, not learners); the team's ``coverage``, ``time``, ``steps``,
``cells_cleared``, ``current_cell`` and ``success``. The last step's info of every agent carries
the team's ``episode_record`` (:mod:`cabinbench.metrics`, with the team metrics ``n_agents``,
``robot_collisions``, ``path_lengths``, ``makespan`` and ``load_balance`` when K > 1; ``None`` for
a ``t90`` never reached); ``env.episode_record`` holds it too (``None`` until the episode ends).
With ``record_in_info=False`` the infos leave it out: every step's info then has the reset's keys,
each a number or an array, as TorchRL's ``PettingZooWrapper`` requires (it converts every info
value with ``torch.tensor`` into the spec it built from the reset's infos).

**Copies**: ``copy.deepcopy`` and pickle give an env that continues exactly as the original.

**Arguments**: ``layout`` (registered name, YAML path or a :class:`~cabinbench.layouts.model.Layout`),
``n_agents`` (K), ``protocol`` (``"sequential"`` or ``"open"``), ``reward`` (``"paper"`` or
``"coverage"``), ``n_rays``, ``lidar_range`` (m), ``field_of_view`` (rad), ``lidar_noise`` (m,
Gaussian; the only randomness, drawn from the reset seed), ``coverage_patch`` (cells per side, 0:
none) and ``coverage_patch_cell`` (m), ``max_cycles`` (default: the
layout's ``max_steps``), ``render_mode`` (``"rgb_array"`` or ``"human"``), ``team_weight``,
``record_in_info``, ``random_start``.
"""

from __future__ import annotations

import math

import gymnasium
import numpy as np
from gymnasium.utils import seeding
from pettingzoo import ParallelEnv

from cabinbench.envs.coverage_env import checked_action, checked_count, checked_step_limit, observation_space
from cabinbench.layouts.model import Layout
from cabinbench.layouts.resolve import load_layout
from cabinbench.metrics import EpisodeTracker
from cabinbench.sim.coverage import CoveragePatch
from cabinbench.sim.lidar import LidarConfig
from cabinbench.sim.render import EnvRenderer
from cabinbench.sim.rewards import REWARD_PRESETS, reward
from cabinbench.sim.world import World, random_start_poses, start_cell_spots
from cabinbench.values import is_real_number

STATE_ENTRIES_PER_ROBOT = 6  # x, y, cos heading, sin heading, forward speed, turn rate
TEAM_STATE_ENTRIES = 4  # coverage, cells cleared, current cell, elapsed steps


class TeamCoverageEnv(ParallelEnv):
    metadata = {
        "name": "cabinbench_team_v0",
        "render_modes": ["rgb_array", "human"],
        "is_parallelizable": True,
        "render_fps": 10,
    }

    def __init__(
        self,
        layout: str | Layout = "a320_cell",
        n_agents: int = 2,
        protocol: str = "sequential",
        reward: str = "paper",
        n_rays: int = 64,
        lidar_range: float = 3.5,
        field_of_view: float = 2 * math.pi,
        lidar_noise: float = 0.0,
        coverage_patch: int = 0,
        coverage_patch_cell: float = 0.25,
        max_cycles: int | None = None,
        render_mode: str | None = None,
        team_weight: float = 0.5,
        record_in_info: bool = True,
        random_start: bool = False,
    ):
        checked_count(n_agents, "n_agents")
        if reward not in REWARD_PRESETS:
            raise ValueError(f"unknown reward preset {reward!r}; choose one of {REWARD_PRESETS}")
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(
                f"render_mode must be None or one of {self.metadata['render_modes']}, got {render_mode!r}"
            )
        self.layout = layout if isinstance(layout, Layout) else load_layout(layout)
        lidar = LidarConfig(n_rays, lidar_range, field_of_view, lidar_noise)
        patch = CoveragePatch(coverage_patch, coverage_patch_cell)
        self.world = World(self.layout, n_agents, protocol, lidar, patch)  # raises when K robots do not fit
        if not (is_real_number(team_weight) and team_weight >= 0):
            raise ValueError(f"team_weight must be a number >= 0, got {team_weight!r}")
        self.reward_preset, self.team_weight, self.record_in_info = reward, team_weight, record_in_info
        self.max_cycles = checked_step_limit(max_cycles, "max_cycles") or self.layout.max_steps
        self.render_mode = render_mode
        self.start_spots = start_cell_spots(self.layout) if random_start else None

        self.possible_agents = [f"robot_{index}" for index in range(n_agents)]
        self.agents: list[str] = []
        self._index = {agent: index for index, agent in enumerate(self.possible_agents)}
        # One space object per agent, built once: PettingZoo requires the same object on every
        # call, and separate objects let each agent's space be seeded on its own.
        self.observation_layout = self.world.observation_layout  # part name -> slice, as every agent's
        self.observation_spaces = {
            agent: observation_space(self.world.observation_size) for agent in self.possible_agents
        }
        self.action_spaces = {
            agent: gymnasium.spaces.Box(-1.0, 1.0, (2,), np.float32) for agent in self.possible_agents
        }
        self.state_space = self._state_space()

        self.np_random: np.random.Generator | None = None
        self.tracker: EpisodeTracker | None = None
        self.episode_record: dict | None = None
        self.renderer = EnvRenderer(render_mode)

    def observation_space(self, agent: str) -> gymnasium.spaces.Box:
        return self.observation_spaces[agent]

    def action_space(self, agent: str) -> gymnasium.spaces.Box:
        return self.action_spaces[agent]

    def _state_space(self) -> gymnasium.spaces.Box:
        robots = self.world.n_robots
        size = STATE_ENTRIES_PER_ROBOT * robots + TEAM_STATE_ENTRIES + self.world.n_goals
        low = np.zeros(size, dtype=np.float32)
        per_robot = low[: STATE_ENTRIES_PER_ROBOT * robots].reshape(robots, STATE_ENTRIES_PER_ROBOT)
        per_robot[:, 2:] = -1.0  # heading cos/sin and the velocities are signed
        return gymnasium.spaces.Box(low, np.ones(size, dtype=np.float32), dtype=np.float32)

    # ----------------------------------------------------------------------------- episode
    def reset(self, seed: int | None = None, options: dict | None = None):
        # Gymnasium's convention: a seed re-seeds; no seed keeps the generator (seeding it once).
        if seed is not None or self.np_random is None:
            self.np_random, _ = seeding.np_random(seed)
        start = None
        if self.start_spots is not None:
            start = random_start_poses(self.layout, self.start_spots, self.world.n_robots, self.np_random)
        self.world.reset(self.np_random, start)
        self.tracker = EpisodeTracker(self.world, self.max_cycles)
        self.episode_record = None
        # The tracker sums contacts over the team; infos report them per robot.
        self._contacts = np.zeros((self.world.n_robots, 3), dtype=np.int64)  # obstacle, robot, bound
        self.agents = self.possible_agents[:]
        if self.render_mode == "human":
            self.render()
        return self._observations(), self._infos()

    def step(self, actions: dict):
        if not self.agents:
            raise RuntimeError("no live agents: call reset() before step()")
        if not isinstance(actions, dict):
            raise ValueError(
                f"actions must be a dict of agent name to action, as {{'robot_0': [1, 0]}}, got {actions!r}"
            )
        commands = np.zeros((self.world.n_robots, 2))
        for agent, action in actions.items():
            if agent not in self._index:
                raise ValueError(f"unknown agent {agent!r}; the agents are {self.possible_agents}")
            if action is not None:
                commands[self._index[agent]] = checked_action(action, name=f"the action of {agent}")[0]

        events = self.world.step(commands)
        self.tracker.update(events)
        for index, robot in enumerate(events.robots):
            self._contacts[index] += (robot.collisions, robot.robot_collisions, robot.bound_violations)
        rewards = {
            agent: reward(self.reward_preset, events, index, self.world.coverable_pixels, self.team_weight)
            for agent, index in self._index.items()
        }
        terminated = bool(events.success)
        truncated = not terminated and self.tracker.steps >= self.max_cycles
        terminations = dict.fromkeys(self.possible_agents, terminated)
        truncations = dict.fromkeys(self.possible_agents, truncated)
        observations, infos = self._observations(), self._infos()
        if terminated or truncated:
            self.episode_record = self.tracker.record()
            if self.record_in_info:
                for info in infos.values():
                    info["episode_record"] = self.episode_record
            self.agents = []
        if self.render_mode == "human":
            self.render()
        return observations, rewards, terminations, truncations, infos

    def _observations(self) -> dict:
        return {agent: self.world.observe(index) for agent, index in self._index.items()}

    def _infos(self) -> dict:
        team = self.tracker.running()
        poses = self.world.poses
        infos = {}
        for agent, index in self._index.items():
            collisions, robot_collisions, bound_violations = self._contacts[index]
            infos[agent] = {
                **team,
                "path_length": float(self.tracker.path_lengths[index]),
                "collisions": int(collisions),
                "robot_collisions": int(robot_collisions),
                "bound_violations": int(bound_violations),
                "pose": poses[index].copy(),
            }
        return infos

    def state(self) -> np.ndarray:
        if self.tracker is None:
            raise RuntimeError("call reset() before state()")
        world, robot = self.world, self.layout.robot
        xmin, ymin, xmax, ymax = self.layout.extent
        poses = world.poses
        per_robot = np.column_stack(
            [
                (poses[:, 0] - xmin) / (xmax - xmin),
                (poses[:, 1] - ymin) / (ymax - ymin),
                np.cos(poses[:, 2]),
                np.sin(poses[:, 2]),
                world.velocities[:, 0] / robot.max_speed,
                world.velocities[:, 1] / robot.max_turn_rate,
            ]
        )
        cells = len(self.layout.cells)
        team = [
            world.coverage,
            world.cell_cleared.mean(),
            world.current_cell / cells,
            min(1.0, self.tracker.steps / self.max_cycles),
        ]
        state = np.concatenate([per_robot.ravel(), team, world.goal_reached]).astype(np.float32)
        # contacts can push a robot a little faster than commanded: keep the state in its space
        return np.clip(state, self.state_space.low, self.state_space.high)

    # ------------------------------------------------------------------------------ render
    def render(self):
        return self.renderer.render(self.world, self.tracker.trajectory() if self.tracker else None)

    def close(self):
        self.renderer.close()
