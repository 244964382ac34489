"""The physical world shared by every env: pymunk bodies, the lidar, the coverage raster and the
seed's cell-by-cell protocol (§4.3.2, Fig. 4.15).

Robots are dynamic discs driven by velocity commands; walls and obstacles are static segments;
contacts are counted as collisions. In the ``sequential`` protocol the current cell is closed by
*bounds* (solid virtual walls the lidar sees; touching one is a violation). When all goal markers
of the cell are reached the bound to the next cell opens and *exit* landmarks appear beyond it;
reaching one moves the team into the next cell, and the bound closes behind once every robot is
through. In the ``open`` protocol there are no bounds: plain coverage of the whole layout.
The pymunk space is rebuilt on every reset because Chipmunk caches contact state.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pymunk
from numba import njit
from pymunk._chipmunk import lib as chipmunk

from .coverage import CoveragePatch, stamp_footprint, write_coverage_patch
from .geometry import distances_to_segments, wrap_angle
from .observation import observation_layout, observation_size
from .layout import MARKER_RADIUS, RESOLUTION, Layout
from .lidar import BOUND, EXIT, GOAL, OBSTACLE, ROBOT, LidarConfig, cast_rays, encode_scan

TIME_STEP = 0.1  # seconds of simulated time per env step
PHYSICS_SUBSTEPS = 4  # 1.25 cm of travel per substep: a first contact sinks in at most that far
ROBOT_MASS = 3.5  # kg, an iRobot Create 2
MOTOR_FORCE = 1000.0  # N (and N·m): reaches the commanded velocity within a substep
PROTOCOLS = ("sequential", "open")
_ROBOT_TYPE, _WALL_TYPE, _BOUND_TYPE = 1, 2, 3


@dataclass(slots=True)
class RobotEvents:
    """What happened to one robot during one step."""

    collisions: int = 0
    robot_collisions: int = 0
    bound_violations: int = 0
    goals_reached: int = 0
    exits_reached: int = 0
    new_coverable_pixels: int = 0
    distance: float = 0.0
    rotation: float = 0.0


@dataclass(slots=True)
class StepEvents:
    robots: list[RobotEvents]
    cells_cleared: int = 0  # cells cleared during this step (team)
    success: bool = False  # the layout's success criterion holds after this step

    @property
    def team_new_coverable_pixels(self) -> int:
        return sum(r.new_coverable_pixels for r in self.robots)


class World:
    """K disc robots on one layout. Construct once; call :meth:`reset` before stepping."""

    def __init__(
        self,
        layout: Layout,
        n_robots: int = 1,
        protocol: str = "sequential",
        lidar: LidarConfig = LidarConfig(),
        patch: CoveragePatch = CoveragePatch(),
    ):
        if protocol not in PROTOCOLS:
            raise ValueError(f"protocol must be one of {PROTOCOLS}, got {protocol!r}")
        self.layout, self.n_robots, self.protocol, self.lidar, self.patch = (
            layout,
            n_robots,
            protocol,
            lidar,
            patch,
        )
        self.ray_angles = lidar.ray_angles()
        self.observation_layout = observation_layout(lidar.n_rays, patch.size)
        self.observation_size = observation_size(self.observation_layout)
        self.start_poses = start_poses(layout, n_robots)
        robot = layout.robot
        self._radius = robot.radius
        passages = layout.passages
        # Static lidar geometry: walls, then the bounds of every passage (switched on and off).
        self.bound_slices = []
        segment_blocks, tags = [layout.walls], [np.full(len(layout.walls), OBSTACLE)]
        offset = len(layout.walls)
        for passage in passages:
            self.bound_slices.append(slice(offset, offset + len(passage.bounds)))
            segment_blocks.append(passage.bounds)
            tags.append(np.full(len(passage.bounds), BOUND))
            offset += len(passage.bounds)
        self.segments = np.ascontiguousarray(np.concatenate(segment_blocks), dtype=np.float64)
        self.segment_tags = np.concatenate(tags).astype(np.int8)
        # Discs: goals, then exits, then robots.
        goals = layout.goals
        self.goal_cell = np.concatenate(
            [np.full(len(c.goals), i) for i, c in enumerate(layout.cells)]
        ).astype(int)
        exits = np.concatenate([p.exits for p in passages]) if passages else np.zeros((0, 2))
        self.exit_passage = (
            np.concatenate([np.full(len(p.exits), k) for k, p in enumerate(passages)]).astype(int)
            if passages
            else np.zeros(0, int)
        )
        self.n_goals, self.n_exits = len(goals), len(exits)
        marker_discs = [
            np.column_stack([points, np.full(len(points), MARKER_RADIUS)]) for points in (goals, exits)
        ]
        self.circles = np.concatenate([*marker_discs, np.zeros((n_robots, 3))]).astype(np.float64)
        self.circles[self.n_goals + self.n_exits :, 2] = robot.radius
        self.circle_tags = np.concatenate(
            [np.full(len(goals), GOAL), np.full(len(exits), EXIT), np.full(n_robots, ROBOT)]
        ).astype(np.int8)
        # Rasters shared by all robots.
        self.floor_mask = layout.free_raster
        self.coverable_mask = layout.coverable_raster
        self.cell_of = layout.cell_raster
        self.coverable_by_cell = np.bincount(
            self.cell_of[self.coverable_mask & (self.cell_of >= 0)], minlength=len(layout.cells)
        )
        self.coverable_pixels = int(self.coverable_mask.sum())
        self.cell_has_goals = np.bincount(self.goal_cell, minlength=len(layout.cells)) > 0
        self._marker_hits = np.full(max(self.n_goals, self.n_exits, 1), -1, dtype=np.int64)
        self._no_noise = np.zeros(0)

    # ------------------------------------------------------------------------------ reset
    def reset(self, rng: np.random.Generator, poses: np.ndarray | None = None) -> None:
        """Start an episode with the robots at ``poses`` ((K, 3): x, y, heading; default ``start_poses``)."""
        self.rng = rng
        layout = self.layout
        self.space = space = pymunk.Space()
        space.collision_slop = 0.002  # Chipmunk's default (0.1) is meant for pixels, not metres
        walls = []
        for x0, y0, x1, y1 in layout.walls:
            wall = pymunk.Segment(space.static_body, (x0, y0), (x1, y1), 0.0)
            wall.collision_type, wall.friction = _WALL_TYPE, 0.0
            walls.append(wall)
        space.add(*walls)
        self.bound_shapes = []
        for passage in layout.passages:
            shapes = []
            for x0, y0, x1, y1 in passage.bounds:
                bound = pymunk.Segment(space.static_body, (x0, y0), (x1, y1), 0.0)
                bound.collision_type, bound.friction = _BOUND_TYPE, 0.0
                shapes.append(bound)
            self.bound_shapes.append(shapes)
        self.bodies, self.motors = [], []
        for index, (x, y, heading) in enumerate(self.start_poses if poses is None else poses):
            body = pymunk.Body(ROBOT_MASS, pymunk.moment_for_circle(ROBOT_MASS, 0.0, layout.robot.radius))
            body.position, body.angle = (x, y), heading
            shape = pymunk.Circle(body, layout.robot.radius)
            shape.collision_type, shape.friction, shape.elasticity = _ROBOT_TYPE, 0.0, 0.0
            shape.robot_index = index
            # Velocity control through force-limited joints to a kinematic "motor" body (Chipmunk's
            # top-down idiom): contacts always win, so the robot never sinks into a wall. Setting
            # the body's velocity directly each step overrides the contact solver instead.
            motor = pymunk.Body(body_type=pymunk.Body.KINEMATIC)
            motor.position, motor.angle = (x, y), heading
            drive = pymunk.PivotJoint(motor, body, (0, 0), (0, 0))
            steer = pymunk.GearJoint(motor, body, 0.0, 1.0)
            for joint in (drive, steer):
                joint.max_bias, joint.max_force = 0.0, MOTOR_FORCE
            space.add(body, shape, motor, drive, steer)
            self.bodies.append(body)
            self.motors.append(motor)
        self._physics = _ChipmunkCalls(space, self.bodies, self.motors)
        self._read_poses()
        space.on_collision(_ROBOT_TYPE, _WALL_TYPE, begin=self._on_wall_contact)
        space.on_collision(_ROBOT_TYPE, _BOUND_TYPE, begin=self._on_bound_contact)
        space.on_collision(_ROBOT_TYPE, _ROBOT_TYPE, begin=self._on_robot_contact)

        # Protocol state.
        cleared = layout.cleared_cells
        self.cell_cleared = np.zeros(len(layout.cells), dtype=bool)
        self.cell_cleared[:cleared] = True
        self.current_cell = max(0, cleared - 1) if cleared else 0
        self.goal_reached = np.zeros(self.n_goals, dtype=bool)
        self.goal_reached[self.goal_cell < cleared] = True
        self.segment_on = np.ones(len(self.segments), dtype=bool)
        for bounds in self.bound_slices:
            self.segment_on[bounds] = False  # bounds start open; the sequential protocol closes them
        self.passage_open = np.zeros(len(layout.passages), dtype=bool)
        self.passages_closing: list[int] = []  # passed by the team's leader; each closes once all are through
        self.success = False
        if self.protocol == "open":
            self.passage_open[:] = True
        else:
            for passage in range(len(layout.passages)):
                self._set_bound(passage, solid=True)
            if cleared:
                self._set_bound(cleared - 1, solid=False)
                self.passage_open[cleared - 1] = True
        self._refresh_markers()

        # Coverage state.
        self.pass_count = np.zeros(layout.raster_shape, dtype=np.uint16)
        self.covered_by_cell = np.zeros(len(layout.cells), dtype=np.int64)
        self.covered_floor_pixels = 0
        self.covered_coverable_pixels = 0
        self.velocities = np.zeros((self.n_robots, 2))  # (forward m/s, turn rad/s) commanded and achieved
        self._pending = [RobotEvents() for _ in range(self.n_robots)]
        for x, y, _ in self._poses.tolist():
            self._stamp(
                x, y, math.nan, math.nan
            )  # the start footprint is covered, but earns no step's reward

    def _set_bound(self, passage: int, solid: bool) -> None:
        """Close (solid) or open a passage's bounds, in physics and for the lidar alike."""
        shapes = self.bound_shapes[passage]
        if solid and shapes[0].space is None:
            self.space.add(*shapes)
        elif not solid and shapes[0].space is not None:
            self.space.remove(*shapes)
        self.segment_on[self.bound_slices[passage]] = solid

    # ------------------------------------------------------------------------ contacts
    def _on_wall_contact(self, arbiter, space, data):
        self._pending[self._robot_of(arbiter)].collisions += 1

    def _on_bound_contact(self, arbiter, space, data):
        self._pending[self._robot_of(arbiter)].bound_violations += 1

    def _on_robot_contact(self, arbiter, space, data):
        for shape in arbiter.shapes:
            self._pending[shape.robot_index].robot_collisions += 1

    @staticmethod
    def _robot_of(arbiter) -> int:
        shape = arbiter.shapes[0] if arbiter.shapes[0].collision_type == _ROBOT_TYPE else arbiter.shapes[1]
        return shape.robot_index

    # ---------------------------------------------------------------------------- state
    @property
    def poses(self) -> np.ndarray:
        """(K, 3) x, y, heading of every robot, as of the last reset or step."""
        return self._poses

    def _read_poses(self) -> list[tuple[float, float, float]]:
        poses = self._physics.poses()
        self._poses = np.array(poses)
        return poses

    @property
    def coverage(self) -> float:
        return self.covered_coverable_pixels / self.coverable_pixels

    @property
    def cells_cleared(self) -> int:
        return int(self.cell_cleared.sum()) - self.layout.cleared_cells

    # ----------------------------------------------------------------------------- step
    def step(self, actions: np.ndarray) -> StepEvents:
        """Advance one env step. ``actions`` is (K, 2) in [-1, 1]: (linear, angular)."""
        robot = self.layout.robot
        before = self._poses.tolist()
        for index, ((x, y, heading), (linear, angular)) in enumerate(zip(before, actions.tolist())):
            speed, turn_rate = linear * robot.max_speed, angular * robot.max_turn_rate
            # Aim at the mid-step heading: the straight chord of the arc that driving while turning
            # traces, so one velocity per step is exact and the substeps need no Python. Only the
            # motor's velocities matter: with max_bias 0 its joints never pull towards its pose.
            aim = heading + turn_rate * TIME_STEP / 2
            self._physics.drive(index, (speed * math.cos(aim), speed * math.sin(aim)), turn_rate)
        self._physics.step(TIME_STEP / PHYSICS_SUBSTEPS, PHYSICS_SUBSTEPS)
        after = self._read_poses()
        events = self._pending
        self._pending = [RobotEvents() for _ in range(self.n_robots)]
        for index, ((x0, y0, heading), (x1, y1, heading1)) in enumerate(zip(before, after)):
            turned = wrap_angle(heading1 - heading)
            robot_events = events[index]
            robot_events.distance = math.hypot(x1 - x0, y1 - y0)
            robot_events.rotation = abs(turned)
            self.velocities[index] = (
                ((x1 - x0) * math.cos(heading) + (y1 - y0) * math.sin(heading)) / TIME_STEP,
                turned / TIME_STEP,
            )
            robot_events.new_coverable_pixels += self._stamp(x1, y1, x0, y0)
        step_events = StepEvents(events)
        self._update_protocol(step_events, self._poses)
        return step_events

    def _stamp(self, x: float, y: float, previous_x: float, previous_y: float) -> int:
        """Cover a robot's footprint at (x, y), coming from the previous pose (NaN: none)."""
        origin_x, origin_y = self.layout.origin
        new_floor, new_coverable = stamp_footprint(
            self.pass_count,
            self.floor_mask,
            self.coverable_mask,
            self.cell_of,
            self.covered_by_cell,
            x,
            y,
            previous_x,
            previous_y,
            self._radius,
            origin_x,
            origin_y,
            RESOLUTION,
        )
        self.covered_floor_pixels += new_floor
        self.covered_coverable_pixels += new_coverable
        return new_coverable

    def _update_protocol(self, events: StepEvents, poses: np.ndarray) -> None:
        reach = self._radius  # a marker is reached when it is under the robot's footprint
        goals_hit = markers_reached(
            self.circles, self.circle_on, 0, self.n_goals, poses, reach, self._marker_hits
        )
        for goal in np.flatnonzero(self._marker_hits[: self.n_goals] >= 0) if goals_hit else ():
            self.goal_reached[goal] = True
            events.robots[self._marker_hits[goal]].goals_reached += 1
        for cell in self._cells_to_check(goals_changed=goals_hit > 0):
            if self._cell_done(cell):
                self.cell_cleared[cell] = True
                events.cells_cleared += 1
                if self.protocol == "sequential" and cell < len(self.layout.passages):
                    self._set_bound(cell, solid=False)
                    self.passage_open[cell] = True
        exit_reached = False
        if self.protocol == "sequential":
            exit_reached = self._advance_through_exits(events, poses, reach)
            self.success = all(
                self.cell_cleared.tolist()
            )  # numpy's .all() costs a microsecond, even on a few cells
        else:
            self.success = self.coverage >= self.layout.success_coverage
        events.success = self.success
        if goals_hit or exit_reached or events.cells_cleared:
            self._refresh_markers()

    def _cells_to_check(self, goals_changed: bool) -> list[int]:
        """Uncleared cells that may have been completed this step: those with goals only when a
        goal was reached; in sequential only the current cell."""
        cells = [self.current_cell] if self.protocol == "sequential" else range(len(self.cell_cleared))
        return [
            cell
            for cell in cells
            if not self.cell_cleared[cell] and (goals_changed or not self.cell_has_goals[cell])
        ]

    def _cell_done(self, cell: int) -> bool:
        if self.cell_has_goals[cell]:
            return bool(self.goal_reached[self.goal_cell == cell].all())
        return self.covered_by_cell[cell] >= self.layout.success_coverage * self.coverable_by_cell[cell]

    def _advance_through_exits(self, events: StepEvents, poses: np.ndarray, reach: float) -> bool:
        """Move the team on when a robot reaches an exit; close the bounds all robots passed.
        Returns whether an exit was reached."""
        exit_reached = False
        passage = self.current_cell
        if passage < len(self.layout.passages) and self.passage_open[passage]:
            # only the open passage's exits are shown, so any hit is one of them
            if markers_reached(
                self.circles, self.circle_on, self.n_goals, self.n_exits, poses, reach, self._marker_hits
            ):
                robot = int(self._marker_hits[: self.n_exits][self._marker_hits[: self.n_exits] >= 0][0])
                events.robots[robot].exits_reached += 1
                self.current_cell += 1
                self.passage_open[passage] = False  # exits vanish; the bound closes once all are through
                self.passages_closing.append(passage)
                exit_reached = True
        if self.passages_closing:
            positions = poses[:, :2]
            for closing in [p for p in self.passages_closing if self._all_through(p, positions)]:
                self._set_bound(closing, solid=True)
                self.passages_closing.remove(closing)
        return exit_reached

    def _all_through(self, passage: int, positions: np.ndarray) -> bool:
        cells = [self.cell_of[self.layout.to_pixel(x, y)] for x, y in positions]
        if any(cell <= passage for cell in cells):  # cells are numbered along the cabin; -1 is no cell
            return False
        bounds = self.layout.passages[passage].bounds
        return all(
            distances_to_segments(position, bounds[:, :2], bounds[:, 2:]).min() > self._radius + 0.01
            for position in positions
        )

    # ------------------------------------------------------------------------- observe
    def markers_visible(self) -> tuple[np.ndarray, np.ndarray]:
        """(goal visible, exit visible) flags for the lidar."""
        goals = self.circle_on[: self.n_goals]
        return goals, self.circle_on[self.n_goals : self.n_goals + self.n_exits]

    def _refresh_markers(self) -> None:
        """Recompute which goals and exits are shown; called whenever the protocol state changes."""
        goals = ~self.goal_reached
        if self.protocol == "sequential":
            goals &= self.goal_cell == self.current_cell
            exits = self.passage_open[self.exit_passage]
        else:
            exits = np.zeros(self.n_exits, dtype=bool)
        self.circle_on = np.concatenate([goals, exits, np.ones(self.n_robots, dtype=bool)])
        # The floor the coverage patch shows: what may be cleaned now. Not the cells the layout
        # starts cleared: a tracking cell's first cell counts as clean, and the way on is ahead.
        self.cell_visible = np.zeros(len(self.layout.cells), dtype=bool)
        if self.protocol == "sequential":
            self.cell_visible[self.current_cell] = True
            if self.current_cell < len(self.passage_open) and self.passage_open[self.current_cell]:
                self.cell_visible[self.current_cell + 1] = True
        else:
            self.cell_visible[:] = True
        self.cell_visible[: self.layout.cleared_cells] = False

    def observe(self, index: int, out: np.ndarray | None = None) -> np.ndarray:
        """Local observation of robot ``index``, laid out as ``self.observation_layout``
        (:mod:`cabinbench.observation`). Written into ``out`` (float32, ``observation_size``) when given, else into a new array."""
        if out is None:
            out = np.empty(self.observation_size, dtype=np.float32)
        lidar, robot = self.lidar, self.layout.robot
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
            self.segments,
            self.segment_tags,
            self.segment_on,
            self.circles,
            self.circle_tags,
            self.circle_on,
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
                self.pass_count,
                self.coverable_mask,
                self.cell_of,
                self.cell_visible,
                self.protocol == "open",
                origin_x,
                origin_y,
                RESOLUTION,
            )
        return out


