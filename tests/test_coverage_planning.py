"""Tests of the raster coverage planner and the path follower.

The planner's stages are tested on rasters; its plans, and the path follower, are driven in the
real env (``CoverageEnv``: pymunk physics, 0.1 s steps, 0.5 m/s, 2 rad/s) on small layouts
written here. Planning time is measured by ``python -m cabinbench.bench``, never by a test.
"""

import fcntl
import importlib
import math
import os
import select
import struct
import sys
import termios
from dataclasses import dataclass, field

import numpy as np
import pytest
from cabinbench.baselines.coverage_planning import (
    MIN_PLAN_COVERAGE,
    FreeSpace,
    SweepOptions,
    astar,
    attachment_points,
    cell_units,
    decompose,
    drop_idle_corners,
    is_narrow,
    lane_lines,
    line_view,
    plan_coverage,
    segment_footprint,
    segment_is_free,
    transpose_cell,
)
from cabinbench.baselines.coverage_planning import plan as plan_module
from cabinbench.baselines.path_following import PathFollower
from scipy import ndimage
from scipy.sparse.csgraph import dijkstra

from cabinbench.envs.coverage_env import CoverageEnv
from cabinbench.errors import UsageError
from cabinbench.geometry import distances_to_segments, world_to_pixel
from cabinbench.sim.physics import TIME_STEP

# The package exports the function ``route`` under the module's name.
route_module = importlib.import_module("cabinbench.baselines.coverage_planning.route")

RESOLUTION = 0.05
TOOL_WIDTH = 0.35
RADIUS = TOOL_WIDTH / 2
ORIGIN = (0.0, 0.0)
# How far (m) the robot in the env may stray from the path it follows: 8 mm measured on a
# 10 cm hairpin; into a corner at full speed 6 mm (12 mm with a braking deceleration of 2 m/s^2).
TRACKING_TOLERANCE = 0.01
CORNER_TOLERANCE = 0.008


# ------------------------------------------------------------------------------------------
# Scenes
# ------------------------------------------------------------------------------------------


@dataclass
class Scene:
    """A rectangular room with obstacles, in metres: as a raster for the planner's stages, as a
    layout file for the env.

    ``rects`` are (x0, y0, x1, y1) boxes, ``discs`` (x, y, radius) with the centre on a pixel
    centre. A pixel is free when its centre lies in no obstacle (x0 <= x < x1, y0 <= y < y1;
    strictly inside a disc).
    """

    width: float
    height: float
    start: tuple[float, float]
    rects: list[tuple[float, float, float, float]] = field(default_factory=list)
    discs: list[tuple[float, float, float]] = field(default_factory=list)

    def free(self) -> np.ndarray:
        rows, cols = round(self.height / RESOLUTION), round(self.width / RESOLUTION)
        y = (np.arange(rows) + 0.5) * RESOLUTION
        x = (np.arange(cols) + 0.5) * RESOLUTION
        free = np.ones((rows, cols), dtype=bool)
        for x0, y0, x1, y1 in self.rects:
            free[np.ix_((y >= y0) & (y < y1), (x >= x0) & (x < x1))] = False
        row_index, col_index = np.mgrid[:rows, :cols]
        for cx, cy, radius in self.discs:  # in whole pixels, so that no centre lies on the edge
            centre_row, centre_col = round(cy / RESOLUTION - 0.5), round(cx / RESOLUTION - 0.5)
            radius_px = round(radius / RESOLUTION)
            free[(row_index - centre_row) ** 2 + (col_index - centre_col) ** 2 < radius_px**2] = False
        return free

    def layout_file(self, folder, heading: float = 0.0) -> str:
        """A ``polygons`` layout of the scene (discs as 32-gons) that ends only on its step limit."""
        polygons = [[[x0, y0], [x1, y0], [x1, y1], [x0, y1]] for x0, y0, x1, y1 in self.rects]
        angles = np.linspace(0, 2 * math.pi, 32, endpoint=False)
        polygons += [
            np.column_stack((cx + radius * np.cos(angles), cy + radius * np.sin(angles))).tolist()
            for cx, cy, radius in self.discs
        ]
        w, h = self.width, self.height
        path = folder / "scene.yaml"
        path.write_text(
            "kind: polygons\n"
            f"polygons:\n  boundary: [[0, 0], [{w}, 0], [{w}, {h}], [0, {h}]]\n  obstacles: {polygons}\n"
            f"start: [{self.start[0]}, {self.start[1]}, {heading}]\n"
            "success_coverage: 1.0\nmax_steps: 20000\n"
        )
        return str(path)


def erode_by_radius(free: np.ndarray) -> np.ndarray:
    """Pixels whose centre is at least the robot radius from every blocked pixel's edge.

    The raster border counts as a wall. Distances are between pixel centres, so half a pixel is
    added to measure from the blocked pixel's edge.
    """
    distance = ndimage.distance_transform_edt(np.pad(free, 1))[1:-1, 1:-1] * RESOLUTION
    return distance >= RADIUS + RESOLUTION / 2


