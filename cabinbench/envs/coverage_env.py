"""Single-robot coverage env (Gymnasium): :class:`CoverageEnv`, the team env core with one robot."""

from __future__ import annotations

import gymnasium as gym

from cabinbench.envs.settings import RENDER_MODES, EnvSettings, checked_action, observation_config
from cabinbench.envs.team_env import TeamCoverageEnv
from cabinbench.layouts.model import Layout

__all__ = ["CoverageEnv", "observation_config"]  # observation_config: where policies look it up

AGENT = "robot_0"


class CoreAttribute:
    """A read-only attribute of the wrapped env core (``env.core``), by the same name."""

    def __set_name__(self, owner, name: str) -> None:
        self.name = name

    def __get__(self, env, owner=None):
        return self if env is None else getattr(env.core, self.name)


class CoverageEnv(gym.Env):
    """Single-robot coverage env (Gymnasium).

    ## Description

    A disc robot cleans an airline-cabin layout, seeing only its own lidar and velocity (the study, §4.3.2:
    global coordinates do not generalise across cabins). Made by ``gymnasium.make("CabinBench/A320Cell-v0")``
    (one id per built-in layout) or ``gymnasium.make("CabinBench/Coverage-v0", layout=...)``.

    ## Action Space

    ``Box(-1, 1, (2,), float32)``:

    | Index | Action  | Min | Max | Unit once scaled                                    |
    |-------|---------|-----|-----|-----------------------------------------------------|
    | 0     | linear  | -1  | 1   | × ``max_speed``: forward speed, m/s (negative backs) |
    | 1     | angular | -1  | 1   | × ``max_turn_rate``: turn rate, rad/s, counter-clockwise |

    Out-of-range values are clipped to [-1, 1]. An action of another shape (``(4,)``, ``(2, 1)``,
    ``()``), NaN, infinity or complex numbers raise ``ValueError`` (a silent zero would hide a diverged
    policy, a dropped imaginary part a bug).

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

    The preset named by ``reward`` (:mod:`cabinbench.sim.rewards`): ``paper`` (the study's Tables
    4.4/4.5: +0.5 per new goal marker, -0.3 per contact, -10 per bound contact, -0.01 per step, +2
    for reaching an exit; on the step that clears a cell the reward is set to 3) or ``coverage``
    (dense: +10 × the newly covered fraction of the coverable area, contact -0.1, bound -1, step
    -0.005, cell +1, exit +0.5).

    ## Starting State

    The layout's start pose; with ``random_start``, a pose drawn from the env's seeded generator at
    each reset: the centre of a random pixel of the start cell where the robot fits and that the start
    reaches, and a uniform heading (for training: from one fixed start a policy can learn one route
    rather than a behaviour). ``lidar_noise`` is drawn from the same generator.

    ## Episode End

    Terminated when the layout's success criterion is met (``sequential``: every cell cleared;
    ``open``: coverage ≥ the layout's ``success_coverage``), on a bound contact if
    ``terminate_on_bound``, or on reaching an exit landmark if ``terminate_on_exit`` (the study's tracking
    training, Table 4.5, ends there); truncated after ``max_steps`` (default: the layout's). Each step is 0.1
    simulated seconds.

    ## Info

    The running metrics (``coverage``, ``path_length``, ``time``, ``steps``, ``collisions``,
    ``robot_collisions`` (always 0: one robot), ``bound_violations``, ``cells_cleared``,
    ``current_cell``, ``success``) and ``pose`` = (x, y, heading) for planners (not for learners: it is
    not part of the observation). Every value is a numpy scalar or array, and every step's info has the
    reset's keys (what Minari's ``record_infos`` and TorchRL's info readers require). Once the episode
    ends, ``env.unwrapped.episode_record`` holds its record, one value per metric of
    :mod:`cabinbench.metrics` (``None`` for a ``t90`` never reached; ``None`` before the end); with
    ``record_in_info=True`` the last step's info also carries it as ``episode_record``.

    ## Copies

    ``copy.deepcopy`` and pickle give an env that continues exactly as the original (the physics
    replays the episode's commands: :mod:`cabinbench.sim.physics`).

    ## Arguments

    ``layout`` (registered name, YAML path or a :class:`~cabinbench.layouts.model.Layout`; anything else
    is a :class:`~cabinbench.errors.LayoutError`), and the settings of
    :class:`~cabinbench.envs.settings.EnvSettings` as keywords (or ``settings=EnvSettings(...)``):
    ``protocol`` (``"sequential"`` or ``"open"``), ``reward`` (``"paper"`` or ``"coverage"``), ``n_rays``,
    ``lidar_range`` (m), ``field_of_view`` (rad), ``lidar_noise`` (m, Gaussian), ``coverage_patch``
    (cells per side, 0: none), ``coverage_patch_cell`` (m), ``max_steps``, ``terminate_on_bound``,
    ``terminate_on_exit``, ``random_start``, ``record_in_info``, ``render_mode`` (``"rgb_array"``: uint8
    H × W × 3, or ``"human"``); ``team_weight`` has no effect on one robot.

    ## Implementation

    The env is the team env :class:`~cabinbench.envs.team_env.TeamCoverageEnv` with one robot (the one
    env core, ``env.unwrapped.core``), seen through Gymnasium's API; both draw from one generator.
    """

    metadata = {"render_modes": list(RENDER_MODES), "render_fps": 10}

    def __init__(self, layout: str | Layout = "a320_cell", settings: EnvSettings | None = None, **overrides):
        self._wrap(TeamCoverageEnv(layout, 1, EnvSettings.of(settings, overrides)))

    def _wrap(self, core: TeamCoverageEnv) -> None:
        """Be the Gymnasium face of ``core`` (one robot)."""
        self.core = core
        self.render_mode = core.render_mode
        self.observation_space, self.action_space = core.observation_space(AGENT), core.action_space(AGENT)

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        self.core.np_random = self.np_random  # one generator, seeded the Gymnasium way
        observations, infos = self.core.reset(options=options)
        return observations[AGENT], infos[AGENT]

    def step(self, action):
        core = self.core
        rewards, terminated, truncated = core.advance(checked_action(action))
        info = core.step_infos(terminated or truncated)[AGENT]
        return core.world.observe(0), rewards[0], terminated, truncated, info

    def render(self):
        return self.core.render()

    def close(self):
        self.core.close()

    # What planners, tests and the trainers read of the env in play (``env.unwrapped.<name>``).
    settings = CoreAttribute()
    layout = CoreAttribute()
    world = CoreAttribute()
    tracker = CoreAttribute()
    max_steps = CoreAttribute()  # this episode's step limit
    episode_record = CoreAttribute()  # None until the episode ends
    observation_layout = CoreAttribute()  # part name -> slice
    observation_config = CoreAttribute()
