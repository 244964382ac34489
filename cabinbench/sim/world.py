"""The world every env steps: K disc robots on one layout, made of

- :mod:`cabinbench.sim.physics`: the pymunk space, robots driven by velocity commands, contacts;
- :mod:`cabinbench.sim.protocol`: the cell-by-cell (``sequential``) or ``open`` protocol, and what the
  lidar sees (bounds, goal and exit markers, robots);
- :mod:`cabinbench.sim.coverage`: the coverage raster and the coverage patch;
- :mod:`cabinbench.sim.observation`: where each part of an observation lies, and its writer.

:class:`World` ties them into one step: drive, move, stamp the footprints, update the protocol.
The pymunk space of the walls is built once per world; a reset puts new robots into it
(:meth:`cabinbench.sim.physics.Physics.reset`).
"""

from __future__ import annotations

import math

import numpy as np

from cabinbench.geometry import wrap_angle
from cabinbench.layouts.fields import RESOLUTION
from cabinbench.layouts.model import Layout
from cabinbench.sim.coverage import CoveragePatch, CoverageRaster, write_coverage_patch
from cabinbench.sim.events import RobotEvents, StepEvents
from cabinbench.sim.interrupts import shielded
from cabinbench.sim.lidar import LidarConfig
from cabinbench.sim.observation import observation_layout, observation_size, write_observation
from cabinbench.sim.physics import TIME_STEP, Physics
from cabinbench.sim.protocol import PROTOCOLS, CellProtocol

__all__ = [
    "PROTOCOLS",
    "TIME_STEP",
    "RobotEvents",
    "StepEvents",
    "World",
    "random_start_poses",
    "start_cell_spots",
    "start_poses",
]