def reachable_area(centre_free: np.ndarray) -> np.ndarray:
    """Pixels the robot disc can touch: centre_free dilated by the radius."""
    reach = int(math.ceil(RADIUS / RESOLUTION))
    rows, cols = np.mgrid[-reach : reach + 1, -reach : reach + 1]
    disc = (rows**2 + cols**2) * RESOLUTION**2 <= RADIUS**2
    return ndimage.binary_dilation(centre_free, structure=disc)


def cabin(length: float, width: float, end_margin: float = 0.0, start=(0.3, 2.0)) -> Scene:
    """A cabin-like room, aisle along x: seat blocks attached to both side walls leave a central
    aisle 0.48 m wide; blocks 0.35 m deep alternate with 0.45 m legroom gaps. ``end_margin``
    leaves open floor (galleys) at both ends.
    """
    aisle_width, gap_width, seat_pitch = 0.48, 0.45, 0.80
    block_depth = seat_pitch - gap_width
    block_start, gap_start = end_margin, end_margin + block_depth
    spans = []
    while gap_start + gap_width + block_depth <= length - end_margin + 1e-9:
        spans.append((block_start, gap_start))
        block_start = gap_start + gap_width
        gap_start += seat_pitch
    spans.append((block_start, length - end_margin))
    sides = [(0.0, width / 2 - aisle_width / 2), (width / 2 + aisle_width / 2, width)]
    return Scene(length, width, start, [(x0, y0, x1, y1) for x0, x1 in spans for y0, y1 in sides])


SCENES = {
    "empty_room": Scene(6.0, 4.0, (0.3, 0.3)),
    "room_with_obstacles": Scene(
        6.0,
        4.0,
        (0.3, 0.3),
        rects=[(2.5, 1.5, 3.5, 2.5), (0.5, 0.5, 2.0, 1.0)],
        discs=[(4.775, 3.025, 0.5)],
    ),
    "cabin": cabin(6.0, 4.0, end_margin=0.6),
    # Like the A320 cell: an open zone 0.95 m deep at the front (x < 0.95 m), then two seat blocks
    # with a legroom column (0.45 m) between them and one behind, all crossed by a 0.4 m cross
    # aisle in the middle.
    "cabin_zone": Scene(
        2.6,
        3.7,
        (0.25, 1.85),
        rects=[
            (0.95, 0.2, 1.35, 1.65),
            (0.95, 2.05, 1.35, 3.5),
            (1.75, 0.2, 2.15, 1.65),
            (1.75, 2.05, 2.15, 3.5),
        ],
    ),
}


def two_rooms_and_a_corridor() -> np.ndarray:
    """Two 1.5 m square rooms joined by a 1.2 m corridor that leaves the robot centre two
    pixels of play (0.4 m wide)."""
    free = np.zeros((30, 84), dtype=bool)
    free[:, :30] = True
    free[:, 54:] = True
    free[11:19, 30:54] = True
    return free


# ------------------------------------------------------------------------------------------
# Coverage of a planned path, and driving in the env
# ------------------------------------------------------------------------------------------


def to_pixel_coordinates(points: np.ndarray) -> np.ndarray:
    """World (x, y) -> continuous pixel coordinates (row, col), pixel centres on integers."""
    points = np.asarray(points, dtype=float)
    return np.column_stack(
        ((points[:, 1] - ORIGIN[1]) / RESOLUTION - 0.5, (points[:, 0] - ORIGIN[0]) / RESOLUTION - 0.5)
    )


def stamp_discs(shape: tuple[int, int], positions: np.ndarray) -> np.ndarray:
    """Raster of the pixels whose centre lies within the robot radius of some position (x, y)."""
    centres = to_pixel_coordinates(positions)
    radius_px = RADIUS / RESOLUTION
    reach = int(math.ceil(radius_px))
    nearest = np.floor(centres + 0.5).astype(int)
    covered = np.zeros(shape, dtype=bool)
    for d_row in range(-reach, reach + 1):
        for d_col in range(-reach, reach + 1):
            rows, cols = nearest[:, 0] + d_row, nearest[:, 1] + d_col
            hit = (rows - centres[:, 0]) ** 2 + (cols - centres[:, 1]) ** 2 <= radius_px**2
            hit &= (rows >= 0) & (rows < shape[0]) & (cols >= 0) & (cols < shape[1])
            covered[rows[hit], cols[hit]] = True
    return covered


def sample_polyline(waypoints: np.ndarray, spacing: float = RESOLUTION / 4) -> np.ndarray:
    """Points along a polyline at most ``spacing`` apart, for stamping the planned path."""
    pieces = [waypoints[:1]]
    for a, b in zip(waypoints[:-1], waypoints[1:]):
        count = max(1, math.ceil(np.hypot(*(b - a)) / spacing))
        pieces.append(a + np.linspace(0, 1, count + 1)[1:, None] * (b - a))
    return np.vstack(pieces)


