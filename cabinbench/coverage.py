"""Coverage stamping: the robot's disc footprint marked on the 0.05 m raster, compiled with numba.

Each pixel counts the passes over it: a pass starts when the pixel enters the footprint (it is
under the disc now and was not at the previous pose). The metrics module turns these counts
into coverage and overlap; this kernel only keeps them up to date and reports what is new.
"""

from __future__ import annotations

import math

from numba import njit


@njit(cache=True)
def stamp_footprint(pass_count, floor_mask, coverable_mask, cell_of, covered_by_cell,
                    x, y, previous_x, previous_y, radius, origin_x, origin_y, resolution):
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