@njit(cache=True)
def write_observation(
    out,
    index,
    poses,
    velocities,
    max_speed,
    max_turn_rate,
    ray_angles,
    max_range,
    segments,
    segment_tags,
    segment_on,
    circles,
    circle_tags,
    circle_on,
    noise,
    velocity_at,
):
    """:meth:`World.observe` in one compiled call: the scan of robot ``index`` (its own disc
    contains the ray origin, so the cast skips it), its range ``noise`` (empty: none), then the
    velocities."""
    first_robot = circles.shape[0] - poses.shape[0]  # the last discs are the robots: place them
    for robot in range(poses.shape[0]):
        circles[first_robot + robot, 0], circles[first_robot + robot, 1] = poses[robot, 0], poses[robot, 1]
    n_rays = ray_angles.shape[0]
    distances, tags = np.empty(n_rays), np.empty(n_rays, dtype=np.int8)
    cast_rays(
        poses[index, 0],
        poses[index, 1],
        poses[index, 2],
        ray_angles,
        max_range,
        segments,
        segment_tags,
        segment_on,
        circles,
        circle_tags,
        circle_on,
        distances,
        tags,
    )
    if noise.shape[0] > 0:
        for r in range(n_rays):
            distances[r] = min(max(distances[r] + noise[r], 0.0), max_range)
    encode_scan(distances, tags, max_range, out)
    # contacts can push a robot a little faster than commanded: keep the entries in [-1, 1]
    out[velocity_at] = min(1.0, max(-1.0, velocities[index, 0] / max_speed))
    out[velocity_at + 1] = min(1.0, max(-1.0, velocities[index, 1] / max_turn_rate))


