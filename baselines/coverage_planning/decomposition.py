"""Stage 1, decomposition: the free pixels cut into boustrophedon cells (Choset, 2000).

Input: the centre-free raster and a sweep axis; output: a list of ``Cell``. A slice line (a raster
row for sweep axis 0, a column for 1) sweeps across the free space; the free intervals of
consecutive slices are matched, and a cell ends wherever the matching is not one-to-one (an
interval splits, two merge, one appears or disappears). A cell also ends where an interval end
jumps by more than ``max_jump`` pixels: such a jump hides a pocket that lanes spaced one tool
width apart could step over (the legroom between two seat rows is the typical case).
``transpose_cell`` tells whether a cell's pixels are also one cell of the other axis, i.e. may be
swept either way.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


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
    # The runs of each line of the other axis (a position here), as ``free_intervals`` finds them.
    padded = np.zeros((len(positions), len(lo) + 2), dtype=np.int8)
    padded[:, 1:-1] = local.T
    change = np.diff(padded, axis=1)
    run_lines, starts = np.nonzero(change == 1)
    _, ends = np.nonzero(change == -1)
    if not np.array_equal(run_lines, np.arange(len(positions))):  # a line crossing it twice
        return None
    runs = np.column_stack((starts, ends - 1))
    # Consecutive runs continue one cell (as in ``decompose``) when they overlap and, with
    # ``max_jump``, neither end jumps further.
    if np.any(runs[1:, 0] > runs[:-1, 1]) or np.any(runs[:-1, 0] > runs[1:, 1]):
        return None
    if max_jump is not None and len(runs) > 1 and np.abs(np.diff(runs, axis=0)).max() > max_jump:
        return None
    return Cell(1 - cell.sweep_axis, offset, runs + cell.first_line)