def plan_segments_are_free(plan, centre_free: np.ndarray) -> bool:
    """Every segment after the start point lies on centre-free pixels."""
    pixels = to_pixel_coordinates(plan.waypoints)
    return all(segment_is_free(centre_free, a, b) for a, b in zip(pixels[1:-1], pixels[2:]))


def follow_in_env(env: CoverageEnv, info: dict, follower: PathFollower, max_steps: int = 20000):
    """Step the reset env with the follower's commands from ``info["pose"]`` until it is done.

    Returns the poses (x, y, heading) from the start on, one per step, and the last info.
    """
    poses = [info["pose"]]
    for _ in range(max_steps):
        if follower.done:
            break
        _, _, terminated, truncated, info = env.step(follower.act(info["pose"]))
        poses.append(info["pose"])
        assert not (terminated or truncated)
    return np.array(poses), info


def room_env(tmp_path, start: tuple[float, float], heading: float = 0.0) -> tuple[CoverageEnv, dict]:
    """The env in an empty 4 m x 4 m room, reset with the robot at ``start``, facing ``heading``."""
    env = CoverageEnv(Scene(4.0, 4.0, start).layout_file(tmp_path, heading), protocol="open")
    _, info = env.reset(seed=0)
    return env, info


def distance_to_polyline(points: np.ndarray, polyline: np.ndarray) -> np.ndarray:
    """Distance from each point to the nearest segment of a polyline."""
    return distances_to_segments(points, polyline[:-1], polyline[1:]).min(axis=1)


# ------------------------------------------------------------------------------------------
# Decomposition
# ------------------------------------------------------------------------------------------


@pytest.mark.parametrize("sweep_axis", [0, 1])
def test_empty_rectangle_is_one_cell(sweep_axis):
    free = np.ones((30, 50), dtype=bool)
    cells = decompose(free, sweep_axis)
    assert len(cells) == 1
    assert cells[0].area_px == free.sum()


@pytest.mark.parametrize("sweep_axis", [0, 1])
@pytest.mark.parametrize("max_jump", [None, 3])
def test_square_obstacle_gives_the_four_classic_cells(sweep_axis, max_jump):
    free = np.ones((40, 60), dtype=bool)
    free[15:25, 25:35] = False
    cells = decompose(free, sweep_axis, max_jump=max_jump)
    assert len(cells) == 4
    assert sum(cell.area_px for cell in cells) == free.sum()
    obstacle_lines = (15, 24) if sweep_axis == 0 else (25, 34)
    before, side_a, side_b, after = sorted(cells, key=lambda cell: (cell.first_line, cell.intervals[0, 0]))
    assert before.first_line == 0 and before.last_line == obstacle_lines[0] - 1
    for side in (side_a, side_b):  # the split: one cell on each side of the obstacle
        assert (side.first_line, side.last_line) == obstacle_lines
    assert side_a.intervals[0, 1] < side_b.intervals[0, 0]
    assert after.first_line == obstacle_lines[1] + 1  # the merge


@pytest.mark.parametrize("max_jump", [None, 3])
def test_cabin_decomposes_into_aisle_and_legroom_pockets(max_jump):
    centre_free = erode_by_radius(cabin(6.0, 4.0).free())
    pocket_count_per_side = 7
    # Slice lines along the aisle (rows): the aisle is one cell, each pocket another.
    cells = decompose(centre_free, sweep_axis=0, max_jump=max_jump)
    assert len(cells) == 1 + 2 * pocket_count_per_side
    lengths = np.array([cell.intervals[:, 1].max() - cell.intervals[:, 0].min() + 1 for cell in cells])
    aisle = cells[int(np.argmax(lengths))]
    assert lengths.max() * RESOLUTION > 5.5  # runs the length of the cabin
    assert (aisle.last_line - aisle.first_line + 1) * RESOLUTION < 0.48 - TOOL_WIDTH + 2 * RESOLUTION
    pockets = [cell for cell in cells if cell is not aisle]
    for pocket in pockets:
        assert is_narrow(pocket, TOOL_WIDTH, RESOLUTION)
        assert (pocket.last_line - pocket.first_line + 1) * RESOLUTION > 1.3  # wall to aisle
        widths = pocket.intervals[:, 1] - pocket.intervals[:, 0] + 1
        # Legroom less the robot diameter, to a pixel (rounded corners widen the pocket mouth).
        assert np.median(widths) * RESOLUTION <= 0.45 - TOOL_WIDTH + RESOLUTION
    assert sum(pocket.first_line > aisle.last_line for pocket in pockets) == pocket_count_per_side
    assert sum(cell.area_px for cell in cells) == centre_free.sum()


# ------------------------------------------------------------------------------------------
# Swaths and A*
# ------------------------------------------------------------------------------------------


