"""Single-robot coverage env (Gymnasium).

A disc robot cleans an airline-cabin layout, seeing only its own lidar and velocity (seed §4.3.2:
global coordinates do not generalise across cabins).

**Action**: ``Box(-1, 1, (2,), float32)`` = (linear, angular). Linear × ``max_speed`` is the
forward speed (m/s, negative reverses); angular × ``max_turn_rate`` is the turn rate (rad/s,
counter-clockwise). Out-of-range values are clipped to [-1, 1]; NaN or infinite values raise
``ValueError`` (a silent zero would hide a diverged policy).

**Observation**: ``Box(float32, (6 * n_rays + coverage_patch² + 2,))``. For each lidar ray
(evenly spread over the field of view, starting behind the robot and turning counter-clockwise):
the hit distance divided by the range (1 when nothing is hit), then a one-hot of what was hit, in
the order ``obstacle, bound, goal, exit, robot`` (all zero when nothing is). With
``coverage_patch = n > 0`` come next n × n entries in [0, 1]: an egocentric window of
``coverage_patch_cell``-metre cells centred on the robot and turned with it, each the fraction of
its cell that is floor still to be cleaned (:class:`~cabinbench.coverage.CoveragePatch`; rows from
behind to ahead, columns from right to left; in ``sequential`` only the current cell's floor, and
the next cell's once its passage is open; never that of cells the layout starts cleared). Last
come the achieved forward speed / ``max_speed`` and turn rate / ``max_turn_rate``. Bounds are
shown only while closed, goal markers only while unreached (in ``sequential``: only those of the
current cell), exits only while their passage is open.

**Reward**: the preset named by ``reward`` (:mod:`cabinbench.rewards`): ``paper`` (seed Tables
4.4/4.5) or ``coverage`` (dense, per newly covered area).

**Episode end**: terminated when the layout's success criterion is met (``sequential``: every
cell cleared; ``open``: coverage ≥ the layout's ``success_coverage``), or on a bound contact if
``terminate_on_bound``; truncated after ``max_steps`` (default: the layout's). Each step is
0.1 simulated seconds.

**Info**: the running metrics (``coverage``, ``path_length``, ``time``, ``collisions``,
``cells_cleared`` ...) and ``pose`` = (x, y, heading) for planners (not for learners: it is not
part of the observation). The last step's info carries ``episode_record``, one value per metric
of :mod:`cabinbench.metrics`.

**Start**: the layout's start pose; with ``random_start``, a pose drawn from the env's seeded
generator at each reset: the centre of a random pixel of the start cell where the robot fits and
that the start reaches, and a uniform heading (for training: from one fixed start a policy can
learn one route rather than a behaviour).

**Arguments**: ``layout`` (registered name, YAML path or a :class:`~cabinbench.layout.Layout`),
``protocol`` (``"sequential"`` or ``"open"``), ``reward``, ``n_rays``, ``lidar_range``,
``field_of_view``, ``lidar_noise`` (m, Gaussian), ``coverage_patch`` (cells per side, 0: none),
``coverage_patch_cell`` (m), ``max_steps``, ``terminate_on_bound``, ``random_start``,
``render_mode`` (``"rgb_array"`` or ``"human"``).
"""

from __future__ import annotations

import inspect
import math

import gymnasium as gym
import numpy as np

from ..coverage import CoveragePatch
from ..layout import Layout, load_layout
from ..lidar import LidarConfig
from ..metrics import EpisodeTracker
from ..render import EnvRenderer
from ..rewards import REWARD_PRESETS, reward
from ..world import World, start_cell_spots

OBSERVATION_SETTINGS = ("n_rays", "lidar_range", "field_of_view", "coverage_patch", "coverage_patch_cell")
"""The arguments (of this env and the team env) that shape the observation."""


def observation_config(env_kwargs: dict, size: int) -> dict:
    """The observation settings of an env made with ``env_kwargs`` (``CoverageEnv``'s defaults for those not given)
    and the observation's size: what a policy or demonstrations must have been recorded with to fit the env."""
    defaults = {
        name: parameter.default for name, parameter in inspect.signature(CoverageEnv).parameters.items()
    }
    return {
        **{name: env_kwargs.get(name, defaults[name]) for name in OBSERVATION_SETTINGS},
        "size": int(size),
    }


def checked_action(action, size: int = 2) -> np.ndarray:
    """The documented action policy: clip to [-1, 1]; refuse NaN and infinity."""
    action = np.asarray(action, dtype=np.float64).reshape(-1, size)
    if not np.isfinite(action).all():
        raise ValueError(f"action contains NaN or infinity: {action.tolist()}")
    return np.clip(action, -1.0, 1.0)


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
        random_start: bool = False,
        render_mode: str | None = None,
    ):
        self.layout = layout if isinstance(layout, Layout) else load_layout(layout)
        lidar = LidarConfig(n_rays, lidar_range, field_of_view, lidar_noise)
        self.world = World(
            self.layout, 1, protocol, lidar, CoveragePatch(coverage_patch, coverage_patch_cell)
        )
        if reward not in REWARD_PRESETS:
            raise ValueError(f"unknown reward preset {reward!r}; choose one of {REWARD_PRESETS}")
        self.reward_preset, self.terminate_on_bound = reward, terminate_on_bound
        self.start_spots = start_cell_spots(self.layout) if random_start else None
        self.max_steps = max_steps or self.layout.max_steps
        self.render_mode = render_mode
        self.observation_space = observation_space(self.world.observation_size)
        self.observation_layout = self.world.observation_layout  # part name -> slice (cabinbench.observation)
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

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        start = None
        if self.start_spots is not None:
            x, y = self.start_spots[self.np_random.integers(len(self.start_spots))]
            start = np.array([[x, y, self.np_random.uniform(-math.pi, math.pi)]])
        self.world.reset(self.np_random, start)
        self.tracker = EpisodeTracker(self.world)
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
        terminated = events.success or (self.terminate_on_bound and events.robots[0].bound_violations > 0)
        truncated = not terminated and self.tracker.steps >= self.max_steps
        return step_reward, terminated, truncated

    def _info(self) -> dict:
        return {**self.tracker.running(), "pose": self.world.poses[0].copy()}

    def render(self):
        return self.renderer.render(self.world, self.tracker.trajectory() if self.tracker else None)

    def close(self):
        self.renderer.close()
