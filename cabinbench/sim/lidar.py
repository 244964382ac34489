"""Simulated 2-D lidar: rays from the robot centre against segments and discs, compiled with numba.

pymunk's ``segment_query_first`` costs about 3 µs a ray, so 64 rays would dominate the env step;
this kernel casts all rays of a robot in a few microseconds. It sees the same geometry pymunk
collides with (walls and bounds as segments) plus the markers and other robots as discs, and
reports for each ray the distance and the tag of the nearest hit.

A building map has tens of thousands of wall segments; a scan reads only those in the squares of a
:class:`SegmentGrid` (buckets of :data:`GRID_CELL` metres) within the lidar's range.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from cabinbench.geometry import segment_offset
from cabinbench.values import is_real_number, is_whole_number

TAGS = ("obstacle", "bound", "goal", "exit", "robot")  # one-hot order in observations
NO_HIT, OBSTACLE, BOUND, GOAL, EXIT, ROBOT = 0, 1, 2, 3, 4, 5
GRID_CELL = 1.0  # metres: a scan of 3.5 m range reads 8 x 8 buckets


@dataclass(frozen=True)
class SegmentGrid:
    """Which segments cross each square of a grid over their extent: bucket ``b`` (row-major) holds
    ``items[starts[b]:starts[b + 1]]``. ``meta`` is [x0, y0, cell size, rows, cols]."""

    meta: np.ndarray
    starts: np.ndarray
    items: np.ndarray

    @classmethod
    def of(cls, segments: np.ndarray, cell: float = GRID_CELL) -> SegmentGrid:
        x0 = min(segments[:, 0].min(), segments[:, 2].min()) if len(segments) else 0.0
        y0 = min(segments[:, 1].min(), segments[:, 3].min()) if len(segments) else 0.0
        x1 = max(segments[:, 0].max(), segments[:, 2].max()) if len(segments) else 0.0
        y1 = max(segments[:, 1].max(), segments[:, 3].max()) if len(segments) else 0.0
        rows, cols = int((y1 - y0) // cell) + 1, int((x1 - x0) // cell) + 1
        meta = np.array([x0, y0, cell, rows, cols], dtype=np.float64)
        starts, items = _fill_buckets(np.ascontiguousarray(segments, dtype=np.float64), meta)
        return cls(meta, starts, items)


@njit(cache=True)
def _bucket_range(a, b, origin, cell, count):
    """First and last bucket index along one axis that the interval [a, b] touches."""
    lo, hi = min(a, b), max(a, b)
    return max(0, min(count - 1, int((lo - origin) // cell))), max(
        0, min(count - 1, int((hi - origin) // cell))
    )


@njit(cache=True)
def _segment_buckets(segments, meta, s):
    """Bucket rows r0..r1 and columns c0..c1 that segment ``s``'s bounding box touches."""
    x0, y0, cell, rows, cols = meta[0], meta[1], meta[2], int(meta[3]), int(meta[4])
    c0, c1 = _bucket_range(segments[s, 0], segments[s, 2], x0, cell, cols)
    r0, r1 = _bucket_range(segments[s, 1], segments[s, 3], y0, cell, rows)
    return r0, r1, c0, c1


@njit(cache=True)
def _fill_buckets(segments, meta):
    """Each segment goes into every bucket its bounding box touches: count, then fill."""
    cols = int(meta[4])
    counts = np.zeros(int(meta[3]) * cols + 1, dtype=np.int64)
    for s in range(segments.shape[0]):
        r0, r1, c0, c1 = _segment_buckets(segments, meta, s)
        for r in range(r0, r1 + 1):
            counts[r * cols + c0 + 1 : r * cols + c1 + 2] += 1
    starts = np.cumsum(counts)
    items = np.empty(starts[-1], dtype=np.int64)
    fill = starts[:-1].copy()
    for s in range(segments.shape[0]):
        r0, r1, c0, c1 = _segment_buckets(segments, meta, s)
        for r in range(r0, r1 + 1):
            for bucket in range(r * cols + c0, r * cols + c1 + 1):
                items[fill[bucket]] = s
                fill[bucket] += 1
    return starts, items


@dataclass(frozen=True)
class LidarConfig:
    """Rays spread evenly over ``field_of_view`` (centred on the heading), up to ``max_range``
    metres, with Gaussian range noise of standard deviation ``noise`` metres."""

    n_rays: int = 64
    max_range: float = 3.5
    field_of_view: float = 2 * math.pi
    noise: float = 0.0

    def __post_init__(self) -> None:
        # named as the envs' arguments, which users give
        if not (is_whole_number(self.n_rays) and self.n_rays >= 1):
            raise ValueError(f"n_rays must be a whole number of rays >= 1, got {self.n_rays!r}")
        if not (is_real_number(self.max_range) and self.max_range > 0):
            raise ValueError(f"lidar_range must be a positive distance in metres, got {self.max_range!r}")
        if not (is_real_number(self.field_of_view) and 0 < self.field_of_view <= 2 * math.pi + 1e-9):
            raise ValueError(
                f"field_of_view must be an angle in (0, 2 pi] radians, got {self.field_of_view!r}"
            )
        if not (is_real_number(self.noise) and self.noise >= 0):
            raise ValueError(f"lidar_noise must be a distance in metres >= 0 (0: none), got {self.noise!r}")

    def ray_angles(self) -> np.ndarray:
        if self.field_of_view >= 2 * math.pi - 1e-9:  # full circle: do not cast the same ray twice
            return np.linspace(-math.pi, math.pi, self.n_rays, endpoint=False)
        return np.linspace(-self.field_of_view / 2, self.field_of_view / 2, self.n_rays)


