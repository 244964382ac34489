"""Coverage metrics: the one place where every metric of an episode record is defined.

An :class:`EpisodeTracker` follows a :class:`~cabinbench.sim.world.World` step by step and produces
one record per episode. Definitions (areas are counted on the 0.05 m raster):

- ``coverage``: covered coverable area / coverable area (coverable = what some reachable robot
  pose covers, a reachable pose being a pixel centre connected to the start whose disc keeps
  1 cm from every wall; so 1.0 is achievable without touching anything; it ends within one
  pixel, 5 cm, of the walls);
- ``coverage_free``: covered floor / all floor (the study's definition, Fig. 5.11);
- ``path_length``: metres travelled by the robot centre (team: all robots together);
- ``path_efficiency``: L_LB / path_length with L_LB = (area covered after the start pose) / tool
  width, the physical lower bound for covering that area; 1 for a straight drive. The design card
  writes L_LB with the whole coverable area: the two agree on complete coverage, and ours stays
  in [0, 1] for an episode that stops early;
- ``time``: simulated seconds; ``steps``: env steps;
- ``t90``, ``t95``, ``t99``: simulated seconds to reach that coverage (None if never);
- ``collisions``: contact events with obstacles; ``robot_collisions``: between two robots (each
  contact counted once, though both robots feel it);
- ``bound_violations``: contacts with the bounds of the sequential protocol;
- ``rotation``: total absolute heading change (radians);
- ``overlap``: Σ over covered pixels of (passes − 1) / covered pixels, a pass being one entry of
  the pixel into the footprint;
- ``cells_cleared``: cells completed (all goal markers reached);
- ``goals_reached``: the protocol's end was reached within the step limit (sequential: every
  goal marker of every cell; open: coverage ≥ the layout's ``success_coverage``);
- ``time_limit``: simulated seconds the episode was allowed (its step limit × the step);
- ``clean_time``: simulated seconds until coverage first reached the layout's
  ``success_coverage`` (None if never), read every :data:`CURVE_STRIDE` steps and at the last,
  as the stored coverage curve samples it (so a stored curve gives it exactly): the floor counts
  as cleaned from then on;
- ``success``: the floor was cleaned within the limit (``clean_time`` is not None);
- ``clean_score``: the headline score, :func:`clean_score`;
- ``wall_time``: real seconds the episode took.

Coverage at the time limit is ``coverage``: an episode that ends early (every goal marker
reached, a bound touched) keeps its final coverage until the limit. The reach metrics of the
learned-coverage literature are aggregates of ``t90`` and ``t99`` (``stats.reach_time``): G90 and
G99, the share of episodes that reach 90 % and 99 %, and T90 and T99, the time to reach it among
those that do.

Where the uncovered floor lies (not an episode metric; the leaderboard's ``uncovered`` table):
:func:`uncovered_by_clearance` splits ``1 - coverage`` into bands of distance from the nearest wall.

Teams (K > 1) add ``n_agents``, ``path_lengths`` (per robot), ``makespan`` (simulated seconds
until the last robot made its last move) and ``load_balance`` (max / mean path length). A single
robot is a team of one (:func:`team_of_one`): its makespan is its episode time.
"""

from __future__ import annotations

import array
import time as clock

import numpy as np

from cabinbench.layouts.fields import RESOLUTION
from cabinbench.sim.events import StepEvents
from cabinbench.sim.physics import TIME_STEP
from cabinbench.sim.world import World

