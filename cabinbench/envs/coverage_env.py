"""Single-robot coverage env (Gymnasium).

## Description

A disc robot cleans an airline-cabin layout, seeing only its own lidar and velocity (seed §4.3.2:
global coordinates do not generalise across cabins). Made by ``gymnasium.make("CabinBench/A320Cell-v0")``
(one id per built-in layout) or ``gymnasium.make("CabinBench/Coverage-v0", layout=...)``.

## Action Space

``Box(-1, 1, (2,), float32)``:

| Index | Action  | Min | Max | Unit once scaled                                    |
|-------|---------|-----|-----|-----------------------------------------------------|
| 0     | linear  | -1  | 1   | × ``max_speed``: forward speed, m/s (negative backs) |
| 1     | angular | -1  | 1   | × ``max_turn_rate``: turn rate, rad/s, counter-clockwise |

Out-of-range values are clipped to [-1, 1]. An action of another shape (``(4,)``, ``(2, 1)``,
``()``), NaN or infinity raises ``ValueError`` (a silent zero would hide a diverged policy).

## Observation Space

``Box(float32, (6 * n_rays + coverage_patch² + 2,))``; ``env.unwrapped.observation_layout`` maps
each part to its slice (:mod:`cabinbench.sim.observation`; read observations through it). With R =
``n_rays`` and P = ``coverage_patch`` (P = 0: no patch part):

| Index            | Part               | Observation                                       | Min | Max |
|------------------|--------------------|---------------------------------------------------|-----|-----|
| 6r               | ``lidar``          | ray r: hit distance / ``lidar_range`` (1: no hit) | 0   | 1   |
| 6r + 1 … 6r + 5  | ``lidar``          | ray r: one-hot of the hit's tag (0s: no hit)      | 0   | 1   |
| 6R … 6R + P² - 1 | ``coverage_patch`` | uncleaned fraction of each patch cell             | 0   | 1   |
| 6R + P²          | ``velocity``       | achieved forward speed / ``max_speed``            | -1  | 1   |
| 6R + P² + 1      | ``velocity``       | achieved turn rate / ``max_turn_rate``            | -1  | 1   |

The lidar part is ray-major, its 6 channels per ray (distance, then the tags ``obstacle, bound,
goal, exit, robot``) named by
:data:`cabinbench.sim.observation.LIDAR_CHANNELS` (read one with
:func:`~cabinbench.sim.observation.lidar_channel`); the design's ``lidar_distance`` and ``lidar_tags``
are not separate slices because the shipped policies were trained on this interleaved order. Rays
spread evenly over ``field_of_view``, starting behind the robot and turning counter-clockwise.
The coverage patch is an egocentric window of P × P cells of ``coverage_patch_cell`` metres,
centred on the robot and turned with it (:class:`~cabinbench.sim.coverage.CoveragePatch`; row-major,
rows from behind to ahead, columns from right to left; in ``sequential`` only the current cell's
floor counts, and the next cell's once its passage is open; never that of cells the layout starts
cleared). Bounds are seen only while closed, goal markers only while unreached (in
``sequential``: only those of the current cell), exits only while their passage is open.

## Rewards

The preset named by ``reward`` (:mod:`cabinbench.sim.rewards`): ``paper`` (seed Tables 4.4/4.5: +0.5
per new goal marker, -0.3 per contact, -10 per bound contact, -0.01 per step, +2 for reaching an
exit; on the step that clears a cell the reward is set to 3) or ``coverage`` (dense: +10 × the
newly covered fraction of the coverable area, contact -0.1, bound -1, step -0.005, cell +1, exit
+0.5).

## Starting State

The layout's start pose; with ``random_start``, a pose drawn from the env's seeded generator at
each reset: the centre of a random pixel of the start cell where the robot fits and that the start
reaches, and a uniform heading (for training: from one fixed start a policy can learn one route
rather than a behaviour). ``lidar_noise`` is drawn from the same generator.

## Episode End

Terminated when the layout's success criterion is met (``sequential``: every cell cleared;
``open``: coverage ≥ the layout's ``success_coverage``), on a bound contact if
``terminate_on_bound``, or on reaching an exit landmark if ``terminate_on_exit`` (the seed's tracking
training, Table 4.5, ends there); truncated after ``max_steps`` (default: the layout's). Each step is 0.1
simulated seconds.

## Info

The running metrics (``coverage``, ``path_length``, ``time``, ``steps``, ``collisions``,
``bound_violations``, ``cells_cleared``, ``current_cell``, ``success``) and ``pose`` = (x, y,
heading) for planners (not for learners: it is not part of the observation). The last step's info
carries ``episode_record``, one value per metric of :mod:`cabinbench.metrics` (``None`` for a
``t90`` never reached).

## Copies

``copy.deepcopy`` and pickle give an env that continues exactly as the original (the physics
replays the episode's commands: :mod:`cabinbench.sim.physics`).

## Arguments

``layout`` (registered name, YAML path or a :class:`~cabinbench.layouts.model.Layout`), ``protocol``
(``"sequential"`` or ``"open"``), ``reward`` (``"paper"`` or ``"coverage"``), ``n_rays``,
``lidar_range`` (m), ``field_of_view`` (rad), ``lidar_noise`` (m, Gaussian), ``coverage_patch``
(cells per side, 0: none), ``coverage_patch_cell`` (m), ``max_steps``, ``terminate_on_bound``,
``terminate_on_exit``, ``random_start``, ``render_mode`` (``"rgb_array"``: uint8 H × W × 3, or ``"human"``).
"""

