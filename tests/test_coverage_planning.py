"""Tests of the raster coverage planner and the path follower.

The end-to-end tests run the follower in a small kinematic simulator defined here (unicycle
integration at dt = 0.1 s, 0.5 m/s, 2 rad/s, the robot disc stamped on a raster), so they need
no physics engine.
"""

import math
import time

import numpy as np
import pytest
from scipy import ndimage

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
from cabinbench.baselines.path_following import PathFollower
from cabinbench.geometry import world_to_pixel

RESOLUTION = 0.05
TOOL_WIDTH = 0.35
RADIUS = TOOL_WIDTH / 2
ORIGIN = (0.0, 0.0)
DT = 0.1
MAX_SPEED = 0.5
MAX_TURN_RATE = 2.0


# ------------------------------------------------------------------------------------------
# Scenes
# ------------------------------------------------------------------------------------------


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


def cabin(length: float, width: float, end_margin: float = 0.0) -> np.ndarray:
    """Free space of a cabin-like room, aisle along x (columns), as a (width, length) raster.

    Seat blocks are attached to both side walls, leaving a central aisle 0.48 m wide; blocks
    0.35 m deep alternate with 0.45 m legroom gaps. ``end_margin`` leaves open floor (galleys)
    at both ends.
    """
    aisle_width, gap_width, seat_pitch = 0.48, 0.45, 0.80
    rows, cols = int(round(width / RESOLUTION)), int(round(length / RESOLUTION))
    y = (np.arange(rows) + 0.5) * RESOLUTION
    x = (np.arange(cols) + 0.5) * RESOLUTION
    free = np.zeros((rows, cols), dtype=bool)
    free[np.abs(y - width / 2) < aisle_width / 2, :] = True
    block_depth = seat_pitch - gap_width
    gap_start = end_margin + block_depth
    while gap_start + gap_width + block_depth <= length - end_margin + 1e-9:
        free[:, (x >= gap_start) & (x < gap_start + gap_width)] = True
        gap_start += seat_pitch
    free[:, (x < end_margin) | (x >= length - end_margin)] = True
    return free


def room_with_obstacles() -> np.ndarray:
    """4 m x 6 m room with two rectangular obstacles and a round one."""
    free = np.ones((80, 120), dtype=bool)
    free[30:50, 50:70] = False
    free[10:20, 10:40] = False
    rows, cols = np.mgrid[:80, :120]
    free[(rows - 60) ** 2 + (cols - 95) ** 2 < 100] = False
    return free


def cabin_zone() -> np.ndarray:
    """A 3.7 m x 2.6 m cabin zone like the A320 cell: an open zone 0.95 m deep at the front
    (x < 0.95 m), then two seat blocks with a legroom column (0.45 m) between them and one
    behind, all crossed by a 0.4 m cross aisle in the middle."""
    free = np.ones((74, 52), dtype=bool)
    free[4:70, 19:27] = False
    free[4:70, 35:43] = False
    free[33:41, 19:43] = True
    return free


def two_rooms_and_a_corridor() -> np.ndarray:
    """Two 1.5 m square rooms joined by a 1.2 m corridor that leaves the robot centre two
    pixels of play (0.4 m wide)."""
    free = np.zeros((30, 84), dtype=bool)
    free[:, :30] = True
    free[:, 54:] = True
    free[11:19, 30:54] = True
    return free


SCENES = {
    "empty_room": (np.ones((80, 120), dtype=bool), (0.3, 0.3)),
    "room_with_obstacles": (room_with_obstacles(), (0.3, 0.3)),
    "cabin": (cabin(6.0, 4.0, end_margin=0.6), (0.3, 2.0)),
    "cabin_zone": (cabin_zone(), (0.25, 1.85)),
}


# ------------------------------------------------------------------------------------------
# Kinematic simulator
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


