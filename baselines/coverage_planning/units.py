"""Stage 3, route units: how each cell is swept, as the pieces the route orders.

Input: a ``Cell`` and its swaths; output: a list of ``Sweep`` units, each with its ``variants``
(raster (row, col) polylines; variant k ^ 1 is variant k reversed). The lane direction is chosen
per cell: a cell that may be swept either way offers the boustrophedon sweeps of both directions
(``cell_sweeps``: two start corners, each either way round, connectors along the cell edge),
and the route picks one. Lanes of one- or two-lane cells are cut where other cells attach,
lanes of wider zones into blocks where corridors branch off their side. ``SweepOptions``
switches these choices off, for comparisons.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from cabinbench.baselines.coverage_planning.decomposition import Cell, line_view, transpose_cell
from cabinbench.baselines.coverage_planning.free_space import segment_is_free
from cabinbench.baselines.coverage_planning.swaths import (
    attachment_points,
    boundary_walk,
    corridor_zigzag,
    cut_lane,
    is_narrow,
    lane_blocks,
    swaths,
)

from cabinbench.geometry import drop_redundant_points, polyline_length

# Douglas-Peucker tolerance (pixels) for boundary-following polylines. Slightly above
# sqrt(2)/2 so that a 45-degree staircase of single-pixel steps becomes one diagonal segment,
# while steps of two pixels or more (real corners) are kept.
BOUNDARY_SIMPLIFY_TOLERANCE_PX = 0.75


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


DEFAULT_SWEEP_OPTIONS = SweepOptions()


def cell_units(
    cell: Cell,
    index: int,
    centre_free: np.ndarray,
    tool_width: float,
    resolution: float,
    max_jump: int | None = None,
    options: SweepOptions = DEFAULT_SWEEP_OPTIONS,
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