class World:
    """K disc robots on one layout. Construct once; call :meth:`reset` before stepping.

    A copy (``copy.deepcopy``, pickle) continues exactly as the original: its physics replays the
    episode's commands (:mod:`cabinbench.sim.physics`). Its methods are :func:`shielded`: a Ctrl-C
    arriving inside one is raised as it returns."""

    @shielded
    def __init__(
        self,
        layout: Layout,
        n_robots: int = 1,
        protocol: str = "sequential",
        lidar: LidarConfig | None = None,
        patch: CoveragePatch | None = None,
    ):
        self.layout, self.n_robots, self.protocol = layout, n_robots, protocol
        self.lidar, self.patch = lidar or LidarConfig(), patch or CoveragePatch()
        self.raster = CoverageRaster(layout)
        self.cell_protocol = CellProtocol(layout, protocol, n_robots, self.raster)
        self.ray_angles = self.lidar.ray_angles()
        self.observation_layout = observation_layout(self.lidar.n_rays, self.patch.size)
        self.observation_size = observation_size(self.observation_layout)
        self.start_poses = start_poses(layout, n_robots)
        # read by the renderer, the metrics and the tests; fixed for the world's life
        cell_protocol = self.cell_protocol
        self.segments, self.segment_tags, self.bound_slices = (
            cell_protocol.segments,
            cell_protocol.segment_tags,
            cell_protocol.bound_slices,
        )
        self.circles, self.circle_tags, self.goal_cell = (
            cell_protocol.circles,
            cell_protocol.circle_tags,
            cell_protocol.goal_cell,
        )
        self.n_goals, self.n_exits = cell_protocol.n_goals, cell_protocol.n_exits
        self.floor_mask, self.coverable_mask = self.raster.floor_mask, self.raster.coverable_mask
        self.cell_of, self.coverable_pixels = self.raster.cell_of, self.raster.coverable_pixels
        self._no_noise = np.zeros(0)
        self.physics = Physics(layout)

    @shielded
    def reset(self, rng: np.random.Generator, poses: np.ndarray | None = None) -> None:
        """Start an episode with the robots at ``poses`` ((K, 3): x, y, heading; default ``start_poses``)."""
        self.rng = rng
        self.physics.reset(self.start_poses if poses is None else poses)
        self._poses = np.array(self.physics.poses())
        self.cell_protocol.reset(self.physics)
        self.raster.reset()
        self.velocities = np.zeros((self.n_robots, 2))  # (forward m/s, turn rad/s) commanded and achieved
        for x, y, _ in self._poses.tolist():
            self.raster.stamp(x, y, math.nan, math.nan)  # the start footprint is covered, but earns no reward

    @shielded
    def step(self, actions: np.ndarray) -> StepEvents:
        """Advance one env step. ``actions`` is (K, 2) in [-1, 1]: (linear, angular)."""
        robot, physics = self.layout.robot, self.physics
        before = self._poses.tolist()
        for index, ((_, _, heading), (linear, angular)) in enumerate(zip(before, actions.tolist())):
            speed, turn_rate = linear * robot.max_speed, angular * robot.max_turn_rate
            # Aim at the mid-step heading: the straight chord of the arc that driving while turning
            # traces, so one velocity per step is exact and the substeps need no Python. Only the
            # motor's velocities matter: with max_bias 0 its joints never pull towards its pose.
            aim = heading + turn_rate * TIME_STEP / 2
            physics.drive(index, (speed * math.cos(aim), speed * math.sin(aim)), turn_rate)
        contacts = physics.step()
        after = physics.poses()
        self._poses = np.array(after)
        events = StepEvents([RobotEvents(*robot_contacts) for robot_contacts in contacts])
        for index, ((x0, y0, heading), (x1, y1, heading1)) in enumerate(zip(before, after)):
            turned = wrap_angle(heading1 - heading)
            robot_events = events.robots[index]
            robot_events.distance = math.hypot(x1 - x0, y1 - y0)
            robot_events.rotation = abs(turned)
            self.velocities[index] = (
                ((x1 - x0) * math.cos(heading) + (y1 - y0) * math.sin(heading)) / TIME_STEP,
                turned / TIME_STEP,
            )
            robot_events.new_coverable_pixels += self.raster.stamp(x1, y1, x0, y0)
        self.cell_protocol.update(events, self._poses)
        return events

    @shielded
    def observe(self, index: int, out: np.ndarray | None = None) -> np.ndarray:
        """Local observation of robot ``index``, laid out as ``self.observation_layout``
        (:mod:`cabinbench.sim.observation`). Written into ``out`` (float32, ``observation_size``) when
        given, else into a new array."""
        if out is None:
            out = np.empty(self.observation_size, dtype=np.float32)
        lidar, robot, cell_protocol = self.lidar, self.layout.robot, self.cell_protocol
        # drawn before the cast, which draws nothing: the same numbers as drawing after it
        noise = self.rng.normal(0.0, lidar.noise, lidar.n_rays) if lidar.noise > 0 else self._no_noise
        write_observation(
            out,
            index,
            self._poses,
            self.velocities,
            robot.max_speed,
            robot.max_turn_rate,
            self.ray_angles,
            lidar.max_range,
            cell_protocol.segments,
            cell_protocol.segment_tags,
            cell_protocol.segment_on,
            cell_protocol.segment_grid.meta,
            cell_protocol.segment_grid.starts,
            cell_protocol.segment_grid.items,
            cell_protocol.circles,
            cell_protocol.circle_tags,
            cell_protocol.circle_on,
            noise,
            self.observation_layout["velocity"].start,
        )
        if self.patch.cells:
            x, y, heading = self._poses[index]
            origin_x, origin_y = self.layout.origin
            write_coverage_patch(
                out,
                self.observation_layout["coverage_patch"].start,
                x,
                y,
                heading,
                self.patch.cells,
                self.patch.cell_size,
                self.raster.pass_count,
                self.raster.coverable_mask,
                self.raster.cell_of,
                cell_protocol.cell_visible,
                self.protocol == "open",
                origin_x,
                origin_y,
                RESOLUTION,
            )
        return out

    # The episode's state, as its parts keep it.
    @property
    def poses(self) -> np.ndarray:
        """(K, 3) x, y, heading of every robot, as of the last reset or step."""
        return self._poses

    @property
    def bodies(self) -> list:
        """The robots' pymunk bodies."""
        return self.physics.bodies

    @property
    def space(self):
        return self.physics.space

    @property
    def pass_count(self) -> np.ndarray:
        return self.raster.pass_count

    @property
    def covered_floor_pixels(self) -> int:
        return self.raster.covered_floor_pixels

    @property
    def covered_coverable_pixels(self) -> int:
        return self.raster.covered_coverable_pixels

    @property
    def coverage(self) -> float:
        return self.raster.coverage

    @property
    def cell_cleared(self) -> np.ndarray:
        return self.cell_protocol.cell_cleared

    @property
    def cells_cleared(self) -> int:
        return self.cell_protocol.cells_cleared

    @property
    def current_cell(self) -> int:
        return self.cell_protocol.current_cell

    @property
    def goal_reached(self) -> np.ndarray:
        return self.cell_protocol.goal_reached

    @property
    def success(self) -> bool:
        return self.cell_protocol.success

    @property
    def segment_on(self) -> np.ndarray:
        return self.cell_protocol.segment_on

    @property
    def circle_on(self) -> np.ndarray:
        return self.cell_protocol.circle_on

    @property
    def cell_visible(self) -> np.ndarray:
        return self.cell_protocol.cell_visible

    def markers_visible(self) -> tuple[np.ndarray, np.ndarray]:
        """(goal visible, exit visible) flags for the lidar."""
        return self.cell_protocol.markers_visible()