def simulate(
    follower: PathFollower, pose, max_steps: int, substeps: int = 4, push=None, lag_substeps: int = 0
) -> np.ndarray:
    """Run the follower on a unicycle; returns every (x, y, heading) visited, substeps included.

    Each control period is integrated exactly (straight line or circular arc) in ``substeps``
    pieces so that the stamped discs leave no gaps. ``push(step, pose)`` may return a
    displacement (dx, dy) applied after a period, as a wall contact would. ``lag_substeps``
    substeps of each period still run at the previous period's speeds, as a drive that takes a
    moment to follow a new command does (the env's physics motor lags by one substep).
    """
    x, y, heading = pose
    poses = [(x, y, heading)]
    previous = (0.0, 0.0)
    for step in range(max_steps):
        if follower.done:
            break
        linear, angular = follower.act((x, y, heading))
        assert -1.0 <= linear <= 1.0 and -1.0 <= angular <= 1.0
        command = (linear * MAX_SPEED, angular * MAX_TURN_RATE)
        h = DT / substeps
        for substep in range(substeps):
            speed, turn_rate = previous if substep < lag_substeps else command
            if abs(turn_rate) > 1e-12:
                new_heading = heading + turn_rate * h
                x += speed / turn_rate * (math.sin(new_heading) - math.sin(heading))
                y -= speed / turn_rate * (math.cos(new_heading) - math.cos(heading))
                heading = new_heading
            else:
                x += speed * math.cos(heading) * h
                y += speed * math.sin(heading) * h
            poses.append((x, y, heading))
        if push is not None:
            dx, dy = push(step, (x, y, heading))
            x, y = x + dx, y + dy
            poses.append((x, y, heading))
        previous = command
    return np.array(poses)


def sample_polyline(waypoints: np.ndarray, spacing: float = RESOLUTION / 4) -> np.ndarray:
    """Points along a polyline at most ``spacing`` apart, for stamping the planned path."""
    pieces = [waypoints[:1]]
    for a, b in zip(waypoints[:-1], waypoints[1:]):
        count = max(1, math.ceil(np.hypot(*(b - a)) / spacing))
        pieces.append(a + np.linspace(0, 1, count + 1)[1:, None] * (b - a))
    return np.vstack(pieces)


def within_one_pixel_of(centre_free: np.ndarray, positions: np.ndarray) -> np.ndarray:
    """For each position (x, y), whether its pixel is centre-free or touches one that is."""
    tolerant = ndimage.binary_dilation(centre_free, structure=np.ones((3, 3), dtype=bool))
    pixels = np.floor(to_pixel_coordinates(positions) + 0.5).astype(int)
    inside = (pixels[:, 0] >= 0) & (pixels[:, 0] < tolerant.shape[0])
    inside &= (pixels[:, 1] >= 0) & (pixels[:, 1] < tolerant.shape[1])
    result = np.zeros(len(positions), dtype=bool)
    result[inside] = tolerant[pixels[inside, 0], pixels[inside, 1]]
    return result


def plan_segments_are_free(plan, centre_free: np.ndarray) -> bool:
    """Every segment after the start point lies on centre-free pixels."""
    pixels = to_pixel_coordinates(plan.waypoints)
    return all(segment_is_free(centre_free, a, b) for a, b in zip(pixels[1:-1], pixels[2:]))


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
    centre_free = erode_by_radius(cabin(6.0, 4.0))
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
    centre_free = erode_by_radius(cabin(6.0, 4.0))
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


