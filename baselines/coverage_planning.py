"""Complete-coverage path planning on a raster, for a disc-shaped cleaning robot.

The planner is a pipeline of small, replaceable steps (in the spirit of Fields2Cover):

1. ``decompose``: boustrophedon cellular decomposition (Choset, 2000). A slice line (a raster
   row or column) sweeps across the free space; the free intervals of consecutive slices are
   matched, and a cell ends wherever the matching is not one-to-one (an interval splits, two
   merge, one appears or disappears). A cell also ends where an interval end jumps by more than
   ``max_jump`` pixels: such a jump hides a pocket that lanes spaced one tool width apart could
   step over (the legroom between two seat rows is the typical case). ``transpose_cell`` tells
   whether a cell's pixels are also one cell of the other axis, i.e. may be swept either way.
2. ``swaths``: the sweep lines of one cell. Ordinary cells get lanes evenly spaced at most one
   tool width apart; an end of the cell that faces a wall or obstacle gets a lane on its
   outermost valid centre positions, an end shared with free neighbouring cells is left to
   their lanes. Cells narrower than a tool width but long get one pass along each of their two
   edges, except that a corridor two pixels wide between two cells gets one zigzag pass
   (``corridor_zigzag``). Lanes of one- or two-lane cells are cut where other cells attach
   (``attachment_points``), lanes of wider zones into blocks where corridors branch off their
   side (``lane_blocks``).
3. ``cell_units``: the route units of each cell and the ways to drive each. The lane direction
   is chosen per cell: a cell that may be swept either way offers the boustrophedon sweeps of
   both directions (``cell_sweeps``: four per direction, two start corners, each either way
   round, connectors along the cell edge), and the route picks one.
4. ``route``: the order of the units and the variant of each: greedy nearest neighbour from
   the start, then 2-opt, Or-opt (which fits a side pocket in between two stretches of the
   corridor it branches off) and a dynamic programme over the variants, with geodesic transit
   costs. Units of ``last_cells`` come after all the others.
5. ``join`` and ``drop_idle_corners``: A* transits between the units (8-connected, simplified by
   line-of-sight shortcuts), then every corner whose shortcut loses no coverage is cut out.

``plan_coverage`` runs the pipeline for both decomposition axes and keeps the shortest plan
that covers at least ``MIN_PLAN_COVERAGE`` of the coverable area (``SweepOptions`` switches the
choices of steps 2-3 off, for comparisons).

Conventions: a raster is indexed ``[row, col] = [iy, ix]`` and pixel (iy, ix) has its centre at
``origin + ((ix + 0.5) * resolution, (iy + 0.5) * resolution)`` metres. Internally all geometry
is in pixel coordinates (row, col), where a pixel centre has integer coordinates and the pixel
covers [row - 0.5, row + 0.5] x [col - 0.5, col + 0.5]. ``centre_free`` marks the pixels where
the robot centre may be (free space eroded by the robot radius). Every segment of a plan stays
inside ``centre_free``: lanes lie on free intervals, connectors on staircases of free pixels,
and every zigzag and shortcut is checked against the raster (``segment_is_free``). A pixel
counts as covered when its centre lies within the tool radius of the path.
"""

from __future__ import annotations

import heapq
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from functools import cached_property

import numpy as np
from scipy import ndimage, sparse
from scipy.sparse.csgraph import dijkstra
from scipy.spatial.distance import cdist

SQRT2 = math.sqrt(2.0)

# Routing costs are geodesic distances, computed by Dijkstra from every cell corner. Searching
# the whole raster from every corner would dominate the planning time (its cost grows with the
# searched area), and the route only needs exact costs between nearby cells, so each search stops
# at this radius; pairs farther apart are ranked by (radius + straight-line distance). Radii from
# 1.5 m to 8 m give plans within 1% of each other on the built-in layouts.
ROUTING_SEARCH_RADIUS_M = 3.0

# Plans should cover at least this fraction of the coverable area: the benchmark's success
# threshold (0.98) plus a margin for tracking errors and for what the protocol leaves out.
MIN_PLAN_COVERAGE = 0.985

# A corner is only cut out when the shortcut covers what the corner alone covered with this much
# to spare (metres), so that a robot tracking the path a centimetre off still covers it.
SHORTCUT_MARGIN_M = 0.01

# Douglas-Peucker tolerance (pixels) for boundary-following polylines. Slightly above
# sqrt(2)/2 so that a 45-degree staircase of single-pixel steps becomes one diagonal segment,
# while steps of two pixels or more (real corners) are kept.
BOUNDARY_SIMPLIFY_TOLERANCE_PX = 0.75


# --------------------------------------------------------------------------------------------
# Coordinates
# --------------------------------------------------------------------------------------------


def world_to_pixel(point: Sequence[float], resolution: float, origin: Sequence[float]) -> tuple[int, int]:
    """(row, col) of the pixel containing world point (x, y)."""
    return (
        int(math.floor((point[1] - origin[1]) / resolution)),
        int(math.floor((point[0] - origin[0]) / resolution)),
    )


def pixels_to_world(pixels: np.ndarray, resolution: float, origin: Sequence[float]) -> np.ndarray:
    """World (x, y) of pixel coordinates (row, col), shape (N, 2) -> (N, 2)."""
    pixels = np.asarray(pixels, dtype=float)
    return np.column_stack(
        (origin[0] + (pixels[:, 1] + 0.5) * resolution, origin[1] + (pixels[:, 0] + 0.5) * resolution)
    )


def polyline_length(points: np.ndarray) -> float:
    """Length of a polyline given as an (N, 2) array."""
    return float(np.linalg.norm(np.diff(points, axis=0), axis=1).sum()) if len(points) > 1 else 0.0


def driving_time(waypoints: np.ndarray, max_speed: float, max_turn_rate: float) -> float:
    """Time (s) to drive a polyline at full speed, turning in place at full rate at each waypoint.

    A differential-drive robot in tight spaces turns in place at the corners, and on a
    boustrophedon path those turns take about as long as the straight driving.
    """
    segments = np.diff(waypoints, axis=0)
    segments = segments[np.any(segments != 0, axis=1)]
    headings = np.arctan2(segments[:, 1], segments[:, 0])
    turns = np.abs((np.diff(headings) + math.pi) % (2.0 * math.pi) - math.pi)
    return polyline_length(waypoints) / max_speed + float(turns.sum()) / max_turn_rate


# --------------------------------------------------------------------------------------------
# Free space: segment checks, A*, geodesic distances
# --------------------------------------------------------------------------------------------


def segment_is_free(free: np.ndarray, start: Sequence[float], end: Sequence[float]) -> bool:
    """True if every pixel that the segment start-end (pixel coordinates) passes through or
    touches is free.

    A pixel square meets the segment's line when the line passes within half the square's
    extent across the line of its centre; inside the bounding box of the endpoints' pixels,
    that is the segment itself. A segment passing exactly through a pixel corner touches all
    the pixels at that corner (so it never cuts a corner, like A*).
    """
    start, end = np.asarray(start, dtype=float), np.asarray(end, dtype=float)
    low = np.floor(np.minimum(start, end) + 0.5).astype(int)
    high = np.floor(np.maximum(start, end) + 0.5).astype(int)
    if low.min() < 0 or high[0] >= free.shape[0] or high[1] >= free.shape[1]:
        return False
    window = free[low[0] : high[0] + 1, low[1] : high[1] + 1]
    if window.all():
        return True
    delta = end - start
    rows, cols = np.nonzero(~window)
    offset = (rows + low[0] - start[0]) * delta[1] - (cols + low[1] - start[1]) * delta[0]
    reach = 0.5 * (abs(delta[0]) + abs(delta[1]))
    return not bool(np.any(np.abs(offset) <= reach + 1e-9))