CURVE_STRIDE = 5
"""Steps between the samples of an episode's stored coverage curve and positions (0.5 s; 0.25 m at
full speed, under a robot radius); ``clean_time`` is read on the same samples."""
COVERAGE_THRESHOLDS = (0.90, 0.95, 0.99)
REACH_TIMES = (*(f"t{round(threshold * 100)}" for threshold in COVERAGE_THRESHOLDS), "clean_time")
"""The metrics of the time to reach a coverage level (t90, t95, t99, and the layout's own level,
clean_time): None in an episode that never does."""
METRICS = (
    "coverage",
    "coverage_free",
    "path_length",
    "path_efficiency",
    "time",
    "steps",
    "t90",
    "t95",
    "t99",
    "collisions",
    "bound_violations",
    "rotation",
    "overlap",
    "cells_cleared",
    "goals_reached",
    "time_limit",
    "clean_time",
    "success",
    "clean_score",
    "wall_time",
)
RATES = ("goals_reached", "success")
"""The metrics that are true or false per episode (summarised as rates)."""
FRACTIONS = ("coverage", "coverage_free", "path_efficiency", "clean_score", *RATES)
"""The metrics that live in [0, 1]: an interval of theirs is clipped to it."""
TEAM_METRICS = ("n_agents", "robot_collisions", "path_lengths", "makespan", "load_balance")
CLEARANCE_BANDS = (0.0, 0.05, 0.10, 0.20, 0.35)
"""Lower edges, in metres from the nearest wall, of the bands of :func:`uncovered_by_clearance`; the last
band is open-ended. A robot covers the first band only when its edge comes within 5 cm of the wall; floor
0.35 m (the built-in robot's diameter) or more from every wall is covered by any pass over it."""


def team_of_one(episodes):
    """Single-robot records (a DataFrame) with the makespan a team of one has, its episode time:
    what K > 1 is compared against."""
    return episodes.assign(makespan=episodes["time"])


def overlap(pass_count: np.ndarray) -> float:
    covered = pass_count > 0
    return float((pass_count[covered].astype(np.int64) - 1).sum() / covered.sum()) if covered.any() else 0.0


def uncovered_by_clearance(
    pass_count: np.ndarray,
    coverable_mask: np.ndarray,
    clearance: np.ndarray,
    bands: tuple[float, ...] = CLEARANCE_BANDS,
) -> np.ndarray:
    """Uncovered coverable area in each band of ``clearance`` (a pixel centre's distance to the nearest
    wall, :attr:`~cabinbench.layouts.model.Layout.clearance`) over the whole coverable area: the
    entries sum to 1 - coverage. With a ``pass_count`` of zeros: each band's share of the coverable area."""
    band = np.digitize(clearance[coverable_mask], bands[1:])
    uncovered = pass_count[coverable_mask] == 0
    return np.bincount(band[uncovered], minlength=len(bands)) / band.size


def clean_score(coverage: float, clean_time: float | None, time_limit: float, level: float) -> float:
    """The headline score of one episode, in [0, 1]: half for cleaning the floor, half for speed.

    An episode that cleaned the floor (coverage reached ``level`` at ``clean_time``) scores
    ``1 - clean_time / (2 time_limit)``, in [0.5, 1); one that did not scores
    ``coverage / (2 level)``, in [0, 0.5), with its coverage at the time limit. So an episode that
    leaves floor dirty, however early it stops, ranks below every episode that cleans it; among
    cleaned ones the faster ranks higher; among the others the one that covered more. The two
    halves meet at 0.5: cleaning at the last step scores what reaching ``level`` would.
    """
    if clean_time is not None:
        return 1.0 - clean_time / (2.0 * time_limit)
    return min(coverage, level) / (2.0 * level)