@pytest.mark.parametrize("tool_width", [0.2, 0.33, 0.35, 0.4])
@pytest.mark.parametrize("extent", [1, 5, 7, 8, 20, 49, 73])
def test_lanes_are_never_more_than_a_tool_width_apart(tool_width, extent):
    free = np.ones((extent + 1, 30), dtype=bool)
    (cell,) = decompose(free, sweep_axis=0)
    lines = lane_lines(cell, line_view(free, 0), tool_width, RESOLUTION)
    assert np.all(np.diff(lines) * RESOLUTION <= tool_width + 1e-9)
    # Both end lines face walls, so the outermost lanes sit on them.
    assert lines[0] == 0 and lines[-1] == extent


def test_lanes_stay_inset_from_a_free_cell_boundary():
    free = np.ones((40, 30), dtype=bool)
    free[20:, 10:20] = False  # the cell below splits into two at row 20
    first_cell = decompose(free, sweep_axis=0)[0]
    lines = lane_lines(first_cell, line_view(free, 0), TOOL_WIDTH, RESOLUTION)
    assert lines[0] == 0 and lines[-1] == 19  # row 19 faces the obstacle
    (left,) = [cell for cell in decompose(free, 0) if cell.first_line == 20 and cell.intervals[0, 0] == 0]
    left_lines = lane_lines(left, line_view(free, 0), TOOL_WIDTH, RESOLUTION)
    # Row 20 borders only free pixels of the first cell: its first lane sits 3 rows further in,
    # so that the gap to the first cell's last lane stays within the tool width.
    assert left_lines[0] == 23 and left_lines[-1] == 39


def test_dead_end_is_swept_along_both_edges():
    free = np.zeros((40, 10), dtype=bool)
    free[2:38, 3:6] = True
    (cell,) = decompose(free, sweep_axis=0)
    assert is_narrow(cell, TOOL_WIDTH, RESOLUTION)
    units = cell_units(cell, 0, free, TOOL_WIDTH, RESOLUTION)
    # One unit per edge, so that the way in and the way out are routed like any other pass.
    assert [set(map(tuple, unit.variants[0])) for unit in units] == [{(2, 3), (37, 3)}, {(2, 5), (37, 5)}]
    for unit in units:
        assert len(unit.variants) == 2 and np.array_equal(unit.variants[1], unit.variants[0][::-1])


def test_corridor_between_two_rooms_is_swept_by_one_zigzag():
    free = two_rooms_and_a_corridor()
    centre_free = erode_by_radius(free)
    corridor_rows = np.flatnonzero(centre_free[:, 42])
    assert len(corridor_rows) == 2  # two pixels of play
    cells = decompose(centre_free, 1, max_jump=3)
    corridors = [cell for cell in cells if is_narrow(cell, TOOL_WIDTH, RESOLUTION)]
    assert len(corridors) == 1
    (unit,) = cell_units(corridors[0], 0, centre_free, TOOL_WIDTH, RESOLUTION, max_jump=3)
    zigzag = unit.variants[0]
    middle = zigzag[(zigzag[:, 1] > 33) & (zigzag[:, 1] < 51)]
    assert set(middle[:, 0]) == set(corridor_rows)
    assert np.all(np.abs(np.diff(middle, axis=0)) == 1)  # one line on, the other edge: 45 degrees
    assert all(segment_is_free(centre_free, a, b) for a, b in zip(zigzag[:-1], zigzag[1:]))

    start = (0.3, 0.75)
    plan = plan_coverage(centre_free, RESOLUTION, ORIGIN, TOOL_WIDTH, start)
    edges = plan_coverage(
        centre_free, RESOLUTION, ORIGIN, TOOL_WIDTH, start, options=SweepOptions(corridor_zigzags=False)
    )
    assert plan.coverage >= MIN_PLAN_COVERAGE and edges.coverage >= MIN_PLAN_COVERAGE
    assert plan.length < edges.length - 0.3  # the corridor is 1.2 m long: once at x1.4, not twice
    assert plan_segments_are_free(plan, centre_free)


def test_corridor_lanes_are_cut_where_pockets_attach():
    centre_free = erode_by_radius(cabin(6.0, 4.0).free())
    cells = decompose(centre_free, sweep_axis=0, max_jump=3)
    aisle = max(cells, key=lambda cell: cell.intervals[:, 1].max() - cell.intervals[:, 0].min())
    lines = line_view(centre_free, 0)
    points = attachment_points(aisle, lines)
    assert len(points) == 7  # seven legroom pockets on either side, facing each other
    units = cell_units(aisle, 0, centre_free, TOOL_WIDTH, RESOLUTION, max_jump=3)
    lanes = lane_lines(aisle, lines, TOOL_WIDTH, RESOLUTION)
    pieces_per_lane = len(units) // len(lanes)
    assert len(units) == len(lanes) * pieces_per_lane and pieces_per_lane == len(points) + 1
    for unit in units:  # each piece is a straight stretch of a lane
        (row_a, col_a), (row_b, col_b) = unit.variants[0]
        assert row_a == row_b and row_a in lanes and col_a < col_b