def start_cell_spots(layout: Layout) -> np.ndarray:
    """(n, 2) centres of the start cell's pixels where a robot may start: free, and reachable from the
    start."""
    start_cell = layout.cell_raster[layout.to_pixel(*layout.start[:2])]
    rows, cols = np.nonzero(layout.centre_free & (layout.cell_raster == start_cell))
    xs, ys = layout.pixel_centres()
    return np.column_stack([xs[cols], ys[rows]])


def start_poses(layout: Layout, n_robots: int) -> np.ndarray:
    """Distinct valid start poses: the layout's start, then the reachable free spots of the start
    cell nearest to it, at least a robot diameter plus 5 cm apart (deterministic)."""
    poses = [layout.start]
    if n_robots == 1:
        return np.array(poses)
    spacing = layout.robot.tool_width + 0.05
    points = start_cell_spots(layout)
    order = np.argsort(np.hypot(*(points - layout.start[:2]).T), kind="stable")
    for point in points[order]:
        if all(np.hypot(point[0] - p[0], point[1] - p[1]) >= spacing for p in poses):
            poses.append((float(point[0]), float(point[1]), layout.start[2]))
            if len(poses) == n_robots:
                return np.array(poses)
    raise ValueError(
        f"layout '{layout.name}' has room for only {len(poses)} robots in its start cell, "
        f"{n_robots} were asked for: use fewer agents or a larger layout"
    )


def random_start_poses(
    layout: Layout, spots: np.ndarray, n_robots: int, rng: np.random.Generator
) -> np.ndarray:
    """``n_robots`` start poses drawn with ``rng`` from ``spots`` (:func:`start_cell_spots`), each
    with a uniform heading: the first at a random spot, the others at spots taken in a random
    order that keep a robot diameter plus 5 cm from those already placed."""
    x, y = spots[rng.integers(len(spots))]
    poses = [(float(x), float(y), float(rng.uniform(-math.pi, math.pi)))]
    spacing = layout.robot.tool_width + 0.05
    for x, y in spots[rng.permutation(len(spots))] if n_robots > 1 else ():
        if all(math.hypot(x - p[0], y - p[1]) >= spacing for p in poses):
            poses.append((float(x), float(y), float(rng.uniform(-math.pi, math.pi))))
            if len(poses) == n_robots:
                break
    if len(poses) < n_robots:
        raise ValueError(f"layout '{layout.name}' has room for only {len(poses)} robots in its start cell")
    return np.array(poses)
