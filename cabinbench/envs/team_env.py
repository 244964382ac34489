"""Multi-robot coverage env (PettingZoo ``ParallelEnv``), the one env core: :class:`TeamCoverageEnv`."""

from __future__ import annotations

import gymnasium
import numpy as np
from gymnasium.utils import seeding
from pettingzoo import ParallelEnv

from cabinbench.envs.settings import (
    RENDER_MODES,
    EnvSettings,
    action_space,
    checked_action,
    checked_count,
    observation_config,
    observation_space,
    resolved_layout,
)
from cabinbench.layouts.model import Layout
from cabinbench.metrics import EpisodeTracker
from cabinbench.sim.physics import TIME_STEP
from cabinbench.sim.render import EnvRenderer
from cabinbench.sim.rewards import REWARD_PRESETS
from cabinbench.sim.world import World, random_start_poses, start_cell_spots

STATE_ENTRIES_PER_ROBOT = 6  # x, y, cos heading, sin heading, forward speed, turn rate
TEAM_STATE_ENTRIES = 4  # coverage, cells cleared, current cell, elapsed steps


class TeamCoverageEnv(ParallelEnv):
    """Multi-robot coverage env (PettingZoo ``ParallelEnv``): the one env core.

    K >= 1 disc robots clean one airline-cabin layout together: one pymunk space, one shared coverage
    raster. Each robot sees only its own lidar and velocity; the other robots show up in its lidar with
    the tag ``robot``. ``state()`` gives a global view for centralised critics. Create it with
    ``cabinbench.parallel_env(...)``; ``cabinbench.env(...)`` is the same env in AEC form. The
    Gymnasium env (:mod:`cabinbench.envs.coverage_env`) is this env with one robot, seen through
    Gymnasium's API; the batched training envs (:mod:`cabinbench.envs.batch_engine`) step it directly
    (:meth:`TeamCoverageEnv.advance`).

    **Agents**: ``robot_0`` … ``robot_{K-1}``; ``robot_0`` starts at the layout's start pose, the
    others at the nearest free spots of the start cell (deterministic, at least a robot diameter plus
    5 cm apart). With ``random_start`` every reset draws the K poses from its seed instead (random
    free spots of the start cell as far apart, uniform headings). Asking for more robots than the
    start cell holds raises ``ValueError``.

    **Action** (per agent): ``Box(-1, 1, (2,), float32)`` = (linear, angular), scaled by the robot's
    ``max_speed`` and ``max_turn_rate``. Out-of-range values are clipped; NaN, infinite or complex
    values raise ``ValueError``. An agent whose action is missing from the dict (or ``None``) stands
    still for that step: it does not move, turn or clean, but it still collides and is still rewarded.

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
    ``max_steps``, and one reached flag (0 or 1) per goal marker of the layout.

    **Reward** (per agent, :func:`cabinbench.sim.rewards.reward` on that robot's events):

    - ``paper`` (the study's Tables 4.4/4.5, for teams): +0.5 per goal marker this robot reached, -0.3 per
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
    on a bound contact of any robot if ``terminate_on_bound``, or when any robot reaches an exit
    landmark if ``terminate_on_exit``; every agent is truncated after ``max_steps`` steps. Agents are
    never removed one by one: all leave ``agents`` together on the last step, and ``step`` after that
    raises until ``reset``.
    Each step is 0.1 simulated seconds.

    **Info** (per agent): that robot's own ``path_length``, ``collisions`` (obstacle contacts),
    ``robot_collisions`` (contacts with other robots), ``bound_violations`` and ``pose`` = (x, y,
    heading) (for planners, not learners); the team's ``coverage``, ``time``, ``steps``,
    ``cells_cleared``, ``current_cell`` and ``success``. Every value is a numpy scalar or array, and
    every step's info has the reset's keys, as clients that build a spec from the reset require
    (TorchRL's ``PettingZooWrapper`` converts every value with ``torch.tensor``; Minari's
    ``record_infos`` stacks them). The team's episode record (:mod:`cabinbench.metrics`, with the team
    metrics ``n_agents``, ``robot_collisions``, ``path_lengths``, ``makespan`` and ``load_balance`` when
    K > 1; ``None`` for a ``t90`` never reached) is ``env.episode_record`` once the episode ends
    (``None`` before); with ``record_in_info=True`` the last step's info of every agent also carries it
    as ``episode_record`` (the keys then change on that step).

    **Copies**: ``copy.deepcopy`` and pickle give an env that continues exactly as the original.

    **Arguments**: ``layout`` (registered name, YAML path or a :class:`~cabinbench.layouts.model.Layout`),
    ``n_agents`` (K), and the settings of :class:`~cabinbench.envs.settings.EnvSettings` as keywords
    (or ``settings=EnvSettings(...)``): ``protocol`` (``"sequential"`` or ``"open"``), ``reward``
    (``"paper"`` or ``"coverage"``), ``n_rays``, ``lidar_range`` (m), ``field_of_view`` (rad),
    ``lidar_noise`` (m, Gaussian; drawn from the reset seed), ``coverage_patch`` (cells per side, 0:
    none) and ``coverage_patch_cell`` (m), ``max_steps`` (default: the layout's; ``max_cycles``, the
    name PettingZoo's tests pass, is taken for it), ``terminate_on_bound``, ``terminate_on_exit``,
    ``random_start``, ``team_weight``, ``record_in_info``, ``render_mode`` (``"rgb_array"`` or ``"human"``).
    """

    metadata = {
        "name": "cabinbench_team_v0",
        "render_modes": list(RENDER_MODES),
        "is_parallelizable": True,
        "render_fps": 10,
    }

    def __init__(
        self,
        layout: str | Layout = "a320_cell",
        n_agents: int = 2,
        settings: EnvSettings | None = None,
        **overrides,
    ):
        if "max_cycles" in overrides:  # PettingZoo's name for the step limit: its max_cycles_test passes it
            if "max_steps" in overrides:
                raise TypeError("give the step limit once: max_steps or max_cycles, not both")
            overrides["max_steps"] = overrides.pop("max_cycles")
        self.settings = EnvSettings.of(settings, overrides)
        # the preset's function (cabinbench.sim.rewards): a robot's step events -> its reward
        self._reward_of = REWARD_PRESETS[self.settings.reward]
        self.n_agents = checked_count(n_agents, "n_agents")
        self.render_mode = self.settings.render_mode
        self.use_layout(resolved_layout(layout))  # raises when K robots do not fit its start cell

        self.possible_agents = [f"robot_{index}" for index in range(n_agents)]
        self.agents: list[str] = []
        self._index = {agent: index for index, agent in enumerate(self.possible_agents)}
        # One space object per agent, built once: PettingZoo requires the same object on every
        # call, and separate objects let each agent's space be seeded on its own.
        size = self.world.observation_size
        self.observation_spaces = {agent: observation_space(size) for agent in self.possible_agents}
        self.action_spaces = {agent: action_space() for agent in self.possible_agents}
        self.observation_layout = self.world.observation_layout  # part name -> slice, as every agent's
        self.observation_config = observation_config(vars(self.settings), size)
        self.state_space = self._state_space()

        self.np_random: np.random.Generator | None = None
        self.tracker: EpisodeTracker | None = None
        self.episode_record: dict | None = None
        self.renderer = EnvRenderer(self.render_mode)

    def use_layout(self, layout: Layout) -> None:
        """Play on ``layout`` from the next reset on (the observation's shape does not depend on it)."""
        settings = self.settings
        self.layout = layout
        self.world = World(layout, self.n_agents, settings.protocol, settings.lidar(), settings.patch())
        self.start_spots = start_cell_spots(layout) if settings.random_start else None
        self.max_steps = settings.max_steps or layout.max_steps

    def observation_space(self, agent: str) -> gymnasium.spaces.Box:
        return self.observation_spaces[agent]

    def action_space(self, agent: str) -> gymnasium.spaces.Box:
        return self.action_spaces[agent]

    def _state_space(self) -> gymnasium.spaces.Box:
        robots = self.n_agents
        size = STATE_ENTRIES_PER_ROBOT * robots + TEAM_STATE_ENTRIES + self.world.n_goals
        low = np.zeros(size, dtype=np.float32)
        per_robot = low[: STATE_ENTRIES_PER_ROBOT * robots].reshape(robots, STATE_ENTRIES_PER_ROBOT)
        per_robot[:, 2:] = -1.0  # heading cos/sin and the velocities are signed
        return gymnasium.spaces.Box(low, np.ones(size, dtype=np.float32), dtype=np.float32)

    # ----------------------------------------------------------------------------- episode
    def reset(self, seed: int | None = None, options: dict | None = None):
        self.begin_episode(seed)
        self.agents = self.possible_agents[:]
        if self.render_mode == "human":
            self.render()
        return self.agent_observations(), self.agent_infos()

    def begin_episode(self, seed: int | None = None) -> None:
        """Reset the world without building observations (the batched envs observe in place)."""
        self.seed_generator(seed)
        start = None
        if self.start_spots is not None:
            start = random_start_poses(self.layout, self.start_spots, self.n_agents, self.np_random)
        self.world.reset(self.np_random, start)
        self.tracker = EpisodeTracker(self.world, self.max_steps)
        self.episode_record = None
        # The tracker sums contacts over the team; infos report them per robot.
        # obstacle, robot, bound: numpy scalars, as the infos give them (made once, not at every step)
        self._contacts = [[np.int64(0)] * 3 for _ in range(self.n_agents)]

    def seed_generator(self, seed: int | None) -> None:
        """Gymnasium's convention: a seed re-seeds; no seed keeps the generator (seeding it once)."""
        if seed is not None or self.np_random is None:
            self.np_random, _ = seeding.np_random(seed)

    def step(self, actions: dict):
        if not self.agents:
            raise RuntimeError("no live agents: call reset() before step()")
        if not isinstance(actions, dict):
            raise ValueError(
                f"actions must be a dict of agent name to action, as {{'robot_0': [1, 0]}}, got {actions!r}"
            )
        commands = np.zeros((self.n_agents, 2))
        for agent, action in actions.items():
            if agent not in self._index:
                raise ValueError(f"unknown agent {agent!r}; the agents are {self.possible_agents}")
            if action is not None:
                commands[self._index[agent]] = checked_action(action, name=f"the action of {agent}")[0]
        rewards, terminated, truncated = self.advance(commands)
        observations, infos = self.agent_observations(), self.step_infos(terminated or truncated)
        if terminated or truncated:
            self.agents = []
        return (
            observations,
            dict(zip(self.possible_agents, rewards)),
            dict.fromkeys(self.possible_agents, terminated),
            dict.fromkeys(self.possible_agents, truncated),
            infos,
        )

    def advance(self, commands: np.ndarray) -> tuple[list[float], bool, bool]:
        """One step on checked (K, 2) ``commands`` (:func:`~cabinbench.envs.settings.checked_action`),
        without building observations and infos: (each robot's reward, terminated, truncated). The
        episode's record is kept in ``episode_record`` when it ends."""
        if self.tracker is None:
            raise RuntimeError("call reset() before step()")
        settings, world = self.settings, self.world
        events = world.step(commands)
        self.tracker.update(events)
        for contacts, robot in zip(self._contacts, events.robots):
            if robot.collisions or robot.robot_collisions or robot.bound_violations:  # rare: most steps skip
                contacts[0] += robot.collisions
                contacts[1] += robot.robot_collisions
                contacts[2] += robot.bound_violations
        reward_of, pixels, team_weight = self._reward_of, world.coverable_pixels, settings.team_weight
        rewards = [reward_of(events, index, pixels, team_weight) for index in range(self.n_agents)]
        terminated = bool(
            events.success
            or (settings.terminate_on_bound and any(robot.bound_violations for robot in events.robots))
            or (settings.terminate_on_exit and any(robot.exits_reached for robot in events.robots))
        )
        truncated = not terminated and self.tracker.steps >= self.max_steps
        if terminated or truncated:
            self.episode_record = self.tracker.record()
        if self.render_mode == "human":
            self.render()
        return rewards, terminated, truncated

    def agent_observations(self) -> dict:
        return {agent: self.world.observe(index) for agent, index in self._index.items()}

    def agent_infos(self) -> dict:
        """Every agent's info (see the module docstring): the same keys at every step."""
        tracker, world = self.tracker, self.world
        team = {
            "coverage": np.float64(world.coverage),
            "time": np.float64(tracker.steps * TIME_STEP),
            "steps": np.int64(tracker.steps),
            "cells_cleared": np.int64(world.cells_cleared),
            "current_cell": np.int64(world.current_cell),
            "success": np.bool_(world.success),
        }
        poses, path_lengths, contacts = world.poses, tracker.path_lengths, self._contacts
        return {
            agent: {
                **team,
                "path_length": path_lengths[index],  # a numpy float64
                "collisions": contacts[index][0],  # obstacles
                "robot_collisions": contacts[index][1],
                "bound_violations": contacts[index][2],
                "pose": poses[index].copy(),
            }
            for agent, index in self._index.items()
        }

    def step_infos(self, ended: bool) -> dict:
        """A step's infos: with ``record_in_info``, the last step's carry the episode record."""
        infos = self.agent_infos()
        if ended and self.settings.record_in_info:
            for info in infos.values():
                info["episode_record"] = self.episode_record
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
            min(1.0, self.tracker.steps / self.max_steps),
        ]
        state = np.concatenate([per_robot.ravel(), team, world.goal_reached]).astype(np.float32)
        # contacts can push a robot a little faster than commanded: keep the state in its space
        return np.clip(state, self.state_space.low, self.state_space.high)

    # ------------------------------------------------------------------------------ render
    def render(self):
        return self.renderer.render(self.world, self.tracker.trajectory() if self.tracker else None)

    def close(self):
        self.renderer.close()
