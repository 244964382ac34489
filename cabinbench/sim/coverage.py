"""The coverage raster: stamping the robots' footprints (compiled with numba), and the robot's view of it.

:class:`CoverageRaster` is one episode's bookkeeping: each pixel counts the passes over it, a pass
starting when the pixel enters the footprint (it is under the disc now and was not at the previous
pose). The metrics module turns these counts into coverage and overlap; :func:`stamp_footprint`
only keeps them up to date and reports what is new.

:class:`CoveragePatch` is the optional part of the observation that shows the robot which floor
near it is still uncleaned (an egocentric local patch of the coverage raster). A real
cleaning robot keeps such a map from its odometry; without it a memoryless policy cannot tell a
cleaned aisle from a dirty one, and so cannot know when a cell is done.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from cabinbench.layouts.fields import RESOLUTION
from cabinbench.layouts.model import Layout
from cabinbench.memory import too_much_memory
from cabinbench.values import is_real_number, is_whole_number

PATCH_SAMPLES = 3  # samples per patch cell and axis: a 0.25 m cell is read on a 3 x 3 grid
# float32 each: the observation space's low and high, the observation, and a copy of it handed out
PATCH_BYTES_PER_ENTRY = 16


class CoverageRaster:
    """The pass counts of one episode on the layout's raster, the covered totals, and per cell the
    covered coverable pixels (what the protocol checks a cell without goals against)."""

    def __init__(self, layout: Layout):
        self.layout = layout
        self.floor_mask = layout.free_raster
        self.coverable_mask = layout.coverable_raster
        self.cell_of = layout.cell_raster
        self.coverable_by_cell = np.bincount(
            self.cell_of[self.coverable_mask & (self.cell_of >= 0)], minlength=len(layout.cells)
        )
        self.coverable_pixels = int(self.coverable_mask.sum())

    def reset(self) -> None:
        self.pass_count = np.zeros(self.layout.raster_shape, dtype=np.uint16)
        self.covered_by_cell = np.zeros(len(self.layout.cells), dtype=np.int64)
        self.covered_floor_pixels = 0
        self.covered_coverable_pixels = 0

    @property
    def coverage(self) -> float:
        return self.covered_coverable_pixels / self.coverable_pixels

    def stamp(self, x: float, y: float, previous_x: float, previous_y: float) -> int:
        """Cover a robot's footprint at (x, y), coming from the previous pose (NaN: none); returns the
        newly covered coverable pixels."""
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
            self.layout.robot.radius,
            origin_x,
            origin_y,
            RESOLUTION,
        )
        self.covered_floor_pixels += new_floor
        self.covered_coverable_pixels += new_coverable
        return new_coverable


@dataclass(frozen=True)
class CoveragePatch:
    """A square window of ``cells`` x ``cells`` cells of ``cell_size`` metres, centred on the robot and
    turned with it. Each entry is the fraction of its cell that is coverable floor not yet covered
    (sampled on a ``PATCH_SAMPLES`` grid). Rows run from behind the robot to ahead of it, columns from
    its right to its left. Only floor the robot may clean now counts: in ``sequential`` the current
    cell, and the next one once its passage is open; never the cells the layout starts cleared.
    ``cells = 0``: no patch."""

    cells: int = 0
    cell_size: float = 0.25

    def __post_init__(self) -> None:
        if not (is_whole_number(self.cells) and self.cells >= 0):
            raise ValueError(
                f"coverage_patch must be a whole number of cells >= 0 (0: no patch), got {self.cells!r}"
            )
        if not (is_real_number(self.cell_size) and self.cell_size > 0):
            raise ValueError(f"coverage_patch_cell must be a positive size in metres, got {self.cell_size!r}")
        problem = too_much_memory(self.size * PATCH_BYTES_PER_ENTRY)
        if problem:
            raise ValueError(
                f"coverage_patch {self.cells}: a patch of {self.cells} x {self.cells} cells {problem}; "
                "use a few dozen cells (e.g. coverage_patch=16)"
            )

    @property
    def size(self) -> int:
        """Entries in the observation."""
        return self.cells * self.cells


@njit(cache=True)
def write_coverage_patch(
    out,
    start,
    x,
    y,
    heading,
    cells,
    cell_size,
    pass_count,
    coverable_mask,
    cell_of,
    cell_visible,
    outside_visible,
    origin_x,
    origin_y,
    resolution,
):
    """Write the :class:`CoveragePatch` of a robot at (x, y, heading) into ``out[start : start +
    cells**2]``. ``cell_visible[c]`` says whether cell ``c``'s floor counts; ``outside_visible`` the
    same for floor in no cell."""
    rows, cols = pass_count.shape
    samples = cells * PATCH_SAMPLES  # per side
    step = cell_size / PATCH_SAMPLES / resolution  # in pixels
    # sample (i, j) lies at first + i * ahead + j * left, in pixel coordinates (column, row)
    ahead_col, ahead_row = step * math.cos(heading), step * math.sin(heading)
    left_col, left_row = -ahead_row, ahead_col
    corner = -samples / 2 + 0.5
    first_col = (x - origin_x) / resolution + corner * (ahead_col + left_col)
    first_row = (y - origin_y) / resolution + corner * (ahead_row + left_row)
    weight = 1.0 / (PATCH_SAMPLES * PATCH_SAMPLES)
    out[start : start + cells * cells] = 0.0
    for i in range(samples):
        entry_row = start + (i // PATCH_SAMPLES) * cells
        col_f, row_f = first_col + i * ahead_col, first_row + i * ahead_row
        for j in range(samples):
            if col_f >= 0.0 and row_f >= 0.0:  # int() then floors
                col, row = int(col_f), int(row_f)
                if col < cols and row < rows and pass_count[row, col] == 0 and coverable_mask[row, col]:
                    cell = cell_of[row, col]
                    if (cell >= 0 and cell_visible[cell]) or (cell < 0 and outside_visible):
                        out[entry_row + j // PATCH_SAMPLES] += weight
            col_f += left_col
            row_f += left_row


@njit(cache=True)
def stamp_footprint(
    pass_count,
    floor_mask,
    coverable_mask,
    cell_of,
    covered_by_cell,
    x,
    y,
    previous_x,
    previous_y,
    radius,
    origin_x,
    origin_y,
    resolution,
):
    """Mark the disc at (x, y) on ``pass_count``; return (newly covered floor px, newly covered
    coverable px). ``previous_x`` is NaN for the first pose of an episode. Pixels are covered when
    their centre lies in the disc; only floor pixels count. ``covered_by_cell`` accumulates newly
    covered coverable pixels per cell."""
    rows, cols = pass_count.shape
    radius_sq = radius * radius
    has_previous = not math.isnan(previous_x)
    row_lo = max(0, int((y - radius - origin_y) / resolution))
    row_hi = min(rows - 1, int((y + radius - origin_y) / resolution))
    col_lo = max(0, int((x - radius - origin_x) / resolution))
    col_hi = min(cols - 1, int((x + radius - origin_x) / resolution))
    new_floor, new_coverable = 0, 0
    for row in range(row_lo, row_hi + 1):
        centre_y = origin_y + (row + 0.5) * resolution
        for col in range(col_lo, col_hi + 1):
            if not floor_mask[row, col]:
                continue
            centre_x = origin_x + (col + 0.5) * resolution
            if (centre_x - x) ** 2 + (centre_y - y) ** 2 > radius_sq:
                continue
            if has_previous and (centre_x - previous_x) ** 2 + (centre_y - previous_y) ** 2 <= radius_sq:
                continue  # still the same pass
            if pass_count[row, col] == 0:
                new_floor += 1
                if coverable_mask[row, col]:
                    new_coverable += 1
                    if cell_of[row, col] >= 0:
                        covered_by_cell[cell_of[row, col]] += 1
            if pass_count[row, col] < 65535:
                pass_count[row, col] += 1
    return new_floor, new_coverable