class _ChipmunkCalls:
    """The per-step calls into Chipmunk, made through pymunk's C bindings (``pymunk._chipmunk``, an
    internal module): pymunk's Python wrappers around them (Space.step's bookkeeping for changes
    made during a step, Vec2d results, attribute hooks) cost more than the physics of these small
    scenes, about a fifth of a training step. That bookkeeping is not needed here: nothing is
    added to or removed from the space during a step, and no post-step callback is used."""

    def __init__(self, space: pymunk.Space, bodies: list[pymunk.Body], motors: list[pymunk.Body]):
        self.pymunk_objects = (space, bodies, motors)  # they own the C objects; pickled instead of pointers
        self.space = space._space
        self.bodies = [body._body for body in bodies]
        self.motors = [motor._body for motor in motors]

    def __reduce__(self):
        return _ChipmunkCalls, self.pymunk_objects

    def drive(self, robot: int, velocity: tuple[float, float], angular_velocity: float) -> None:
        chipmunk.cpBodySetVelocity(self.motors[robot], velocity)
        chipmunk.cpBodySetAngularVelocity(self.motors[robot], angular_velocity)

    def step(self, dt: float, substeps: int) -> None:
        for _ in range(substeps):
            chipmunk.cpSpaceStep(self.space, dt)

    def poses(self) -> list[tuple[float, float, float]]:
        positions = [chipmunk.cpBodyGetPosition(body) for body in self.bodies]
        return [(p.x, p.y, chipmunk.cpBodyGetAngle(body)) for p, body in zip(positions, self.bodies)]


@njit(cache=True)
def markers_reached(circles, circle_on, first, count, poses, reach, hits):
    """For markers ``first .. first + count - 1`` that are shown: ``hits[m - first]`` = the index of
    the first robot whose centre is within ``reach`` of it, else -1. Returns how many were hit."""
    reach_sq = reach * reach
    n_hit = 0
    for m in range(count):
        hits[m] = -1
        if not circle_on[first + m]:
            continue
        for robot in range(poses.shape[0]):
            dx, dy = poses[robot, 0] - circles[first + m, 0], poses[robot, 1] - circles[first + m, 1]
            if dx * dx + dy * dy <= reach_sq:
                hits[m] = robot
                n_hit += 1
                break
    return n_hit


def start_cell_spots(layout: Layout) -> np.ndarray:
    """(n, 2) centres of the start cell's pixels where a robot may start: free, and reachable from the start."""
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
