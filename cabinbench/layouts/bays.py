"""``cells: auto``: a building map split into bays, the cells of the ``sequential`` protocol.

A cabin's cells are slabs across its aisle, one after another; a building's bays are slabs across
its corridor, cut where the floor is narrow: at the walls between rooms, which only the corridor
crosses. The protocol visits cells in a line, each next to the one before, so rooms as cells
would not do: the rooms off a corridor touch only the corridor, not one another.

Along each axis, the *opening* of a raster line (a column, to cut across x; a row, to cut across
y) is the length of it the robot centre can stand on, in the largest region where it fits. A cut
goes through the middle of a run of lines whose opening is at most ``NARROW_FRACTION`` of the
median line's, the narrowest first, where it leaves at least ``MIN_BAY_M`` to the ends of the
floor and to the other cuts; a cut that would leave a bay whose floor is not connected within it
(a room reached only from the next bay) is not made. The axis with more bays wins (x on a tie).
The bays run along it from the end where the robot starts: without a ``start``, the robot starts
in the first bay, as the occupancy kind chooses a start in a whole map.
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage

from cabinbench.layouts.fields import CONTACT_CLEARANCE, RESOLUTION, Cell, FieldChecker, RobotSpec
from cabinbench.layouts.kinds.occupancy import largest_region_start

AUTO = "auto"
NARROW_FRACTION = 0.5  # a wall between two rooms: only the corridor crosses it
MIN_BAY_M = 2.0  # about a small office's width: narrower bays would cut rooms, not separate them


def auto_cells(
    check: FieldChecker,
    clearance: np.ndarray,
    extent: tuple[float, float, float, float],
    robot: RobotSpec,
    start: tuple[float, float, float] | None,
) -> tuple[list[Cell], tuple[float, float, float]]:
    """The bays of a map (``clearance`` on the layout's raster, its origin at the extent's lower
    corner) in visiting order, and the start: ``start`` if given (it must lie in the first or the
    last bay), else one in the first bay."""
    standing = _largest_region(clearance >= robot.radius + CONTACT_CLEARANCE)
    splits = [(axis, _cuts(standing, axis)) for axis in (1, 0)]  # x first: it wins a tie
    axis, cuts = max(splits, key=lambda split: len(split[1]))
    xmin, ymin, xmax, ymax = extent
    low, high = (xmin, xmax) if axis == 1 else (ymin, ymax)
    edges = [low, *(low + cut * RESOLUTION for cut in cuts), high]
    rects = [(a, ymin, b, ymax) if axis == 1 else (xmin, a, xmax, b) for a, b in zip(edges[:-1], edges[1:])]
    if start is not None:
        where = start[0] if axis == 1 else start[1]
        bay = int(np.searchsorted(edges[1:-1], where, side="right"))
        if 0 < bay < len(rects) - 1:
            check.fail(
                "start",
                f"({start[0]}, {start[1]}) lies in bay {bay + 1} of the {len(rects)} that cells: auto "
                f"cuts, and the bays are visited in a line",
                "start in the first or the last bay (the ends of the building), or list the cells",
            )
        if bay == len(rects) - 1:
            rects.reverse()
    else:
        first = np.zeros_like(standing)
        first[_bay_slice(rects[0], extent, axis, standing.shape)] = True
        start = largest_region_start(np.where(first, clearance, 0.0), (xmin, ymin), robot)
    return [Cell(f"bay_{index}", rect, np.zeros((0, 2))) for index, rect in enumerate(rects)], start


def _largest_region(mask: np.ndarray) -> np.ndarray:
    labels, count = ndimage.label(mask, structure=np.ones((3, 3)))
    if count == 0:
        return mask
    return labels == 1 + int(np.argmax(np.bincount(labels.ravel())[1:]))


def _cuts(standing: np.ndarray, axis: int) -> list[int]:
    """Raster lines to cut before, across ``axis`` (1: columns, 0: rows), ascending."""
    lines = standing if axis == 0 else standing.T  # [line, position]
    opening = lines.sum(axis=1)
    used = np.flatnonzero(opening)
    if len(used) == 0:
        return []
    first, last = int(used[0]), int(used[-1]) + 1
    narrow = opening <= NARROW_FRACTION * np.median(opening[first:last])
    narrow[:first] = narrow[last:] = False
    candidates = []
    padded = np.concatenate(([False], narrow, [False])).astype(np.int8)
    changes = np.flatnonzero(np.diff(padded))
    for run_start, run_stop in zip(changes[::2], changes[1::2]):
        cut = (int(run_start) + int(run_stop)) // 2
        # the floor must cross the cut line: the robot drives from one bay to the next there
        if (lines[cut - 1] & lines[cut]).any():
            candidates.append((int(opening[cut]), cut))
    shortest = round(MIN_BAY_M / RESOLUTION)
    cuts: list[int] = []
    for _, cut in sorted(candidates):
        if min(cut - first, last - cut, *(abs(cut - other) for other in cuts)) >= shortest and _connected(
            lines, first, last, sorted([*cuts, cut])
        ):
            cuts.append(cut)
    return sorted(cuts)


def _connected(lines: np.ndarray, first: int, last: int, cuts: list[int]) -> bool:
    """Whether the floor of every bay between ``cuts`` is one 4-connected piece."""
    edges = [first, *cuts, last]
    return all(ndimage.label(lines[a:b])[1] == 1 for a, b in zip(edges[:-1], edges[1:]))


def _bay_slice(rect, extent, axis: int, shape: tuple[int, int]) -> tuple[slice, slice]:
    """The raster pixels of a bay."""
    if axis == 1:
        a, b = (round((rect[0] - extent[0]) / RESOLUTION), round((rect[2] - extent[0]) / RESOLUTION))
        return slice(0, shape[0]), slice(a, b)
    a, b = (round((rect[1] - extent[1]) / RESOLUTION), round((rect[3] - extent[1]) / RESOLUTION))
    return slice(a, b), slice(0, shape[1])