@pytest.mark.parametrize("scene", list(SCENES))
def test_plan_and_follow_covers_the_reachable_area(scene):
    free, start = SCENES[scene]
    centre_free = erode_by_radius(free)
    plan = plan_coverage(centre_free, RESOLUTION, ORIGIN, TOOL_WIDTH, start)
    assert np.allclose(plan.waypoints[0], start)
    assert plan_segments_are_free(plan, centre_free)
    assert plan.coverage >= MIN_PLAN_COVERAGE

    follower = PathFollower(plan.waypoints, MAX_SPEED, MAX_TURN_RATE, DT)
    poses = simulate(follower, (*start, 0.0), max_steps=20000)
    assert follower.done
    steps = (len(poses) - 1) // 4
    assert plan.duration <= steps * DT <= 1.15 * plan.duration  # the estimate the axis choice uses
    assert within_one_pixel_of(centre_free, poses[:, :2]).all()
    reachable = reachable_area(centre_free)
    covered = stamp_discs(free.shape, poses[:, :2]) & reachable
    coverage = covered.sum() / reachable.sum()
    print(
        f"{scene}: sweep axis {plan.sweep_axis}, {len(plan.cells)} cells, "
        f"{plan.length:.1f} m planned, {steps} steps, coverage {coverage:.4f}"
    )
    assert coverage >= 0.98


def test_path_efficiency_in_the_empty_room():
    free, start = SCENES["empty_room"]
    centre_free = erode_by_radius(free)
    plan = plan_coverage(centre_free, RESOLUTION, ORIGIN, TOOL_WIDTH, start)
    reachable_m2 = reachable_area(centre_free).sum() * RESOLUTION**2
    efficiency = (reachable_m2 / TOOL_WIDTH) / plan.length
    print(f"empty room: efficiency {efficiency:.3f}")
    assert efficiency >= 0.8


@pytest.mark.parametrize("sweep_axis", [0, 1])
def test_both_sweep_axes_give_complete_plans(sweep_axis):
    free, start = SCENES["cabin"]
    centre_free = erode_by_radius(free)
    plan = plan_coverage(centre_free, RESOLUTION, ORIGIN, TOOL_WIDTH, start, sweep_axis=sweep_axis)
    assert plan.sweep_axis == sweep_axis
    assert plan_segments_are_free(plan, centre_free)
    reachable = reachable_area(centre_free)
    covered = stamp_discs(free.shape, sample_polyline(plan.waypoints)) & reachable
    assert covered.sum() / reachable.sum() >= 0.98
    assert sorted(plan.cell_order) == list(range(len(plan.cells)))


def test_last_cells_are_swept_last():
    free, start = SCENES["cabin"]
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


def test_per_cell_direction_beats_a_single_axis():
    # The cabin zone: columns of legroom crossing an aisle, and an open zone 0.55 m wide (for
    # the robot centre) at the front. Lanes along the columns suit the columns, but the front
    # zone then needs three long lanes 5 pixels apart; lanes across it, 11 short ones, cover it
    # with less driving. Only a per-cell choice gets both.
    centre_free = erode_by_radius(cabin_zone())
    start = SCENES["cabin_zone"][1]
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


def test_long_cabin_plan_and_its_planning_time():
    free = cabin(20.0, 4.0, end_margin=0.6)
    assert free.shape == (80, 400)
    centre_free = erode_by_radius(free)
    timings = []
    for _ in range(3):
        begin = time.perf_counter()
        plan = plan_coverage(centre_free, RESOLUTION, ORIGIN, TOOL_WIDTH, (0.3, 2.0))
        timings.append(time.perf_counter() - begin)
    print(
        f"400x80 cabin: best of 3 planning times {min(timings) * 1000:.0f} ms, "
        f"{len(plan.cells)} cells, {plan.length:.1f} m, sweep axis {plan.sweep_axis}"
    )
    assert plan_segments_are_free(plan, centre_free)


# ------------------------------------------------------------------------------------------
# Path follower
# ------------------------------------------------------------------------------------------


def distance_to_polyline(points: np.ndarray, polyline: np.ndarray) -> np.ndarray:
    """Distance from each point to the nearest segment of a polyline."""
    starts, ends = polyline[:-1], polyline[1:]
    segments = ends - starts
    lengths2 = np.maximum((segments**2).sum(axis=1), 1e-12)
    t = np.clip(((points[:, None, :] - starts[None]) * segments[None]).sum(axis=2) / lengths2, 0, 1)
    nearest = starts[None] + t[..., None] * segments[None]
    return np.linalg.norm(points[:, None, :] - nearest, axis=2).min(axis=1)