def test_transposed_cell_has_the_same_pixels():
    free = np.zeros((30, 20), dtype=bool)
    free[5:25, 4:16] = True
    free[10:20, 16:18] = True  # a bump on one side: still one cell across without max_jump
    (cell,) = decompose(free, sweep_axis=0)
    across = transpose_cell(cell)
    assert across is not None and across.sweep_axis == 1 and across.area_px == cell.area_px
    assert all(across.contains(row, col) for row, col in zip(*np.nonzero(free)))
    assert transpose_cell(cell, max_jump=3) is None  # the bump's 10-pixel jump splits it


def test_astar_is_optimal_and_stays_free():
    free = np.ones((30, 40), dtype=bool)
    free[5:25, 20] = False  # a wall to go around
    start, goal = (15, 5), (15, 35)
    path = astar(free, start, goal)
    assert tuple(path[0]) == start and tuple(path[-1]) == goal
    assert free[path[:, 0], path[:, 1]].all()
    steps = np.diff(path, axis=0)
    assert np.abs(steps).max() == 1
    diagonal = np.all(steps != 0, axis=1)
    # No corner cutting: both pixels beside a diagonal step are free.
    assert free[path[:-1][diagonal, 0] + steps[diagonal, 0], path[:-1][diagonal, 1]].all()
    assert free[path[:-1][diagonal, 0], path[:-1][diagonal, 1] + steps[diagonal, 1]].all()
    length = np.where(diagonal, math.sqrt(2), 1.0).sum()
    # Optimal: round the lower end of the wall (row 25), 10 rows down and back up.
    assert length == pytest.approx(20 * math.sqrt(2) + 10)
    assert length == pytest.approx(FreeSpace(free).pairwise_distances(np.array([start, goal]))[0, 1])
    assert astar(free, (15, 5), (15, 20)) is None  # a blocked goal

    simplified = FreeSpace(free).transit(start, goal)
    assert len(simplified) <= 4
    assert all(segment_is_free(free, a, b) for a, b in zip(simplified[:-1], simplified[1:]))


@pytest.mark.parametrize("radius", [math.inf, 12.0])
def test_geodesic_distances_equal_scipy_dijkstra_on_the_same_graph(radius):
    """The compiled searches (stopped at the routing radius) give scipy's distances to the bit, so
    routes do not depend on which computes them."""
    rng = np.random.default_rng(0)
    free = ndimage.binary_opening(rng.random((40, 50)) > 0.25)  # rooms of free pixels and specks
    space = FreeSpace(free, search_radius_px=radius)
    pixels = np.argwhere(free)[rng.choice(int(free.sum()), 60, replace=False)]
    pixels = np.vstack([pixels, pixels[:3]])  # a pixel given twice
    nodes = space.node_id[pixels[:, 0], pixels[:, 1]]
    reference = dijkstra(space.graph, directed=False, indices=nodes, limit=radius)[:, nodes]
    straight = np.sqrt(((pixels[:, None, :] - pixels[None, :, :]) ** 2).sum(axis=2))
    expected = np.where(np.isfinite(reference), reference, radius + straight)
    assert np.array_equal(space.pairwise_distances(pixels), expected)
    assert not np.isfinite(reference).all()  # some pairs out of reach (or in separate rooms)


def test_segment_check_rejects_corner_cutting():
    free = np.ones((5, 5), dtype=bool)
    free[1, 2] = False
    assert not segment_is_free(free, (0, 1), (2, 3))  # passes exactly through a corner of (1, 2)
    assert segment_is_free(free, (0, 0), (4, 0))
    assert not segment_is_free(free, (2, 0), (2, 5))  # leaves the raster


def touches_square(start, end, centre) -> bool:
    """Reference: does the closed segment meet the closed pixel square (Liang-Barsky clipping)?"""
    low, high = 0.0, 1.0
    delta = np.subtract(end, start)
    for axis in (0, 1):
        for bound, sign in ((centre[axis] - 0.5, -1.0), (centre[axis] + 0.5, 1.0)):
            p, q = sign * delta[axis], sign * (bound - start[axis])
            if p == 0.0:
                if q < 0.0:
                    return False
            elif p < 0.0:
                low = max(low, q / p)
            else:
                high = min(high, q / p)
    return low <= high + 1e-12


def test_segment_check_matches_a_clipping_reference():
    rng = np.random.default_rng(1)
    for trial in range(400):
        free = rng.random((10, 10)) > 0.1
        start, end = rng.integers(0, 10, 2).astype(float), rng.integers(0, 10, 2).astype(float)
        if trial % 2:  # fractional ends, kept inside their pixels
            start, end = start + rng.uniform(-0.45, 0.45, 2), end + rng.uniform(-0.45, 0.45, 2)
        blocked = zip(*np.nonzero(~free))
        expected = not any(touches_square(start, end, pixel) for pixel in blocked)
        assert segment_is_free(free, start, end) == expected, (start, end)