class FreeSpace:
    """A centre-free raster prepared for repeated A* searches and geodesic distance queries.

    A* runs in pure Python over a flat list with a one-pixel obstacle border, so that the inner
    loop needs no bounds checks. Geodesic distances use the same 8-connected graph (diagonal
    moves only where both side pixels are free) as a sparse matrix for scipy's Dijkstra.
    """

    def __init__(self, free: np.ndarray, search_radius_px: float = math.inf):
        self.free = np.asarray(free, dtype=bool)
        self.search_radius_px = search_radius_px
        height, width = self.free.shape
        self.padded_width = width + 2
        padded = np.zeros((height + 2, width + 2), dtype=bool)
        padded[1:-1, 1:-1] = self.free
        self.free_flat = padded.ravel().tolist()
        self.node_id = np.full(self.free.shape, -1, dtype=np.int64)
        self.node_id[self.free] = np.arange(int(self.free.sum()))

    @cached_property
    def graph(self) -> sparse.csr_matrix:
        """The 8-connected pixel graph (built on first use: A* alone does not need it)."""
        free, ids = self.free, self.node_id
        tails, heads, weights = [], [], []

        def add_edges(tail_ids, head_ids, mask, weight):
            tails.append(tail_ids[mask])
            heads.append(head_ids[mask])
            weights.append(np.full(int(mask.sum()), weight))

        add_edges(ids[:, :-1], ids[:, 1:], free[:, :-1] & free[:, 1:], 1.0)
        add_edges(ids[:-1, :], ids[1:, :], free[:-1, :] & free[1:, :], 1.0)
        square_free = free[:-1, :-1] & free[1:, 1:] & free[:-1, 1:] & free[1:, :-1]
        add_edges(ids[:-1, :-1], ids[1:, 1:], square_free, SQRT2)
        add_edges(ids[:-1, 1:], ids[1:, :-1], square_free, SQRT2)
        node_count = int(free.sum())
        return sparse.csr_matrix(
            (np.concatenate(weights), (np.concatenate(tails), np.concatenate(heads))),
            shape=(node_count, node_count),
        )

    def astar(self, start: Sequence[int], goal: Sequence[int]) -> np.ndarray | None:
        """Shortest 8-connected pixel path from start to goal (inclusive), or None."""
        width = self.padded_width
        free = self.free_flat
        start_node = (start[0] + 1) * width + start[1] + 1
        goal_node = (goal[0] + 1) * width + goal[1] + 1
        if not (free[start_node] and free[goal_node]):
            return None
        goal_row, goal_col = divmod(goal_node, width)
        # (offset, step cost, the two side neighbours a diagonal step must not cut between)
        moves = [(1, 1.0, 0, 0), (-1, 1.0, 0, 0), (width, 1.0, 0, 0), (-width, 1.0, 0, 0)]
        moves += [(dr * width + dc, SQRT2, dr * width, dc) for dr in (-1, 1) for dc in (-1, 1)]
        best_cost = {start_node: 0.0}
        parent = {start_node: start_node}
        heap = [(0.0, 0.0, start_node)]
        closed = set()
        while heap:
            _, negative_cost, node = heapq.heappop(heap)
            if node == goal_node:
                break
            if node in closed:
                continue
            closed.add(node)
            cost = -negative_cost
            for offset, step, side_a, side_b in moves:
                neighbour = node + offset
                if not free[neighbour] or (side_a and not (free[node + side_a] and free[node + side_b])):
                    continue
                new_cost = cost + step
                if new_cost < best_cost.get(neighbour, math.inf):
                    best_cost[neighbour] = new_cost
                    parent[neighbour] = node
                    row, col = divmod(neighbour, width)
                    d_row, d_col = abs(row - goal_row), abs(col - goal_col)
                    octile = d_row + d_col + (SQRT2 - 2.0) * min(d_row, d_col)
                    # Ties on f go to the larger cost so far, i.e. the node nearer the goal.
                    heapq.heappush(heap, (new_cost + octile, -new_cost, neighbour))
        else:
            return None
        path = [goal_node]
        while path[-1] != start_node:
            path.append(parent[path[-1]])
        rows, cols = np.divmod(np.array(path[::-1]), width)
        return np.column_stack((rows - 1, cols - 1))

    def shortcut(self, pixel_path: np.ndarray) -> np.ndarray:
        """Simplify a pixel path to few waypoints with line-of-sight shortcuts.

        First keep only the pixels where the step direction changes, then, from each kept
        waypoint, jump to the farthest following one that is in straight line of sight.
        """
        if len(pixel_path) <= 2:
            return pixel_path
        steps = np.diff(pixel_path, axis=0)
        turns = np.any(steps[1:] != steps[:-1], axis=1)
        corners = pixel_path[np.concatenate(([True], turns, [True]))]
        kept = [0]
        while kept[-1] < len(corners) - 1:
            anchor = kept[-1]
            farthest = anchor + 1
            while farthest + 1 < len(corners) and segment_is_free(
                self.free, corners[anchor], corners[farthest + 1]
            ):
                farthest += 1
            kept.append(farthest)
        return corners[kept]

    def transit(self, start: Sequence[int], goal: Sequence[int]) -> np.ndarray:
        """Few-waypoint collision-free path between two free pixels (A* then shortcuts)."""
        pixel_path = self.astar(start, goal)
        if pixel_path is None:
            raise ValueError(f"no free path from pixel {tuple(start)} to pixel {tuple(goal)}")
        return self.shortcut(pixel_path)

    def pairwise_distances(self, pixels: np.ndarray) -> np.ndarray:
        """Geodesic distances (pixels) between free pixels, searched up to the routing radius.

        Pairs beyond the radius get (radius + straight-line distance): larger than every exact
        distance, and still ordered by how far apart the pixels are.
        """
        pixels = np.asarray(pixels, dtype=int)
        nodes = self.node_id[pixels[:, 0], pixels[:, 1]]
        unique_nodes, inverse = np.unique(nodes, return_inverse=True)
        radius = self.search_radius_px
        # A few sources at a time: Dijkstra returns a dense row over the whole raster per source.
        rows_per_batch = max(1, 2**22 // self.graph.shape[0])
        distances = np.vstack(
            [
                dijkstra(self.graph, directed=False, indices=batch, limit=radius)[:, unique_nodes]
                for batch in np.array_split(unique_nodes, math.ceil(len(unique_nodes) / rows_per_batch))
            ]
        )
        distances = distances[np.ix_(inverse, inverse)]
        return np.where(np.isfinite(distances), distances, radius + cdist(pixels, pixels))


def astar(centre_free: np.ndarray, start: Sequence[int], goal: Sequence[int]) -> np.ndarray | None:
    """Shortest 8-connected path (no corner cutting, octile heuristic) between two pixels.

    Returns the (K, 2) array of (row, col) pixels from start to goal inclusive, or None when the
    goal cannot be reached. Use ``FreeSpace(centre_free).transit`` for the simplified path.
    """
    return FreeSpace(centre_free).astar(start, goal)


# --------------------------------------------------------------------------------------------
# 1. Decomposition
# --------------------------------------------------------------------------------------------


@dataclass
class Cell:
    """One boustrophedon cell: a run of consecutive slice lines, one free interval on each.

    ``sweep_axis`` is the raster axis along which the slice advances: 0 means the slice lines are
    rows (line index = row, position along the line = column); 1 means they are columns (line
    index = column, position = row). ``intervals[k] = (lo, hi)`` is the inclusive range of free
    positions on line ``first_line + k``.
    """

    sweep_axis: int
    first_line: int
    intervals: np.ndarray = field(repr=False)

    @property
    def last_line(self) -> int:
        return self.first_line + len(self.intervals) - 1

    def interval(self, line: int) -> tuple[int, int]:
        lo, hi = self.intervals[line - self.first_line]
        return int(lo), int(hi)

    def to_pixels(self, line_positions: np.ndarray) -> np.ndarray:
        """Convert (line, position) points of this cell to raster (row, col) points."""
        line_positions = np.asarray(line_positions)
        return line_positions if self.sweep_axis == 0 else line_positions[:, ::-1]

    def contains(self, row: int, col: int) -> bool:
        """True if raster pixel (row, col) belongs to this cell."""
        line, position = (row, col) if self.sweep_axis == 0 else (col, row)
        if not self.first_line <= line <= self.last_line:
            return False
        lo, hi = self.interval(line)
        return lo <= position <= hi

    @property
    def area_px(self) -> int:
        return int((self.intervals[:, 1] - self.intervals[:, 0] + 1).sum())


def line_view(centre_free: np.ndarray, sweep_axis: int) -> np.ndarray:
    """The raster seen with the slice lines as rows (a transposed view for sweep axis 1)."""
    if sweep_axis not in (0, 1):
        raise ValueError(f"sweep_axis must be 0 or 1, got {sweep_axis}")
    return centre_free if sweep_axis == 0 else centre_free.T


def free_intervals(lines: np.ndarray) -> list[np.ndarray]:
    """For each row of a boolean raster, its maximal free runs as an (n, 2) array of (lo, hi)."""
    padded = np.zeros((lines.shape[0], lines.shape[1] + 2), dtype=np.int8)
    padded[:, 1:-1] = lines
    change = np.diff(padded, axis=1)
    start_lines, starts = np.nonzero(change == 1)
    _, ends = np.nonzero(change == -1)  # one past the last free pixel of each run
    runs = np.column_stack((starts, ends - 1))
    bounds = np.searchsorted(start_lines, np.arange(lines.shape[0] + 1))
    return [runs[bounds[k] : bounds[k + 1]] for k in range(lines.shape[0])]


def decompose(centre_free: np.ndarray, sweep_axis: int, max_jump: int | None = None) -> list[Cell]:
    """Boustrophedon cellular decomposition of the free pixels.

    Intervals of consecutive lines are connected when they share a position (4-connectivity,
    the connectivity a robot centre needs to move between them). An interval continues the cell
    of the previous line's interval only if the two overlap each other and nothing else, and,
    when ``max_jump`` is given, neither end moves by more than ``max_jump`` pixels. Every other
    interval opens a new cell. Cells are returned in the order they are opened.
    """
    lines = line_view(np.asarray(centre_free, dtype=bool), sweep_axis)
    cells_first_line: list[int] = []
    cells_intervals: list[list[np.ndarray]] = []
    previous = np.zeros((0, 2), dtype=int)
    previous_cells = np.zeros(0, dtype=int)
    for line, current in enumerate(free_intervals(lines)):
        # Intervals are sorted and disjoint, so the overlapping ones form a contiguous range.
        first_over = np.searchsorted(previous[:, 1], current[:, 0], side="left")
        last_over = np.searchsorted(previous[:, 0], current[:, 1], side="right") - 1
        previous_overlap_count = np.zeros(len(previous), dtype=int)
        for first, last in zip(first_over, last_over):
            previous_overlap_count[first : last + 1] += 1
        current_cells = np.empty(len(current), dtype=int)
        for k, (first, last) in enumerate(zip(first_over, last_over)):
            continues = first == last and previous_overlap_count[first] == 1
            if continues and max_jump is not None:
                continues = bool(np.abs(current[k] - previous[first]).max() <= max_jump)
            if continues:
                current_cells[k] = previous_cells[first]
                cells_intervals[current_cells[k]].append(current[k])
            else:
                current_cells[k] = len(cells_first_line)
                cells_first_line.append(line)
                cells_intervals.append([current[k]])
        previous, previous_cells = current, current_cells
    return [
        Cell(sweep_axis=sweep_axis, first_line=first_line, intervals=np.array(intervals, dtype=int))
        for first_line, intervals in zip(cells_first_line, cells_intervals)
    ]


def transpose_cell(cell: Cell, max_jump: int | None = None) -> Cell | None:
    """The cell's pixels as one cell of the other sweep axis, or None when they do not form one.

    The pixels are decomposed along the other axis with the same ``max_jump``. They form a single
    cell there when every line of the other axis crosses them in one interval and no interval end
    jumps by more than ``max_jump``: the condition under which lanes across the original lines
    sweep the cell as completely as lanes along them.
    """
    lo, hi = cell.intervals[:, 0], cell.intervals[:, 1]
    offset = int(lo.min())
    positions = np.arange(offset, int(hi.max()) + 1)
    local = (positions >= lo[:, None]) & (positions <= hi[:, None])  # [line, position]
    parts = decompose(local.T, sweep_axis=0, max_jump=max_jump)
    if len(parts) != 1:
        return None
    return Cell(1 - cell.sweep_axis, offset + parts[0].first_line, parts[0].intervals + cell.first_line)


# --------------------------------------------------------------------------------------------
# 2. Swaths
# --------------------------------------------------------------------------------------------


def max_lane_spacing_px(tool_width: float, resolution: float) -> int:
    """Largest whole number of pixels not exceeding the tool width (at least one)."""
    return max(1, int(math.floor(tool_width / resolution + 1e-9)))


def is_narrow(cell: Cell, tool_width: float, resolution: float) -> bool:
    """A cell at most one tool width across and longer than it is wide: swept along its edges."""
    widths = cell.intervals[:, 1] - cell.intervals[:, 0]
    length = cell.last_line - cell.first_line
    return bool(widths.max() <= max_lane_spacing_px(tool_width, resolution) and length > widths.max())


def faces_obstacle(cell: Cell, lines: np.ndarray, end: int) -> bool:
    """True if the cell's first (end 0) or last (end 1) line borders blocked pixels beyond it.

    Such an end line needs a lane of its own: the strip of floor beyond it (an obstacle's face
    or a wall) can only be reached from there. An end that only borders free pixels of the
    neighbouring cells needs no lane, the lanes on both sides of the boundary reach across it.
    """
    line = cell.last_line if end else cell.first_line
    beyond = line + 1 if end else line - 1
    if not 0 <= beyond < lines.shape[0]:
        return True
    lo, hi = cell.interval(line)
    return not lines[beyond, lo : hi + 1].all()


def faces_obstacle_only(cell: Cell, lines: np.ndarray) -> bool:
    """True if the cell is a dead end: its first or last line has no free pixel beyond it."""
    for line, beyond in ((cell.first_line, cell.first_line - 1), (cell.last_line, cell.last_line + 1)):
        lo, hi = cell.interval(line)
        if not 0 <= beyond < lines.shape[0] or not lines[beyond, lo : hi + 1].any():
            return True
    return False


def lane_lines(cell: Cell, lines: np.ndarray, tool_width: float, resolution: float) -> np.ndarray:
    """Lines of the lanes of an ordinary cell, at most one tool width apart.

    An end line that faces an obstacle gets a lane; an end shared with free neighbouring cells
    is left to within half a tool width, so that lanes on either side of a cell boundary are
    never more than one tool width apart and cells do not double their boundary lanes. Between
    the two outermost lanes, n = ceil(extent / spacing) gaps spread the lanes evenly; the spacing
    is a whole number of pixels so rounding cannot push two lanes more than a tool width apart.
    """
    spacing = max_lane_spacing_px(tool_width, resolution)
    inset = (spacing - 1) // 2
    first, last = cell.first_line, cell.last_line
    first_faces, last_faces = faces_obstacle(cell, lines, 0), faces_obstacle(cell, lines, 1)
    low = first if first_faces else min(first + inset, last)
    high = last if last_faces else max(last - inset, first)
    if low > high:  # thinner than two insets: a single lane, on the facing end if there is one
        lane = first if first_faces else last if last_faces else round((first + last) / 2)
        return np.array([lane])
    gaps = math.ceil((high - low) / spacing)
    return np.unique(np.round(np.linspace(low, high, gaps + 1)).astype(int))


def swaths(cell: Cell, centre_free: np.ndarray, tool_width: float, resolution: float) -> list[np.ndarray]:
    """The sweep lines of a cell as (line, position) polylines, ordered across the cell.

    Ordinary cell: one straight lane per line from ``lane_lines``, from lo to hi of that line's
    interval. Narrow cell: its lo edge and its hi edge, each a staircase from the first line to
    the last (one edge only when the cell is a single pixel wide everywhere).
    """
    if is_narrow(cell, tool_width, resolution):
        edges = [boundary_walk(cell, side=0, from_line=cell.first_line, to_line=cell.last_line)]
        if np.any(cell.intervals[:, 1] > cell.intervals[:, 0]):
            edges.append(boundary_walk(cell, side=1, from_line=cell.first_line, to_line=cell.last_line))
        return edges
    lanes = []
    for line in lane_lines(cell, line_view(centre_free, cell.sweep_axis), tool_width, resolution):
        lo, hi = cell.interval(line)
        lanes.append(np.array([[line, lo], [line, hi]]))
    return lanes


def boundary_walk(cell: Cell, side: int, from_line: int, to_line: int) -> np.ndarray:
    """Staircase of free (line, position) points along one edge of a cell (side 0: lo, 1: hi).

    Between two lines the step is taken at the inner of the two edge positions, which lies on
    both intervals, so every segment of the staircase stays on free pixels.
    """
    step = 1 if to_line >= from_line else -1
    lines = np.arange(from_line, to_line + step, step)
    edge = cell.intervals[lines - cell.first_line, side]
    inner = np.maximum(edge[:-1], edge[1:]) if side == 0 else np.minimum(edge[:-1], edge[1:])
    points = [[lines[0], edge[0]]]
    for k in range(len(lines) - 1):
        points += [[lines[k], inner[k]], [lines[k + 1], inner[k]]]
    points.append([lines[-1], edge[-1]])
    return drop_redundant_points(np.array(points))


def corridor_zigzag(cell: Cell, lines: np.ndarray) -> np.ndarray | None:
    """One pass that covers both edges of a corridor two pixels wide, or None for other cells.

    The pass touches the two edges on alternate lines, so every pixel beyond either edge is at
    most one line from a point where the robot centre is on that edge: about 1.4 times the
    corridor length instead of the 2 of a pass along each edge. Only for corridors open at both
    ends (between two other cells): a dead end is driven in and out anyway, and its two edge
    passes are that in and out.
    """
    widths = cell.intervals[:, 1] - cell.intervals[:, 0]
    if len(widths) < 3 or np.median(widths) > 1 or faces_obstacle_only(cell, lines):
        return None
    points = np.array(
        [
            [line, cell.interval(line)[k % 2]]
            for k, line in enumerate(range(cell.first_line, cell.last_line + 1))
        ]
    )
    if not all(segment_is_free(lines, a, b) for a, b in zip(points[:-1], points[1:])):
        return None
    return points


def attachment_points(cell: Cell, lines: np.ndarray) -> np.ndarray:
    """Positions where neighbouring cells attach to the cell across its first or last line.

    One point per free run of the line beyond that touches the cell: the middle of the overlap.
    A corridor swept by one or two lanes is cut at these points, so that the route may sweep a
    stretch of it on the way to a side pocket and the next stretch after the pocket.
    """
    points = []
    for line, beyond in ((cell.first_line, cell.first_line - 1), (cell.last_line, cell.last_line + 1)):
        if not 0 <= beyond < lines.shape[0]:
            continue
        lo, hi = cell.interval(line)
        for run_lo, run_hi in free_intervals(lines[beyond : beyond + 1])[0]:
            if run_hi >= lo and run_lo <= hi:
                points.append((max(int(run_lo), lo) + min(int(run_hi), hi)) // 2)
    return np.unique(np.array(points, dtype=int))


def cut_lane(lane: np.ndarray, cuts: np.ndarray) -> list[np.ndarray]:
    """A straight (line, position) lane cut into consecutive pieces at the given positions."""
    line, lo, hi = int(lane[0, 0]), int(lane[:, 1].min()), int(lane[:, 1].max())
    stops = np.concatenate(([lo], cuts[(cuts > lo) & (cuts < hi)], [hi]))
    if len(stops) == 2 and lo == hi:
        return [np.array([[line, lo]])]
    return [np.array([[line, a], [line, b]]) for a, b in zip(stops[:-1], stops[1:])]


def lane_blocks(cell: Cell, lanes: list[np.ndarray], centre_free: np.ndarray) -> list[list[np.ndarray]]:
    """The lanes of a cell in blocks, cut where neighbouring cells attach to the lanes' ends.

    With lanes across the slice lines, the neighbours of the cell touch the ends of some lanes
    (a corridor branching off the side). Each run of such lanes cuts the block at its middle, so
    that the route can sweep the lanes on either side of the branch at different times, e.g.
    half a zone on the way out, the other half on the way back.
    """
    lines = line_view(centre_free, cell.sweep_axis)
    line_numbers = np.arange(cell.first_line, cell.last_line + 1)
    lo, hi = cell.intervals[:, 0], cell.intervals[:, 1]
    before = (lo > 0) & lines[line_numbers, np.maximum(lo - 1, 0)]
    beyond = (hi < lines.shape[1] - 1) & lines[line_numbers, np.minimum(hi + 1, lines.shape[1] - 1)]
    attached = np.concatenate(([False], before | beyond, [False])).astype(np.int8)
    starts = np.flatnonzero(np.diff(attached) == 1)
    stops = np.flatnonzero(np.diff(attached) == -1) - 1
    cuts = cell.first_line + (starts + stops) // 2
    lane_lines_ = np.array([int(lane[0, 0]) for lane in lanes])
    blocks, first = [], 0
    for cut in cuts:
        split = int(np.searchsorted(lane_lines_, cut, side="right"))
        if first < split < len(lanes):
            blocks.append(lanes[first:split])
            first = split
    blocks.append(lanes[first:])
    return blocks


# --------------------------------------------------------------------------------------------
# 3. Route units: how each cell is swept
# --------------------------------------------------------------------------------------------


@dataclass
class Sweep:
    """One unit of the route: a part of a cell swept in one go.

    ``variants`` are the ways to drive it, raster (row, col) polylines; variant k ^ 1 is variant k
    reversed; ``cell`` is the index of the cell it belongs to.
    """

    cell: int
    variants: list[np.ndarray]


@dataclass(frozen=True)
class SweepOptions:
    """Choices of the pipeline that can be changed, for comparisons and ablations."""

    # The lane direction of the cells that may be swept either way: "route" offers both
    # directions to the route, "fewest_lanes" takes lanes along the cell's longer extent,
    # "slice" keeps the lanes along the slice lines (one global direction per plan).
    lane_direction: str = "route"
    lane_blocks: bool = True  # zones cut into blocks of lanes where corridors branch off
    corridor_zigzags: bool = True  # one zigzag pass through corridors two pixels wide


def cell_units(
    cell: Cell,
    index: int,
    centre_free: np.ndarray,
    tool_width: float,
    resolution: float,
    max_jump: int | None = None,
    options: SweepOptions = SweepOptions(),
) -> list[Sweep]:
    """The route units of one cell, with the lane direction chosen per cell.

    - A narrow cell: one unit per edge pass, so that the way into a pocket and the way out are
      routed like any other pass; a corridor two pixels wide between two cells instead gets one
      zigzag unit (``corridor_zigzag``).
    - A cell that one or two lanes sweep (in whichever direction needs the fewer): one unit per
      lane piece, the lanes cut where neighbouring cells attach (``attachment_points``), so that
      a corridor is swept piecewise on the way to and back from what branches off it.
    - Any other cell: boustrophedon units whose variants include, when the cell is also one cell
      of the other axis (``transpose_cell``), the sweeps with lanes across the slice lines, so
      that the route picks the lane direction of each cell along with the order. Where
      corridors branch off the side of the lanes, the lanes are cut into blocks
      (``lane_blocks``), each a unit, in the direction whose sweep is the shorter.
    """
    lines = line_view(centre_free, cell.sweep_axis)
    if is_narrow(cell, tool_width, resolution):
        edges = swaths(cell, centre_free, tool_width, resolution)
        zigzag = corridor_zigzag(cell, lines) if options.corridor_zigzags and len(edges) == 2 else None
        if zigzag is not None:
            return [Sweep(index, _both_ways(cell, zigzag))]
        return [Sweep(index, _both_ways(cell, edge, lines)) for edge in edges]
    if options.lane_direction not in ("route", "fewest_lanes", "slice"):
        raise ValueError(f"unknown lane_direction {options.lane_direction!r}")
    orientations = [cell]
    across = transpose_cell(cell, max_jump) if options.lane_direction != "slice" else None
    if across is not None and not is_narrow(across, tool_width, resolution):
        orientations.append(across)
    directions = [(option, swaths(option, centre_free, tool_width, resolution)) for option in orientations]
    option, lanes = min(directions, key=lambda direction: len(direction[1]))
    if options.lane_direction == "fewest_lanes":
        directions = [(option, lanes)]
    if len(lanes) <= 2:
        option_view = line_view(centre_free, option.sweep_axis)
        cuts = attachment_points(option, option_view)
        pieces = [piece for lane in lanes for piece in cut_lane(lane, cuts)]
        return [Sweep(index, _both_ways(option, piece, option_view)) for piece in pieces]
    directions = [(option, lanes) for option, lanes in directions if len(lanes) > 2]
    blocks = [
        lane_blocks(option, lanes, centre_free) if options.lane_blocks else [lanes]
        for option, lanes in directions
    ]
    if all(len(direction_blocks) == 1 for direction_blocks in blocks):
        variants = [
            variant for option, lanes in directions for variant in cell_sweeps(option, lanes, centre_free)
        ]
        return [Sweep(index, variants)]
    lengths = [polyline_length(cell_sweeps(option, lanes, centre_free)[0]) for option, lanes in directions]
    best = int(np.argmin(lengths))
    return [Sweep(index, cell_sweeps(directions[best][0], block, centre_free)) for block in blocks[best]]


def cell_sweeps(cell: Cell, lanes: list[np.ndarray], centre_free: np.ndarray) -> list[np.ndarray]:
    """Four ways to sweep lanes of a cell, as raster (row, col) polylines; variant k ^ 1 is k
    reversed.

    The lanes in order, alternating direction, starting at the lo (variant 0) or hi (variant 2)
    end of the first lane; each connector follows the cell edge on the side where the previous
    lane ended, so that it covers the edge strip between the two lanes.
    """
    lines = line_view(centre_free, cell.sweep_axis)
    sweeps = []
    for start_side in (0, 1):
        path = drop_redundant_points(np.vstack(_lanes_boustrophedon(cell, lanes, start_side)))
        pixels = cell.to_pixels(_simplify_boundary_runs(path, lines))
        sweeps += [pixels, pixels[::-1]]
    return sweeps


def _lanes_boustrophedon(cell: Cell, lanes: list[np.ndarray], start_side: int) -> list[np.ndarray]:
    """Lanes joined back and forth, connectors along the cell edge (side 0: lo, 1: hi)."""
    pieces = []
    side = start_side
    for k, lane in enumerate(lanes):
        line = int(lane[0, 0])
        if k > 0:
            previous_line = int(lanes[k - 1][0, 0])
            pieces.append(boundary_walk(cell, side, previous_line, line))
        pieces.append(lane if side == 0 else lane[::-1])
        side = 1 - side
    return pieces


def _both_ways(cell: Cell, path: np.ndarray, lines: np.ndarray | None = None) -> list[np.ndarray]:
    """A single pass (line, position polyline) as the two variants of a unit: forward, backward.

    With ``lines``, the staircases of the pass are simplified (``_simplify_boundary_runs``).
    """
    path = drop_redundant_points(path)
    if lines is not None:
        path = _simplify_boundary_runs(path, lines)
    pixels = cell.to_pixels(path)
    return [pixels, pixels[::-1]]


def _simplify_boundary_runs(path: np.ndarray, lines: np.ndarray) -> np.ndarray:
    """Simplify a sweep polyline without moving its lanes.

    Only staircase stretches (runs of short segments, as produced by ``boundary_walk`` on sloped
    edges) are simplified; straight lanes and long connectors are kept exactly, since the outer
    lanes must stay on the outermost centre positions to reach the edge strip.
    """
    segment_lengths = np.abs(np.diff(path, axis=0)).max(axis=1)
    short = segment_lengths <= 1
    result = [path[:1]]
    k = 0
    while k < len(short):
        if not short[k]:
            result.append(path[k + 1 : k + 2])
            k += 1
            continue
        end = k
        while end < len(short) and short[end]:
            end += 1
        result.append(simplify(path[k : end + 1], lines, BOUNDARY_SIMPLIFY_TOLERANCE_PX)[1:])
        k = end
    return np.vstack(result)


def drop_redundant_points(points: np.ndarray) -> np.ndarray:
    """Remove repeated points and the middle points of straight runs from a polyline."""
    points = points[np.concatenate(([True], np.any(np.diff(points, axis=0) != 0, axis=1)))]
    if len(points) <= 2:
        return points
    incoming = points[1:-1] - points[:-2]
    outgoing = points[2:] - points[1:-1]
    cross = incoming[:, 0] * outgoing[:, 1] - incoming[:, 1] * outgoing[:, 0]
    forward = (incoming * outgoing).sum(axis=1) > 0
    keep = np.concatenate(([True], ~((cross == 0) & forward), [True]))
    return points[keep]


def simplify(points: np.ndarray, free: np.ndarray, tolerance: float) -> np.ndarray:
    """Douglas-Peucker simplification that only accepts chords lying on free pixels."""
    keep = np.zeros(len(points), dtype=bool)
    keep[[0, -1]] = True
    stack = [(0, len(points) - 1)]
    while stack:
        first, last = stack.pop()
        if last - first < 2:
            continue
        start, end = points[first].astype(float), points[last].astype(float)
        chord = end - start
        chord_length = math.hypot(chord[0], chord[1])
        offsets = points[first + 1 : last] - start
        if chord_length > 0:
            deviation = np.abs(offsets[:, 0] * chord[1] - offsets[:, 1] * chord[0]) / chord_length
        else:
            deviation = np.hypot(offsets[:, 0], offsets[:, 1])
        if deviation.max() <= tolerance and segment_is_free(free, start, end):
            continue
        farthest = first + 1 + int(np.argmax(deviation))
        keep[farthest] = True
        stack += [(first, farthest), (farthest, last)]
    return points[keep]


# --------------------------------------------------------------------------------------------
# 4. Routing
# --------------------------------------------------------------------------------------------


def route(
    sweeps: list[list[np.ndarray]],
    start: Sequence[int],
    pairwise_distance: Callable[[np.ndarray], np.ndarray],
    last_units: set[int] | frozenset[int] = frozenset(),
) -> list[tuple[int, int]]:
    """Order the units and choose how to sweep each: a list of (unit index, variant index).

    ``sweeps[i]`` lists the variants of unit i (polylines in pixels; variant k ^ 1 must be
    variant k reversed). ``pairwise_distance(points)`` returns the transit cost matrix between
    pixel points. Units in ``last_units`` come after all the others.

    The objective is transits plus in-unit lengths. Greedy nearest neighbour builds a first
    route; then 2-opt (reversing a stretch of the route reverses each of its units, which is
    still a valid sweep, so the move is exact), Or-opt (moving short stretches) and a dynamic
    programme that picks the best variant of every unit for the fixed order alternate until none
    improves.
    """
    entries = np.array([[variant[0] for variant in unit] for unit in sweeps])  # (units, variants, 2)
    unit_count, variant_count = entries.shape[:2]
    if unit_count == 0:
        return []
    in_unit_length = np.array([[polyline_length(variant) for variant in unit] for unit in sweeps])
    # Exits are the entries of the reversed variants, so one set of points serves for both.
    points = np.vstack((np.asarray(start)[None, :], entries.reshape(-1, 2)))
    distances = pairwise_distance(points)
    start_to = distances[0, 1:].reshape(unit_count, variant_count)
    between = distances[1:, 1:].reshape(unit_count, variant_count, unit_count, variant_count)
    # transit[a, v, b, w]: from the exit of unit a swept by variant v to the entry of b by w.
    transit = between[:, np.arange(variant_count) ^ 1]
    costs = RouteCosts(start_to, transit, in_unit_length)

    groups = [
        [index for index in range(unit_count) if index not in last_units],
        sorted(set(last_units) & set(range(unit_count))),
    ]
    tour = _greedy(groups, costs)
    group_end = len(groups[0])
    cost = costs.tour(tour)
    while True:
        tour = _two_opt(tour, group_end, costs)
        tour = _or_opt(tour, group_end, costs)
        tour = _best_variants([cell for cell, _ in tour], costs)
        new_cost = costs.tour(tour)
        if new_cost >= cost - 1e-9:
            return tour
        cost = new_cost


@dataclass
class RouteCosts:
    """The cost tables of a route (see ``route``); steps are (unit, variant) tuples."""

    start_to: np.ndarray  # [unit, variant]: from the start to the entry
    transit: np.ndarray  # [unit, variant, unit, variant]: from an exit to an entry
    in_unit: np.ndarray  # [unit, variant]: the sweep itself

    def link(self, a: tuple[int, int] | None, b: tuple[int, int] | None) -> float:
        """Transit from step a (None: the start) to step b (None: the end of the route, free)."""
        if b is None:
            return 0.0
        return self.start_to[b] if a is None else self.transit[a + b]

    def tour(self, tour: list[tuple[int, int]]) -> float:
        steps = [None, *tour, None]
        transits = sum(self.link(a, b) for a, b in zip(steps[:-1], steps[1:]))
        return float(sum(self.in_unit[step] for step in tour) + transits)


def _greedy(groups, costs: RouteCosts) -> list[tuple[int, int]]:
    """Nearest neighbour: repeatedly sweep the unswept cell whose entry is the closest."""
    tour: list[tuple[int, int]] = []
    for group in groups:
        remaining = list(group)
        while remaining:
            options = costs.start_to[remaining] if not tour else costs.transit[tour[-1]][remaining]
            # Equal transits (adjacent units) are decided by the cheaper way through the unit.
            options = options + 1e-6 * costs.in_unit[remaining]
            flat = int(np.argmin(options))
            row, variant = divmod(flat, options.shape[1])
            tour.append((remaining.pop(row), variant))
    return tour


def _two_opt(tour, group_end, costs: RouteCosts) -> list[tuple[int, int]]:
    """2-opt on the open route with a fixed start; stretches never cross the group boundary."""
    tour = list(tour)

    improved = True
    while improved:
        improved = False
        for group_start, group_stop in ((0, group_end), (group_end, len(tour))):
            for i in range(group_start, group_stop):
                for j in range(i, group_stop):
                    first, last = tour[i], tour[j]
                    reversed_first = (first[0], first[1] ^ 1)
                    reversed_last = (last[0], last[1] ^ 1)
                    before = tour[i - 1] if i > 0 else None
                    after = tour[j + 1] if j + 1 < len(tour) else None
                    old = costs.link(before, first) + costs.link(last, after)
                    new = costs.link(before, reversed_last) + costs.link(reversed_first, after)
                    if new < old - 1e-9:
                        tour[i : j + 1] = [(cell, variant ^ 1) for cell, variant in reversed(tour[i : j + 1])]
                        improved = True
    return tour


def _or_opt(tour, group_end, costs: RouteCosts, max_segment: int = 3) -> list[tuple[int, int]]:
    """Or-opt: move stretches of up to ``max_segment`` units, either way round, to a better place.

    This is the move that nests routes: a side pocket left for later is fitted in between two
    pieces of the corridor it branches off. Stretches stay within their group.
    """
    tour = list(tour)
    improved = True
    while improved:
        improved = False
        for length in range(1, max_segment + 1):
            i = 0
            while i + length <= len(tour):
                in_first_group = i < group_end
                if in_first_group and i + length > group_end:
                    i += 1
                    continue
                move = _best_insertion(tour, i, length, group_end, in_first_group, costs)
                if move is not None:
                    gap, stretch = move
                    rest = tour[:i] + tour[i + length :]
                    tour = rest[:gap] + stretch + rest[gap:]
                    improved = True
                i += 1
    return tour


def _best_insertion(tour, i, length, group_end, in_first_group, costs: RouteCosts):
    """The best (gap, stretch) to move tour[i : i + length] to, or None if no move gains."""
    stretch = tour[i : i + length]
    rest = tour[:i] + tour[i + length :]
    before = tour[i - 1] if i > 0 else None
    after = tour[i + length] if i + length < len(tour) else None
    removal = costs.link(before, stretch[0]) + costs.link(stretch[-1], after) - costs.link(before, after)
    rest_end = group_end - length if in_first_group else group_end
    gaps = np.arange(0, rest_end + 1) if in_first_group else np.arange(rest_end, len(rest) + 1)
    # Gap g lies between rest[g - 1] (or the start) and rest[g] (or the end of the route).
    cells = np.array([cell for cell, _ in rest] + [0], dtype=int)
    variants = np.array([variant for _, variant in rest] + [0], dtype=int)
    has_previous, has_next = gaps > 0, gaps < len(rest)
    previous, following = np.maximum(gaps - 1, 0), gaps
    p_cell, p_variant = cells[previous], variants[previous]
    f_cell, f_variant = cells[following], variants[following]

    def links_into(cell, variant):  # from the unit before each gap (or the start) to (cell, variant)
        from_start = costs.start_to[cell, variant]
        return np.where(has_previous, costs.transit[p_cell, p_variant, cell, variant], from_start)

    def links_out_of(cell, variant):  # from (cell, variant) to the unit after each gap (if any)
        return np.where(has_next, costs.transit[cell, variant, f_cell, f_variant], 0.0)

    replaced = np.where(has_next, links_into(f_cell, f_variant), 0.0)
    best_gain, best = 1e-9, None
    for candidate in (stretch, [(cell, variant ^ 1) for cell, variant in reversed(stretch)]):
        gain = removal - (links_into(*candidate[0]) + links_out_of(*candidate[-1]) - replaced)
        k = int(np.argmax(gain))
        if gain[k] > best_gain:
            best_gain, best = gain[k], (int(gaps[k]), candidate)
    return best


def _best_variants(order, costs: RouteCosts) -> list[tuple[int, int]]:
    """For a fixed unit order, the cheapest variant of every unit (Viterbi over the variants)."""
    cost = costs.start_to[order[0]] + costs.in_unit[order[0]]
    choices = []
    for previous, cell in zip(order[:-1], order[1:]):
        candidates = cost[:, None] + costs.transit[previous, :, cell, :]
        choices.append(np.argmin(candidates, axis=0))
        cost = candidates.min(axis=0) + costs.in_unit[cell]
    variants = [int(np.argmin(cost))]
    for choice in reversed(choices):
        variants.append(int(choice[variants[-1]]))
    return list(zip(order, reversed(variants)))


# --------------------------------------------------------------------------------------------
# 5. Path: transits, and shortcuts that lose no coverage
# --------------------------------------------------------------------------------------------


def join(free_space: FreeSpace, start_pixel: tuple[int, int], sweeps: list[np.ndarray]) -> np.ndarray:
    """The sweeps in route order, joined by A* transits, as one (row, col) polyline."""
    pieces = [np.array([start_pixel])]
    position = start_pixel
    for sweep in sweeps:
        pieces += [free_space.transit(position, tuple(sweep[0])), sweep]
        position = tuple(sweep[-1])
    return drop_redundant_points(np.vstack(pieces))


def drop_idle_corners(
    path: np.ndarray,
    free: np.ndarray,
    radius_px: float,
    margin_px: float = 0.0,
    max_corners: int = 1,
    max_passes: int = 4,
) -> np.ndarray:
    """Shortcut the corners of a path wherever the shortcut loses no coverage.

    Up to ``max_corners`` consecutive inner waypoints are cut out when the straight segment that
    replaces them lies on free pixels and covers, within ``radius_px - margin_px``, every pixel
    that only the replaced segments covered. This removes the detours that cover nothing new:
    turns into cell corners that neighbouring passes already reach, staircases along edges that
    other lanes sweep, and the corners between transits and sweeps. The first and last waypoints
    stay.
    """
    points = [np.asarray(point, dtype=float) for point in path]
    if len(points) < 3:
        return path
    shape = free.shape
    footprints = [segment_footprint(a, b, radius_px, shape) for a, b in zip(points[:-1], points[1:])]
    counts = np.zeros(free.size, dtype=np.int32)
    for footprint in footprints:
        counts[footprint] += 1  # a segment's footprint has no repeated pixel

    def try_cut(first: int, count: int) -> bool:
        """Replace corners first .. first + count - 1 by one segment if that loses nothing."""
        before, after = points[first - 1], points[first + count]
        detour = polyline_length(np.array(points[first - 1 : first + count + 1]))
        if detour - np.hypot(*(after - before)) <= 1e-6 or not segment_is_free(free, before, after):
            return False
        replaced = footprints[first - 1 : first + count]
        pixels, times = np.unique(np.concatenate(replaced), return_counts=True)
        lost_rows, lost_cols = np.divmod(pixels[counts[pixels] == times], shape[1])
        distances = distance_to_segment(np.column_stack((lost_rows, lost_cols)), before, after)
        if np.any(distances > radius_px - margin_px + 1e-9):
            return False
        shortcut = segment_footprint(before, after, radius_px, shape)
        for footprint in replaced:
            counts[footprint] -= 1
        counts[shortcut] += 1
        footprints[first - 1 : first + count] = [shortcut]
        del points[first : first + count]
        return True

    for _ in range(max_passes):
        changed = False
        k = 1
        while k < len(points) - 1:
            if any(try_cut(k, count) for count in range(1, max_corners + 1) if k + count < len(points)):
                changed = True
                continue  # the new corner at k may go as well
            k += 1
        if not changed:
            break
    return np.array(points)


def distance_to_segment(points: np.ndarray, start: np.ndarray, end: np.ndarray) -> np.ndarray:
    """Distance from each (row, col) point to the segment start-end."""
    offsets = np.asarray(points, dtype=float) - start
    delta = end - start
    length2 = float(delta @ delta)
    t = np.zeros(len(offsets)) if length2 == 0 else np.clip(offsets @ delta / length2, 0.0, 1.0)
    return np.hypot(*(offsets - t[:, None] * delta).T)


def segment_footprint(
    start: np.ndarray, end: np.ndarray, radius_px: float, shape: tuple[int, int]
) -> np.ndarray:
    """Flat indices of the pixels whose centre lies within ``radius_px`` of the segment."""
    start, end = np.asarray(start, dtype=float), np.asarray(end, dtype=float)
    low = np.maximum(np.floor(np.minimum(start, end) - radius_px), 0).astype(int)
    high = np.minimum(np.ceil(np.maximum(start, end) + radius_px), np.array(shape) - 1).astype(int)
    rows = np.arange(low[0], high[0] + 1, dtype=float)[:, None] - start[0]
    cols = np.arange(low[1], high[1] + 1, dtype=float)[None, :] - start[1]
    delta = end - start
    length2 = float(delta @ delta)
    t = 0.0 if length2 == 0 else np.clip((rows * delta[0] + cols * delta[1]) / length2, 0.0, 1.0)
    inside = (rows - t * delta[0]) ** 2 + (cols - t * delta[1]) ** 2 <= radius_px**2 + 1e-9
    hit_rows, hit_cols = np.nonzero(inside)
    return (hit_rows + low[0]) * shape[1] + hit_cols + low[1]


def path_coverage(pixel_path: np.ndarray, coverable: np.ndarray, radius_px: float) -> float:
    """Fraction of the ``coverable`` pixels within ``radius_px`` of a (row, col) polyline."""
    covered = np.zeros(coverable.size, dtype=bool)
    points = np.asarray(pixel_path, dtype=float)
    for a, b in zip(points[:-1], points[1:]) if len(points) > 1 else [(points[0], points[0])]:
        covered[segment_footprint(a, b, radius_px, coverable.shape)] = True
    return float((covered & coverable.ravel()).sum() / max(int(coverable.sum()), 1))


# --------------------------------------------------------------------------------------------
# 6. The whole plan
# --------------------------------------------------------------------------------------------


@dataclass
class Plan:
    """A coverage plan: ``waypoints`` (N, 2) in metres, starting at the start point.

    ``length`` is in metres, ``duration`` the estimated driving time in seconds (see
    ``driving_time``), ``cell_order`` the indices of ``cells`` in the order they are first
    swept, ``coverage`` the fraction of the coverable area (what some reachable robot position
    covers) that the planned path covers.
    """

    waypoints: np.ndarray
    cells: list[Cell]
    sweep_axis: int
    length: float
    duration: float
    cell_order: list[int]
    coverage: float


def plan_coverage(
    centre_free: np.ndarray,
    resolution: float,
    origin: Sequence[float],
    tool_width: float = 0.35,
    start: Sequence[float] = (0.0, 0.0),
    last_cells: Callable[[Cell], bool] | None = None,
    sweep_axis: int | None = None,
    max_speed: float = 0.5,
    max_turn_rate: float = 2.0,
    min_coverage: float = MIN_PLAN_COVERAGE,
    options: SweepOptions = SweepOptions(),
) -> Plan:
    """Plan a path whose tool disc covers all the area reachable from ``start``.

    ``last_cells`` is a predicate on cells; the cells it selects are swept after all the others
    (e.g. the cells holding goal markers: ``lambda cell: cell.contains(*world_to_pixel(marker,
    resolution, origin))``).

    ``sweep_axis`` None tries both decomposition axes. Of the candidate plans the shortest one
    that covers at least ``min_coverage`` of the coverable area is kept, or the one covering the
    most if none does. The shortest sweeps are not always the most complete: the round ends of
    short lanes leave scallops along walls, and blocks of lanes leave the wall strip at each cut
    to them. So when no plan covers enough, plans without blocks, then with lanes along each
    cell's longer extent, are tried too. ``max_speed`` (m/s) and ``max_turn_rate`` (rad/s) only
    serve the ``duration`` estimate.
    The plan is restricted to the pixels 4-connected to the start (snapped to the nearest free
    pixel when it is not on one).
    """
    centre_free = np.asarray(centre_free, dtype=bool)
    if not centre_free.any():
        raise ValueError("centre_free has no free pixel")
    start_pixel = _nearest_free_pixel(centre_free, world_to_pixel(start, resolution, origin))
    labels, _ = ndimage.label(centre_free)
    reachable = labels == labels[start_pixel]
    free_space = FreeSpace(reachable, search_radius_px=ROUTING_SEARCH_RADIUS_M / resolution)
    radius_px = tool_width / 2 / resolution
    coverable = ndimage.distance_transform_edt(~reachable) <= radius_px + 1e-9
    axes = (0, 1) if sweep_axis is None else (sweep_axis,)
    # Fallbacks when no plan covers enough: no blocks, then lanes along each cell's longer extent
    # (fewer lane ends, so fewer of the scallops that round lane ends leave along walls).
    no_blocks = replace(options, lane_blocks=False)
    attempts = list(dict.fromkeys([options, no_blocks, replace(no_blocks, lane_direction="fewest_lanes")]))
    plans = []
    for attempt in attempts:
        for axis in axes:
            cells, cell_order, pixel_path = _plan_for_axis(
                free_space, axis, resolution, tool_width, start_pixel, last_cells, attempt
            )
            waypoints = np.vstack(
                (np.asarray(start, dtype=float)[None, :], pixels_to_world(pixel_path, resolution, origin))
            )
            # The start point may itself be the centre of its pixel.
            waypoints = waypoints[np.concatenate(([True], np.any(np.diff(waypoints, axis=0) != 0, axis=1)))]
            length = polyline_length(waypoints)
            duration = driving_time(waypoints, max_speed, max_turn_rate)
            coverage = path_coverage(pixel_path, coverable, radius_px)
            plans.append(Plan(waypoints, cells, axis, length, duration, cell_order, coverage))
        if any(plan.coverage >= min_coverage for plan in plans):
            break
    enough = [plan for plan in plans if plan.coverage >= min_coverage]
    if enough:
        return min(enough, key=lambda plan: plan.length)
    return max(plans, key=lambda plan: plan.coverage)


def _plan_for_axis(free_space, sweep_axis, resolution, tool_width, start_pixel, last_cells, options):
    """Decompose, sweep, route and join for one axis: the cells, the cell order, the pixel path."""
    max_jump = max_lane_spacing_px(tool_width, resolution) // 2
    cells = decompose(free_space.free, sweep_axis, max_jump=max_jump)
    units = [
        unit
        for index, cell in enumerate(cells)
        for unit in cell_units(cell, index, free_space.free, tool_width, resolution, max_jump, options)
    ]
    variant_count = max(len(unit.variants) for unit in units)
    # Pairs (k, k ^ 1) repeat, so padding every unit to the same variant count keeps the pairing.
    variants = [[unit.variants[k % len(unit.variants)] for k in range(variant_count)] for unit in units]
    chosen_last = {
        k for k, unit in enumerate(units) if last_cells is not None and last_cells(cells[unit.cell])
    }
    tour = route(variants, start_pixel, free_space.pairwise_distances, chosen_last)
    path = join(free_space, start_pixel, [variants[unit][variant] for unit, variant in tour])
    path = drop_idle_corners(
        path, free_space.free, tool_width / 2 / resolution, SHORTCUT_MARGIN_M / resolution
    )
    cell_order = list(dict.fromkeys(units[unit].cell for unit, _ in tour))
    return cells, cell_order, path


def _nearest_free_pixel(centre_free: np.ndarray, pixel: tuple[int, int]) -> tuple[int, int]:
    """The pixel itself if free (clamped into the raster), else the nearest free pixel."""
    row = min(max(pixel[0], 0), centre_free.shape[0] - 1)
    col = min(max(pixel[1], 0), centre_free.shape[1] - 1)
    if centre_free[row, col]:
        return row, col
    _, (nearest_rows, nearest_cols) = ndimage.distance_transform_edt(~centre_free, return_indices=True)
    return int(nearest_rows[row, col]), int(nearest_cols[row, col])
