"""The study's cell-by-cell cleaning protocol (§4.3.2, Fig. 4.15), and the open protocol.

In ``sequential`` the current cell is closed by *bounds* (solid virtual walls the lidar sees;
touching one is a violation). When all goal markers of the cell are reached (a cell without goals:
when its coverable floor is covered to the layout's ``success_coverage``) the bound to the next
cell opens and *exit* landmarks appear beyond it; reaching one moves the team into the next cell,
and the bound closes behind once every robot is through. In ``open`` there are no bounds: plain
coverage of the whole layout.

:class:`CellProtocol` also holds what the lidar can see: the segments (walls, then every
passage's bounds) and discs (goals, exits, robots), each with its tag and whether it is shown now.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from cabinbench.geometry import distances_to_segments
from cabinbench.layouts.model import MARKER_RADIUS, Layout
from cabinbench.sim.coverage import CoverageRaster
from cabinbench.sim.events import StepEvents
from cabinbench.sim.lidar import BOUND, EXIT, GOAL, OBSTACLE, ROBOT, SegmentGrid
from cabinbench.sim.physics import Physics

PROTOCOLS = ("sequential", "open")


class CellProtocol:
    """The protocol's state for K robots on one layout; :meth:`reset` starts an episode."""

    def __init__(self, layout: Layout, protocol: str, n_robots: int, raster: CoverageRaster):
        if protocol not in PROTOCOLS:
            raise ValueError(f"protocol must be one of {PROTOCOLS}, got {protocol!r}")
        self.layout, self.protocol, self.n_robots, self.raster = layout, protocol, n_robots, raster
        self.reach = layout.robot.radius  # a marker is reached when it is under the robot's footprint
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
        self.segment_grid = SegmentGrid.of(self.segments)
        # Discs: goals, then exits, then robots (placed by the observation writer).
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
        self.circles[self.n_goals + self.n_exits :, 2] = layout.robot.radius
        self.circle_tags = np.concatenate(
            [np.full(len(goals), GOAL), np.full(len(exits), EXIT), np.full(n_robots, ROBOT)]
        ).astype(np.int8)
        self.cell_has_goals = np.bincount(self.goal_cell, minlength=len(layout.cells)) > 0
        self._marker_hits = np.full(max(self.n_goals, self.n_exits, 1), -1, dtype=np.int64)

    def reset(self, physics: Physics) -> None:
        """Start an episode whose bounds are ``physics``'s: every cell open but those the layout starts
        cleared, as the protocol has it."""
        self.physics = physics
        layout = self.layout
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

    @property
    def cells_cleared(self) -> int:
        """Cells cleared in this episode (not those the layout starts cleared)."""
        return int(self.cell_cleared.sum()) - self.layout.cleared_cells

    def _set_bound(self, passage: int, solid: bool) -> None:
        """Close (solid) or open a passage's bounds, in physics and for the lidar alike."""
        self.physics.set_bound(passage, solid)
        self.segment_on[self.bound_slices[passage]] = solid

    def update(self, events: StepEvents, poses: np.ndarray) -> None:
        """Note the goals and exits the robots at ``poses`` reached, clear the cells that are done, and
        move the team on; adds what happened to ``events``."""
        goals_hit = markers_reached(
            self.circles, self.circle_on, 0, self.n_goals, poses, self.reach, self._marker_hits
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
            exit_reached = self._advance_through_exits(events, poses)
            # numpy's .all() costs a microsecond, even on a few cells
            self.success = all(self.cell_cleared.tolist())
        else:
            self.success = self.raster.coverage >= self.layout.success_coverage
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
        raster = self.raster
        return raster.covered_by_cell[cell] >= self.layout.success_coverage * raster.coverable_by_cell[cell]

    def _advance_through_exits(self, events: StepEvents, poses: np.ndarray) -> bool:
        """Move the team on when a robot reaches an exit; close the bounds all robots passed.
        Returns whether an exit was reached."""
        exit_reached = False
        passage = self.current_cell
        if passage < len(self.layout.passages) and self.passage_open[passage]:
            # only the open passage's exits are shown, so any hit is one of them
            if markers_reached(
                self.circles, self.circle_on, self.n_goals, self.n_exits, poses, self.reach, self._marker_hits
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
        cells = [self.raster.cell_of[self.layout.to_pixel(x, y)] for x, y in positions]
        if any(cell <= passage for cell in cells):  # cells are numbered along the cabin; -1 is no cell
            return False
        bounds = self.layout.passages[passage].bounds
        return all(
            distances_to_segments(position, bounds[:, :2], bounds[:, 2:]).min() > self.reach + 0.01
            for position in positions
        )

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