# ------------------------------------------------------------------------------------------
# Whole plans, followed in the kinematic simulator
# ------------------------------------------------------------------------------------------


def test_path_efficiency_in_the_empty_room():
    scene = SCENES["empty_room"]
    centre_free, start = erode_by_radius(scene.free()), scene.start
    plan = plan_coverage(centre_free, RESOLUTION, ORIGIN, TOOL_WIDTH, start)
    reachable_m2 = reachable_area(centre_free).sum() * RESOLUTION**2
    efficiency = (reachable_m2 / TOOL_WIDTH) / plan.length
    print(f"empty room: efficiency {efficiency:.3f}")
    assert efficiency >= 0.8


@pytest.mark.parametrize("sweep_axis", [0, 1])
def test_both_sweep_axes_give_complete_plans(sweep_axis):
    scene = SCENES["cabin"]
    free, start = scene.free(), scene.start
    centre_free = erode_by_radius(free)
    plan = plan_coverage(centre_free, RESOLUTION, ORIGIN, TOOL_WIDTH, start, sweep_axis=sweep_axis)
    assert plan.sweep_axis == sweep_axis
    assert plan_segments_are_free(plan, centre_free)
    reachable = reachable_area(centre_free)
    covered = stamp_discs(free.shape, sample_polyline(plan.waypoints)) & reachable
    assert covered.sum() / reachable.sum() >= 0.98
    assert sorted(plan.cell_order) == list(range(len(plan.cells)))


def plan_the_cabin_with_stderr_to(stream, monkeypatch):
    """Plan the cabin scene, writing stderr to ``stream``, with the progress bar due at once (it
    waits ``PROGRESS_DELAY_S`` otherwise: a cabin's plan is over before)."""
    monkeypatch.setattr(plan_module, "PROGRESS_DELAY_S", 0.0)
    monkeypatch.setattr(sys, "stderr", stream)
    scene = SCENES["cabin"]
    plan_coverage(erode_by_radius(scene.free()), RESOLUTION, ORIGIN, TOOL_WIDTH, scene.start)
    stream.flush()


def test_a_long_plan_shows_a_progress_bar_on_a_terminal(monkeypatch):
    master, slave = os.openpty()
    fcntl.ioctl(slave, termios.TIOCSWINSZ, struct.pack("HHHH", 24, 120, 0, 0))  # 120 columns wide
    with open(slave, "w") as terminal:
        plan_the_cabin_with_stderr_to(terminal, monkeypatch)
        shown = b""
        while select.select([master], [], [], 0)[0]:
            shown += os.read(master, 4096)
    os.close(master)
    # the bar counts the 4 stages of both sweep axes (tqdm redraws it at most every 0.1 s)
    assert "coverage plan:" in shown.decode() and "/8 [" in shown.decode()


def test_a_plan_piped_or_written_to_a_file_shows_no_bar(monkeypatch, tmp_path):
    with open(tmp_path / "stderr.txt", "w") as log:
        plan_the_cabin_with_stderr_to(log, monkeypatch)
    assert (tmp_path / "stderr.txt").read_text() == ""


def test_last_cells_are_swept_last():
    scene = SCENES["cabin"]
    free, start = scene.free(), scene.start
    centre_free = erode_by_radius(free)
    # Goal markers in two legroom pockets (the first and the fifth gap, on either side).
    first_pocket_x = 0.6 + 0.35 + 0.45 / 2
    markers = [(first_pocket_x, 0.5), (first_pocket_x + 4 * 0.8, 3.5)]
    marker_pixels = [world_to_pixel(marker, RESOLUTION, ORIGIN) for marker in markers]
    assert all(centre_free[pixel] for pixel in marker_pixels)

    def holds_marker(cell):
        return any(cell.contains(*pixel) for pixel in marker_pixels)

    free_order = plan_coverage(centre_free, RESOLUTION, ORIGIN, TOOL_WIDTH, start).cell_order
    plan = plan_coverage(centre_free, RESOLUTION, ORIGIN, TOOL_WIDTH, start, last_cells=holds_marker)
    marked = {index for index, cell in enumerate(plan.cells) if holds_marker(cell)}
    assert len(marked) == 2
    assert set(plan.cell_order[-2:]) == marked
    assert not set(free_order[-2:]) == marked  # the constraint changed the route
    assert plan_segments_are_free(plan, centre_free)


def _straight_line_distances(points):
    return np.linalg.norm(points[:, None, :] - points[None, :, :], axis=2)