class EpisodeTracker:
    """Accumulates one episode's metrics from the world's step events; ``max_steps`` is the
    episode's step limit."""

    def __init__(self, world: World, max_steps: int):
        self.world = world
        self.time_limit = max_steps * TIME_STEP
        self.clean_time: float | None = None
        self.started = clock.perf_counter()
        self.steps = 0
        n = world.n_robots
        self.path_lengths = np.zeros(n)
        self.last_move_step = np.zeros(n, dtype=int)
        self.rotation = 0.0
        self.collisions = self.robot_collisions = self.bound_violations = 0
        self.initial_coverable_pixels = world.covered_coverable_pixels
        self.threshold_times: dict[float, float | None] = {t: None for t in COVERAGE_THRESHOLDS}
        self._unreached_thresholds = list(COVERAGE_THRESHOLDS)  # ascending; coverage never drops
        self._poses = array.array(
            "d", world.poses.tobytes()
        )  # every step's poses, flat: compact for long episodes
        self._note_thresholds()

    def update(self, events: StepEvents) -> None:
        self.steps += 1
        robot_contacts = 0
        for index, robot in enumerate(events.robots):
            self.path_lengths[index] += robot.distance
            if robot.distance > 1e-4 or robot.rotation > 1e-4:
                self.last_move_step[index] = self.steps
            self.rotation += robot.rotation
            self.collisions += robot.collisions
            self.bound_violations += robot.bound_violations
            robot_contacts += robot.robot_collisions
        self.robot_collisions += robot_contacts // 2  # every robot-robot contact is reported to both robots
        self._poses.frombytes(self.world.poses.tobytes())
        self._note_thresholds()

    def _note_thresholds(self) -> None:
        coverage = self.world.coverage
        if self.clean_time is None and self.steps % CURVE_STRIDE == 0 and self._cleaned(coverage):
            self.clean_time = self.steps * TIME_STEP
        while self._unreached_thresholds and coverage >= self._unreached_thresholds[0]:
            self.threshold_times[self._unreached_thresholds.pop(0)] = self.steps * TIME_STEP

    def _cleaned(self, coverage: float) -> bool:
        return coverage >= self.world.layout.success_coverage

    def final_clean_time(self) -> float | None:
        """``clean_time``, the last step counting as a sample."""
        if self.clean_time is None and self._cleaned(self.world.coverage):
            return self.steps * TIME_STEP
        return self.clean_time

    @property
    def path_length(self) -> float:
        return float(self.path_lengths.sum())

    def path_efficiency(self) -> float:
        new_area = (self.world.covered_coverable_pixels - self.initial_coverable_pixels) * RESOLUTION**2
        lower_bound = new_area / self.world.layout.robot.tool_width
        return float(min(1.0, lower_bound / self.path_length)) if self.path_length > 0 else 0.0

    def running(self) -> dict:
        """The metrics that are cheap to report at every step (for ``info``)."""
        world = self.world
        return {
            "coverage": world.coverage,
            "path_length": self.path_length,
            "time": self.steps * TIME_STEP,
            "steps": self.steps,
            "collisions": self.collisions,
            "bound_violations": self.bound_violations,
            "cells_cleared": world.cells_cleared,
            "current_cell": world.current_cell,
            "success": world.success,
        }

    def record(self) -> dict:
        """The episode record: every metric of :data:`METRICS` (and the team metrics for K > 1)."""
        world = self.world
        floor_pixels = int(world.floor_mask.sum())
        clean_time = self.final_clean_time()
        record = {
            "coverage": world.coverage,
            "coverage_free": world.covered_floor_pixels / floor_pixels,
            "path_length": self.path_length,
            "path_efficiency": self.path_efficiency(),
            "time": self.steps * TIME_STEP,
            "steps": self.steps,
            **dict(zip(REACH_TIMES, self.threshold_times.values())),
            "collisions": self.collisions,
            "bound_violations": self.bound_violations,
            "rotation": self.rotation,
            "overlap": overlap(world.pass_count),
            "cells_cleared": world.cells_cleared,
            "goals_reached": bool(world.success),
            "time_limit": self.time_limit,
            "clean_time": clean_time,
            "success": clean_time is not None,
            "clean_score": clean_score(
                world.coverage, clean_time, self.time_limit, world.layout.success_coverage
            ),
            "wall_time": clock.perf_counter() - self.started,
        }
        if world.n_robots > 1:
            mean_path = self.path_lengths.mean()
            record.update(
                n_agents=world.n_robots,
                robot_collisions=self.robot_collisions,
                path_lengths=self.path_lengths.tolist(),
                makespan=float(self.last_move_step.max() * TIME_STEP),
                load_balance=float(self.path_lengths.max() / mean_path) if mean_path > 0 else 1.0,
            )
        return record

    def trajectory(self) -> np.ndarray:
        """(steps + 1, K, 2) robot positions."""
        return np.frombuffer(self._poses).reshape(-1, self.world.n_robots, 3)[:, :, :2].copy()
