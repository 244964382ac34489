"""The settings every coverage env shares, and the checks of what a user passes to one.

:class:`EnvSettings` holds the keyword arguments of the PettingZoo team env (the one env core,
:class:`~cabinbench.envs.team_env.TeamCoverageEnv`), of its Gymnasium wrappers
(:class:`~cabinbench.envs.coverage_env.CoverageEnv`, :class:`~cabinbench.envs.suite_env.SuiteEnv`) and
of the batched training envs: each env takes them as keywords (or as ``settings=EnvSettings(...)``),
and a value that cannot work is refused when the env is made, naming the argument.
"""

from __future__ import annotations

import dataclasses
import math
import os
from dataclasses import dataclass

import gymnasium
import numpy as np

from cabinbench.errors import LayoutError
from cabinbench.layouts.model import Layout
from cabinbench.layouts.resolve import load_layout
from cabinbench.sim.coverage import CoveragePatch
from cabinbench.sim.lidar import LidarConfig
from cabinbench.sim.rewards import REWARD_PRESETS
from cabinbench.values import is_real_number, is_whole_number

RENDER_MODES = ("rgb_array", "human")
OBSERVATION_SETTINGS = ("n_rays", "lidar_range", "field_of_view", "coverage_patch", "coverage_patch_cell")
"""The settings that shape the observation: what a policy or demonstrations are recorded with."""


@dataclass(frozen=True)
class EnvSettings:
    """One coverage env's settings (every keyword argument but ``layout`` and ``n_agents``)."""

    protocol: str = "sequential"  # the study's cell-by-cell order, or "open": any floor, any order
    reward: str = "paper"  # a preset of cabinbench.sim.rewards: the study's tables, or dense "coverage"
    n_rays: int = 64  # lidar rays: what a robot sees, its only view of the walls
    lidar_range: float = 3.5  # metres: beyond this a ray reports no hit
    field_of_view: float = 2 * math.pi  # radians the rays spread over, centred on the heading
    lidar_noise: float = 0.0  # metres, Gaussian: sensor noise drawn from the reset's seed
    coverage_patch: int = 0  # cells per side of the egocentric window on the uncleaned floor (0: none)
    coverage_patch_cell: float = 0.25  # metres per patch cell
    max_steps: int | None = None  # the step limit (truncation); None: the layout's, scaled with its area
    terminate_on_bound: bool = False  # end on a bound contact (the study's tracking training)
    terminate_on_exit: bool = False  # end on reaching an exit landmark (the study's tracking training)
    random_start: bool = False  # draw the start poses from the seed: a policy learns a behaviour, not a route
    team_weight: float = 0.5  # share of the team's new area in each robot's "coverage" reward (teams only)
    record_in_info: bool = False  # add the episode record to the last step's infos (their keys then change)
    render_mode: str | None = None  # "rgb_array" (uint8 H x W x 3 frames) or "human" (a window)

    def __post_init__(self) -> None:
        self.lidar()  # LidarConfig and CoveragePatch check their arguments, naming them
        self.patch()
        if self.reward not in REWARD_PRESETS:
            raise ValueError(f"reward must be one of {REWARD_PRESETS}, got {self.reward!r}")
        if self.max_steps is not None:
            checked_count(self.max_steps, "max_steps", " (None: the layout's)")
        if not (is_real_number(self.team_weight) and self.team_weight >= 0):
            raise ValueError(f"team_weight must be a number >= 0, got {self.team_weight!r}")
        if self.render_mode is not None and self.render_mode not in RENDER_MODES:
            raise ValueError(
                f"render_mode must be None or one of {list(RENDER_MODES)}, got {self.render_mode!r}"
            )

    @classmethod
    def of(cls, settings: EnvSettings | None, overrides: dict) -> EnvSettings:
        """``settings`` (default: the defaults) with the keyword arguments ``overrides`` on top."""
        names = [field.name for field in dataclasses.fields(cls)]
        unknown = sorted(set(overrides) - set(names))
        if unknown:
            raise TypeError(
                f"unknown env argument {unknown[0]!r}; the arguments are layout, {', '.join(names)}"
            )
        return dataclasses.replace(settings or cls(), **overrides)

    def lidar(self) -> LidarConfig:
        return LidarConfig(self.n_rays, self.lidar_range, self.field_of_view, self.lidar_noise)

    def patch(self) -> CoveragePatch:
        return CoveragePatch(self.coverage_patch, self.coverage_patch_cell)


def observation_config(env_kwargs: dict, size: int) -> dict:
    """The observation settings of an env made with ``env_kwargs`` (the defaults for those not
    given) and the observation's size: what a policy or demonstrations must have been recorded
    with to fit the env."""
    return {
        **{name: env_kwargs.get(name, getattr(EnvSettings, name)) for name in OBSERVATION_SETTINGS},
        "size": int(size),
    }


def resolved_layout(layout) -> Layout:
    """``layout`` as given to an env: a :class:`Layout`, a layout name or a YAML path."""
    if isinstance(layout, Layout):
        return layout
    if not isinstance(layout, (str, os.PathLike)):
        raise LayoutError(
            f"layout={layout!r}",
            "layout",
            f"a {type(layout).__name__} is not a layout",
            "give a layout name such as 'a320_cell', a suite layout ('cabin-v1-test/0007') or a .yaml path",
        )
    return load_layout(layout)


def checked_action(action, shape: tuple[int, ...] = (2,), name: str = "action") -> np.ndarray:
    """The documented action policy: ``action`` must be real numbers of ``shape`` (the last axis is
    (linear, angular)); values are clipped to [-1, 1]; NaN and infinity are refused (a silent zero
    would hide a diverged policy), and so are complex numbers (casting would drop a part).
    Returns float64 (robots, 2), possibly a view of ``action``: read it before ``action`` changes."""
    given = np.asarray(action)
    if given.dtype.kind not in "biufO":
        raise ValueError(f"{name} must be real numbers, got {given.dtype} values: {given.tolist()}")
    action = np.asarray(given, dtype=np.float64)
    if action.shape != shape:
        raise ValueError(f"{name} must have shape {shape} (linear, angular), got shape {action.shape}")
    if not (
        np.abs(action) <= 1.0
    ).all():  # out of range, or NaN (which compares false); rare, and clip is slow
        if not np.isfinite(action).all():
            raise ValueError(f"{name} contains NaN or infinity: {action.tolist()}")
        action = np.clip(action, -1.0, 1.0)
    return action.reshape(-1, 2)


def checked_count(value, name: str, note: str = "") -> int:
    """``value`` of the argument ``name`` if it is a whole number >= 1, else a ValueError naming it."""
    if not (is_whole_number(value) and value >= 1):
        raise ValueError(f"{name} must be a whole number >= 1{note}, got {value!r}")
    return value


def observation_space(size: int) -> gymnasium.spaces.Box:
    """Ray blocks and the patch lie in [0, 1]; the two velocity entries in [-1, 1]."""
    low = np.zeros(size, dtype=np.float32)
    low[-2:] = -1.0
    return gymnasium.spaces.Box(low, np.ones(size, dtype=np.float32), dtype=np.float32)


def action_space() -> gymnasium.spaces.Box:
    """(linear, angular), each in [-1, 1], scaled by the robot's ``max_speed`` and ``max_turn_rate``."""
    return gymnasium.spaces.Box(-1.0, 1.0, (2,), np.float32)