def test_follower_tracks_corners_closely():
    path = np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 0.1], [0.0, 0.1], [0.0, 1.5], [1.0, 2.5]])
    follower = PathFollower(path, MAX_SPEED, MAX_TURN_RATE, DT)
    poses = simulate(follower, (0.0, 0.0, math.pi / 2), max_steps=1000)
    assert follower.done
    assert np.hypot(*(poses[-1, :2] - path[-1])) <= follower.goal_tolerance
    assert distance_to_polyline(poses[:, :2], path).max() < 0.005


def test_follower_stops_on_corners_despite_a_lagging_drive():
    # A long diagonal at full speed into a corner, as transits into cell corners are: the drive
    # keeps its old speed for a quarter of each period, and the robot must still stop within
    # millimetres of the corner and of the end (walls may be 1 cm away).
    path = np.array([[0.0, 0.0], [1.5, 0.6], [1.5, 2.0]])
    follower = PathFollower(path, MAX_SPEED, MAX_TURN_RATE, DT)
    poses = simulate(follower, (0.0, 0.0, math.atan2(0.6, 1.5)), max_steps=1000, lag_substeps=1)
    assert follower.done
    # Overshoot at the corner and past the end (12 mm with a braking deceleration of 2 m/s^2).
    assert distance_to_polyline(poses[:, :2], path).max() < 0.008


def test_follower_recovers_from_pushes():
    path = np.array([[0.0, 0.0], [3.0, 0.0], [3.0, 1.0]])
    follower = PathFollower(path, MAX_SPEED, MAX_TURN_RATE, DT)

    def push(step, pose):
        return (0.0, 0.04) if step in (10, 11, 30) else (0.0, 0.0)

    poses = simulate(follower, (0.0, 0.0, 0.0), max_steps=1000, push=push)
    assert follower.done
    deviation = distance_to_polyline(poses[:, :2], path)
    assert deviation.max() < 0.09  # the pushes themselves
    assert deviation[-100:].max() < 0.005  # back on the line well before the end


def test_follower_skip_and_retarget():
    path = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [2.0, 1.0]])
    follower = PathFollower(path, MAX_SPEED, MAX_TURN_RATE, DT)
    assert follower.act((0.0, 0.0, 0.0))[0] > 0  # already facing the first segment: drives
    follower.skip_to(3)
    assert follower.target_index == 3
    simulate(follower, (1.0, 1.0, 0.0), max_steps=200)
    assert follower.done
    assert np.array_equal(follower.act((2.0, 1.0, 0.0)), np.zeros(2))

    follower.set_path([[2.0, 1.0], [2.0, 0.0]])
    assert not follower.done
    command = follower.act((2.0, 1.0, 0.0))
    assert command[0] == 0.0 and command[1] == -1.0  # turns clockwise in place, at full rate
    poses = simulate(follower, (2.0, 1.0, 0.0), max_steps=200)
    assert follower.done and np.hypot(*(poses[-1, :2] - [2.0, 0.0])) <= follower.goal_tolerance


def test_follower_never_skips_a_corner():
    # A hairpin: the robot passes close to waypoint 3 while on the first segment.
    path = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 0.08], [0.0, 0.08]])
    follower = PathFollower(path, MAX_SPEED, MAX_TURN_RATE, DT)
    targets = []
    x, y, heading = 0.0, 0.0, 0.0
    for _ in range(300):
        if follower.done:
            break
        linear, angular = follower.act((x, y, heading))
        targets.append(follower.target_index)
        heading += angular * MAX_TURN_RATE * DT
        x += linear * MAX_SPEED * math.cos(heading) * DT
        y += linear * MAX_SPEED * math.sin(heading) * DT
    assert follower.done
    assert targets == sorted(targets) and set(targets) == {1, 2, 3}