from __future__ import annotations

import inspect
import math

import gymnasium as gym
import numpy as np

from cabinbench.layouts.model import Layout
from cabinbench.layouts.resolve import load_layout
from cabinbench.metrics import EpisodeTracker
from cabinbench.sim.coverage import CoveragePatch
from cabinbench.sim.lidar import LidarConfig
from cabinbench.sim.render import EnvRenderer
from cabinbench.sim.rewards import REWARD_PRESETS, reward
from cabinbench.sim.world import World, random_start_poses, start_cell_spots
from cabinbench.values import is_whole_number

OBSERVATION_SETTINGS = ("n_rays", "lidar_range", "field_of_view", "coverage_patch", "coverage_patch_cell")
"""The arguments (of this env and the team env) that shape the observation."""


def observation_config(env_kwargs: dict, size: int) -> dict:
    """The observation settings of an env made with ``env_kwargs`` (``CoverageEnv``'s defaults for
    those not given) and the observation's size: what a policy or demonstrations must have been
    recorded with to fit the env."""
    defaults = {
        name: parameter.default for name, parameter in inspect.signature(CoverageEnv).parameters.items()
    }
    return {
        **{name: env_kwargs.get(name, defaults[name]) for name in OBSERVATION_SETTINGS},
        "size": int(size),
    }


def checked_action(action, shape: tuple[int, ...] = (2,), name: str = "action") -> np.ndarray:
    """The documented action policy: ``action`` must have ``shape`` (the last axis is (linear,
    angular)); values are clipped to [-1, 1]; NaN and infinity are refused. Returns (robots, 2)."""
    action = np.asarray(action, dtype=np.float64)
    if action.shape != shape:
        raise ValueError(f"{name} must have shape {shape} (linear, angular), got shape {action.shape}")
    if not np.isfinite(action).all():
        raise ValueError(f"{name} contains NaN or infinity: {action.tolist()}")
    return np.clip(action, -1.0, 1.0).reshape(-1, 2)


def checked_count(value, name: str, note: str = "") -> int:
    """``value`` of the argument ``name`` if it is a whole number >= 1, else a ValueError naming it."""
    if not (is_whole_number(value) and value >= 1):
        raise ValueError(f"{name} must be a whole number >= 1{note}, got {value!r}")
    return value


def checked_step_limit(steps: int | None, name: str = "max_steps") -> int | None:
    """A step limit as given: None (the layout's own) or a whole number >= 1."""
    return None if steps is None else checked_count(steps, name, " (None: the layout's)")


def observation_space(size: int) -> gym.spaces.Box:
    """Ray blocks lie in [0, 1]; the two velocity entries in [-1, 1]."""
    low = np.zeros(size, dtype=np.float32)
    low[-2:] = -1.0
    return gym.spaces.Box(low, np.ones(size, dtype=np.float32), dtype=np.float32)