@njit(cache=True)
def _segments_in_range(x, y, max_range, segments, segment_on, grid_meta, grid_starts, grid_items, near):
    """Write into ``near`` the switched-on segments within ``max_range`` of (x, y), each once, and
    return how many: the only ones any ray of the scan can hit. Reads only the buckets in range."""
    seen = np.zeros(segments.shape[0], dtype=np.bool_)
    n_near = 0
    gx, gy, cell, rows, cols = grid_meta[0], grid_meta[1], grid_meta[2], int(grid_meta[3]), int(grid_meta[4])
    c0, c1 = _bucket_range(x - max_range, x + max_range, gx, cell, cols)
    r0, r1 = _bucket_range(y - max_range, y + max_range, gy, cell, rows)
    for r in range(r0, r1 + 1):
        for k in range(grid_starts[r * cols + c0], grid_starts[r * cols + c1 + 1]):
            s = grid_items[k]
            if seen[s] or not segment_on[s]:
                continue
            seen[s] = True
            dx, dy = segment_offset(x, y, segments[s, 0], segments[s, 1], segments[s, 2], segments[s, 3])
            if dx * dx + dy * dy <= max_range * max_range:
                near[n_near] = s
                n_near += 1
    return n_near


@njit(cache=True, fastmath=True)
def cast_rays(
    x,
    y,
    heading,
    ray_angles,
    max_range,
    segments,
    segment_tags,
    segment_on,
    grid_meta,
    grid_starts,
    grid_items,
    circles,
    circle_tags,
    circle_on,
    distances,
    tags,
):
    """Fill ``distances`` (max_range where nothing is hit) and ``tags`` for one robot.

    ``segments`` is (S, 4) [x0, y0, x1, y1], bucketed by ``grid_*`` (a :class:`SegmentGrid` of
    them); ``circles`` is (C, 3) [x, y, radius]. Entries whose ``*_on`` flag is False are ignored,
    as is any disc containing the ray origin (the robot itself, or a marker it stands on).
    """
    near_segments = np.empty(segments.shape[0], dtype=np.int64)
    n_near = _segments_in_range(
        x, y, max_range, segments, segment_on, grid_meta, grid_starts, grid_items, near_segments
    )
    for r in range(ray_angles.shape[0]):
        angle = heading + ray_angles[r]
        dx, dy = math.cos(angle), math.sin(angle)
        best, best_tag, best_segment = max_range, NO_HIT, -1
        for k in range(n_near):
            s = near_segments[k]
            ax, ay = segments[s, 0], segments[s, 1]
            ex, ey = segments[s, 2] - ax, segments[s, 3] - ay
            denominator = dx * ey - dy * ex
            if denominator == 0.0:
                continue
            wx, wy = ax - x, ay - y
            distance = (wx * ey - wy * ex) / denominator
            along = (wx * dy - wy * dx) / denominator
            # of segments hit at the same distance (a corner) the first in ``segments`` counts,
            # whatever order the buckets gave them in
            if 0.0 <= distance <= best and 0.0 <= along <= 1.0 and (distance < best or s < best_segment):
                best, best_tag, best_segment = distance, segment_tags[s], s
        for c in range(circles.shape[0]):
            if not circle_on[c]:
                continue
            fx, fy = x - circles[c, 0], y - circles[c, 1]
            radius = circles[c, 2]
            c_term = fx * fx + fy * fy - radius * radius
            if c_term <= 0.0:
                continue
            b_term = fx * dx + fy * dy
            discriminant = b_term * b_term - c_term
            if b_term >= 0.0 or discriminant < 0.0:
                continue
            distance = -b_term - math.sqrt(discriminant)
            if distance < best:
                best, best_tag = distance, circle_tags[c]
        distances[r] = best
        tags[r] = best_tag


@njit(cache=True)
def encode_scan(distances, tags, max_range, out):
    """Write the observation block of a scan: per ray [distance / max_range, one-hot of TAGS]."""
    width = 1 + 5
    for r in range(distances.shape[0]):
        base = r * width
        out[base] = distances[r] / max_range
        for k in range(5):
            out[base + 1 + k] = 0.0
        if tags[r] != NO_HIT:
            out[base + tags[r]] = 1.0