def test_a_long_route_searched_by_neighbour_lists_is_as_short_as_an_exhaustive_one(monkeypatch):
    # 600 lanes (more than EXHAUSTIVE_ROUTE_UNITS) scattered over a 300 x 300 px floor, each
    # swept either way; the last 20 are kept for the end of the route.
    rng = np.random.default_rng(0)
    starts = rng.uniform(0, 300, size=(600, 2))
    ends = starts + rng.uniform(-6, 6, size=(600, 2))
    sweeps = [[np.array([a, b]), np.array([b, a])] for a, b in zip(starts, ends)]
    last = set(range(580, 600))
    assert len(sweeps) > route_module.EXHAUSTIVE_ROUTE_UNITS

    def length(tour):
        path = np.vstack([np.array([[150.0, 150.0]])] + [sweeps[unit][variant] for unit, variant in tour])
        return float(np.linalg.norm(np.diff(path, axis=0), axis=1).sum())

    by_neighbours = route_module.route(sweeps, (150, 150), _straight_line_distances, last)
    monkeypatch.setattr(route_module, "EXHAUSTIVE_ROUTE_UNITS", len(sweeps))
    exhaustive = route_module.route(sweeps, (150, 150), _straight_line_distances, last)
    for tour in (by_neighbours, exhaustive):
        assert sorted(unit for unit, _ in tour) == list(range(600))
        assert {unit for unit, _ in tour[-20:]} == last
    assert by_neighbours != exhaustive  # the neighbour lists searched differently
    assert length(by_neighbours) <= 1.02 * length(exhaustive)


def test_a_floor_too_large_to_route_in_one_piece_is_refused_in_one_line(monkeypatch):
    # On a machine without memory even a small room's distance tables do not fit.
    free_space = importlib.import_module("cabinbench.baselines.coverage_planning.free_space")
    page = os.sysconf("SC_PAGE_SIZE")
    monkeypatch.setattr(free_space.os, "sysconf", lambda name: page if name == "SC_PAGE_SIZE" else 0)
    with pytest.raises(UsageError, match="distance tables need about .* split it into cells") as error:
        plan_coverage(np.ones((40, 40), dtype=bool), RESOLUTION, ORIGIN, TOOL_WIDTH, (1.0, 1.0))
    assert "\n" not in str(error.value)


def test_per_cell_direction_beats_a_single_axis():
    # The cabin zone: columns of legroom crossing an aisle, and an open zone 0.55 m wide (for
    # the robot centre) at the front. Lanes along the columns suit the columns, but the front
    # zone then needs three long lanes 5 pixels apart; lanes across it, 11 short ones, cover it
    # with less driving. Only a per-cell choice gets both.
    scene = SCENES["cabin_zone"]
    centre_free, start = erode_by_radius(scene.free()), scene.start
    per_cell = plan_coverage(centre_free, RESOLUTION, ORIGIN, TOOL_WIDTH, start)
    for axis in (0, 1):
        single = plan_coverage(
            centre_free,
            RESOLUTION,
            ORIGIN,
            TOOL_WIDTH,
            start,
            sweep_axis=axis,
            options=SweepOptions(lane_direction="slice"),
        )
        print(f"cabin zone: per-cell {per_cell.length:.2f} m, single axis {axis} {single.length:.2f} m")
        assert per_cell.length < single.length - 0.5
    assert per_cell.coverage >= MIN_PLAN_COVERAGE
    assert plan_segments_are_free(per_cell, centre_free)


def test_dropping_idle_corners_keeps_coverage():
    free = np.ones((30, 40), dtype=bool)
    radius_px = RADIUS / RESOLUTION
    # Two lanes, a detour back into the area they cover, then the third lane.
    path = np.array([[5, 5], [5, 35], [12, 35], [12, 5], [9, 10], [19, 5], [19, 35]], dtype=float)
    shorter = drop_idle_corners(path, free, radius_px)

    def covered(points):
        pixels = [segment_footprint(a, b, radius_px, free.shape) for a, b in zip(points[:-1], points[1:])]
        return set(np.concatenate(pixels).tolist())

    assert [9, 10] not in shorter.tolist()
    assert covered(shorter) >= covered(path)
    assert len(shorter) < len(path) and np.array_equal(shorter[[0, -1]], path[[0, -1]])


def test_long_cabin_plan_sweeps_every_cell_within_the_free_space():
    free = cabin(20.0, 4.0, end_margin=0.6).free()
    assert free.shape == (80, 400)
    centre_free = erode_by_radius(free)
    plan = plan_coverage(centre_free, RESOLUTION, ORIGIN, TOOL_WIDTH, (0.3, 2.0))
    assert plan.coverage >= MIN_PLAN_COVERAGE
    assert sorted(plan.cell_order) == list(range(len(plan.cells)))
    assert plan_segments_are_free(plan, centre_free)


# ------------------------------------------------------------------------------------------
# Plans driven in the env
# ------------------------------------------------------------------------------------------