class CoverageEnv(gym.Env):
    metadata = {"render_modes": ["rgb_array", "human"], "render_fps": 10}

    def __init__(
        self,
        layout: str | Layout = "a320_cell",
        protocol: str = "sequential",
        reward: str = "paper",
        n_rays: int = 64,
        lidar_range: float = 3.5,
        field_of_view: float = 2 * math.pi,
        lidar_noise: float = 0.0,
        coverage_patch: int = 0,
        coverage_patch_cell: float = 0.25,
        max_steps: int | None = None,
        terminate_on_bound: bool = False,
        terminate_on_exit: bool = False,
        random_start: bool = False,
        render_mode: str | None = None,
    ):
        lidar = LidarConfig(n_rays, lidar_range, field_of_view, lidar_noise)
        self._world_settings = (protocol, lidar, CoveragePatch(coverage_patch, coverage_patch_cell))
        self._step_limit, self._random_start = checked_step_limit(max_steps), random_start
        self.use_layout(layout if isinstance(layout, Layout) else load_layout(layout))
        if reward not in REWARD_PRESETS:
            raise ValueError(f"unknown reward preset {reward!r}; choose one of {REWARD_PRESETS}")
        self.reward_preset, self.terminate_on_bound = reward, terminate_on_bound
        self.terminate_on_exit = terminate_on_exit
        self.start_spots = start_cell_spots(self.layout) if random_start else None
        self.max_steps = max_steps or self.layout.max_steps
        self.render_mode = render_mode
        self.observation_space = observation_space(self.world.observation_size)
        self.observation_layout = self.world.observation_layout  # part name -> slice
        self.observation_config = observation_config(
            {
                "n_rays": n_rays,
                "lidar_range": lidar_range,
                "field_of_view": field_of_view,
                "coverage_patch": coverage_patch,
                "coverage_patch_cell": coverage_patch_cell,
            },
            self.world.observation_size,
        )
        self.action_space = gym.spaces.Box(-1.0, 1.0, (2,), np.float32)
        self.tracker: EpisodeTracker | None = None
        self.renderer = EnvRenderer(render_mode)

    def use_layout(self, layout: Layout) -> None:
        """Play on ``layout`` from the next reset on (the observation's shape does not depend on it)."""
        self.layout = layout
        self.world = World(layout, 1, *self._world_settings)
        self.start_spots = start_cell_spots(layout) if self._random_start else None
        self.max_steps = self._step_limit or layout.max_steps

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        start = None
        if self.start_spots is not None:
            start = random_start_poses(self.layout, self.start_spots, 1, self.np_random)
        self.world.reset(self.np_random, start)
        self.tracker = EpisodeTracker(self.world, self.max_steps)
        if self.render_mode == "human":
            self.render()
        return self.world.observe(0), self._info()

    def step(self, action):
        step_reward, terminated, truncated = self.advance(checked_action(action))
        info = self._info()
        if terminated or truncated:
            info["episode_record"] = self.tracker.record()
        if self.render_mode == "human":
            self.render()
        return self.world.observe(0), step_reward, terminated, truncated, info

    def advance(self, action: np.ndarray) -> tuple[float, bool, bool]:
        """One step without building the observation and info: (reward, terminated, truncated).
        ``action`` must already be checked. The batched env steps through this."""
        if self.tracker is None:
            raise RuntimeError("call reset() before step()")
        events = self.world.step(action)
        self.tracker.update(events)
        step_reward = reward(self.reward_preset, events, 0, self.world.coverable_pixels)
        robot = events.robots[0]
        terminated = (
            events.success
            or (self.terminate_on_bound and robot.bound_violations > 0)
            or (self.terminate_on_exit and robot.exits_reached > 0)
        )
        truncated = not terminated and self.tracker.steps >= self.max_steps
        return step_reward, terminated, truncated

    def _info(self) -> dict:
        return {**self.tracker.running(), "pose": self.world.poses[0].copy()}

    def render(self):
        return self.renderer.render(self.world, self.tracker.trajectory() if self.tracker else None)

    def close(self):
        self.renderer.close()
