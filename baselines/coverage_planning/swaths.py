"""Stage 2, swaths: the sweep lines of one cell, as (line, position) polylines.

Input: a ``Cell``, the centre-free raster, the tool width and the raster resolution. Ordinary
cells get lanes evenly spaced at most one tool width apart (``lane_lines``); an end of the cell
that faces a wall or obstacle gets a lane on its outermost valid centre positions, an end shared
with free neighbouring cells is left to their lanes. Cells narrower than a tool width but long
get one pass along each of their two edges (``boundary_walk``), except that a corridor two pixels
wide between two cells gets one zigzag pass (``corridor_zigzag``). The points where other cells
attach (``attachment_points``, ``cut_lane``) and the blocks of lanes between corridors branching
off a zone's side (``lane_blocks``) let the next stage cut the swaths into route units.
"""

from __future__ import annotations

import math

import numpy as np
from cabinbench.baselines.coverage_planning.decomposition import Cell, free_intervals, line_view
from cabinbench.baselines.coverage_planning.free_space import segment_is_free

from cabinbench.geometry import drop_redundant_points


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