@pytest.mark.parametrize("scene", list(SCENES))
def test_plan_driven_in_the_env_covers_the_floor(scene, tmp_path):
    env = CoverageEnv(SCENES[scene].layout_file(tmp_path), protocol="open")
    _, info = env.reset(seed=0)
    layout, robot = env.layout, env.layout.robot
    plan = plan_coverage(
        layout.centre_free,
        RESOLUTION,
        layout.origin,
        robot.tool_width,
        layout.start[:2],
        max_speed=robot.max_speed,
        max_turn_rate=robot.max_turn_rate,
    )
    assert np.allclose(plan.waypoints[0], layout.start[:2])
    assert plan_segments_are_free(plan, layout.centre_free)
    assert plan.coverage >= MIN_PLAN_COVERAGE

    follower = PathFollower(plan.waypoints, robot.max_speed, robot.max_turn_rate, TIME_STEP)
    _, info = follow_in_env(env, info, follower)
    assert follower.done
    print(
        f"{scene}: sweep axis {plan.sweep_axis}, {len(plan.cells)} cells, {plan.length:.1f} m planned, "
        f"{info['time']:.1f} s driven ({plan.duration:.1f} s estimated), coverage {info['coverage']:.4f}, "
        f"{info['collisions']} contacts"
    )
    assert plan.duration <= info["time"] <= 1.15 * plan.duration  # the estimate the axis choice uses
    assert info["collisions"] == 0  # the path keeps the disc off every wall and obstacle
    assert info["coverage"] >= 0.98


# ------------------------------------------------------------------------------------------
# Path follower, in the env
# ------------------------------------------------------------------------------------------


def test_follower_tracks_corners_closely(tmp_path):
    path = np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 0.1], [0.0, 0.1], [0.0, 1.5], [1.0, 2.5]]) + 0.7
    env, info = room_env(tmp_path, path[0], heading=math.pi / 2)
    follower = PathFollower(path, 0.5, 2.0, TIME_STEP)
    poses, info = follow_in_env(env, info, follower, max_steps=1000)
    assert follower.done
    assert np.hypot(*(poses[-1, :2] - path[-1])) <= follower.goal_tolerance
    assert distance_to_polyline(poses[:, :2], path).max() < TRACKING_TOLERANCE


def test_follower_stops_on_corners_at_full_speed(tmp_path):
    # A long diagonal at full speed into a corner, as transits into cell corners are: the physics
    # motor keeps the old speed for a substep after each command, and the robot must still stop
    # within millimetres of the corner and of the end (walls may be 1 cm away).
    path = np.array([[0.0, 0.0], [1.5, 0.6], [1.5, 2.0]]) + 0.7
    env, info = room_env(tmp_path, path[0], heading=math.atan2(0.6, 1.5))
    follower = PathFollower(path, 0.5, 2.0, TIME_STEP)
    poses, _ = follow_in_env(env, info, follower, max_steps=1000)
    assert follower.done
    assert distance_to_polyline(poses[:, :2], path).max() < CORNER_TOLERANCE


def test_follower_returns_to_the_line_from_off_it(tmp_path):
    # As after a push by a wall contact: the robot is 6 cm to the side of the segment it tracks,
    # and steers back onto its line rather than straight for the next waypoint.
    path = np.array([[0.5, 1.0], [3.5, 1.0], [3.5, 2.0]])
    env, info = room_env(tmp_path, (0.5, 1.06))
    follower = PathFollower(path, 0.5, 2.0, TIME_STEP)
    follower.skip_to(1)
    poses, _ = follow_in_env(env, info, follower, max_steps=1000)
    assert follower.done
    deviation = distance_to_polyline(poses[:, :2], path)
    assert deviation[0] == pytest.approx(0.06)
    assert deviation[poses[:, 0] > 1.0].max() < TRACKING_TOLERANCE  # back on the line within 0.5 m


def test_follower_skip_and_retarget(tmp_path):
    path = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [2.0, 1.0]]) + 1.0
    env, info = room_env(tmp_path, path[2])
    follower = PathFollower(path, 0.5, 2.0, TIME_STEP)
    assert follower.act((1.0, 1.0, 0.0))[0] > 0  # at the path start, facing the first segment: drives
    follower.skip_to(3)
    assert follower.target_index == 3
    poses, info = follow_in_env(env, info, follower, max_steps=200)
    assert follower.done
    assert np.array_equal(follower.act(info["pose"]), np.zeros(2))

    follower.set_path([path[3], [3.0, 1.0]])
    assert not follower.done
    command = follower.act(info["pose"])
    assert command[0] == 0.0 and command[1] == -1.0  # turns clockwise in place, at full rate
    poses, _ = follow_in_env(env, info, follower, max_steps=200)
    assert follower.done and np.hypot(*(poses[-1, :2] - [3.0, 1.0])) <= follower.goal_tolerance


def test_follower_never_skips_a_corner(tmp_path):
    # A hairpin: the robot passes close to waypoint 3 while on the first segment.
    path = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 0.08], [0.0, 0.08]]) + 1.0
    env, info = room_env(tmp_path, path[0])
    follower = PathFollower(path, 0.5, 2.0, TIME_STEP)
    targets = []
    for _ in range(300):
        if follower.done:
            break
        action = follower.act(info["pose"])
        targets.append(follower.target_index)
        *_, info = env.step(action)
    assert follower.done
    assert targets == sorted(targets) and set(targets) == {1, 2, 3}
