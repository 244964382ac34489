"""Plane geometry shared by the layouts, the world and the planners: one definition each.

Conventions: metres; headings in radians, counter-clockwise from +x. The coverage raster's pixel
(row, col) covers x in [origin_x + col * res, origin_x + (col + 1) * res) and y likewise with
row; row 0 is the lowest y (images drawn from it are flipped to put it at the bottom).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numba import njit
from scipy import ndimage


def wrap_angle(angle: float | np.ndarray) -> float | np.ndarray:
    """Angle wrapped to [-pi, pi); elementwise for an array."""
    return (angle + math.pi) % (2.0 * math.pi) - math.pi


def world_to_pixel(point: Sequence[float], resolution: float, origin: Sequence[float]) -> tuple[int, int]:
    """(row, col) of the pixel containing world point (x, y); outside the raster when the point is."""
    return (
        int(math.floor((point[1] - origin[1]) / resolution)),
        int(math.floor((point[0] - origin[0]) / resolution)),
    )


def pixels_to_world(pixels: np.ndarray, resolution: float, origin: Sequence[float]) -> np.ndarray:
    """World (x, y) of the centres of pixels (row, col), shape (N, 2) -> (N, 2)."""
    pixels = np.asarray(pixels, dtype=float)
    return np.column_stack(
        (origin[0] + (pixels[:, 1] + 0.5) * resolution, origin[1] + (pixels[:, 0] + 0.5) * resolution)
    )


def segment_projections(points, starts: np.ndarray, ends: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The nearest point on each segment ``starts[i]``-``ends[i]`` (arrays (M, 2)) to each of ``points``
    ((N, 2), or one point (2,)): ``t`` (N, M), where it lies along the segment (0 at the start, 1 at
    the end), and the vector from it to the point, (N, M, 2). A segment of zero length is its start."""
    t, offset_x, offset_y = _nearest_on_segments(points, starts, ends)
    return t, np.stack([offset_x, offset_y], axis=-1)


def distances_to_segments(points, starts: np.ndarray, ends: np.ndarray) -> np.ndarray:
    """Exact distance from each of ``points`` ((N, 2), or one point (2,)) to each segment
    ``starts[i]``-``ends[i]`` (arrays (M, 2)): shape (N, M)."""
    _, offset_x, offset_y = _nearest_on_segments(points, starts, ends)
    return np.sqrt(offset_x**2 + offset_y**2)


def _nearest_on_segments(points, starts: np.ndarray, ends: np.ndarray):
    """The one definition of a point's nearest point on a segment: ``t`` (N, M) and the offsets' x
    and y (N, M) each (:func:`segment_offset` finds the same ``t`` compiled, for one point and one
    segment). A squared length is floored at 1e-12, so that a segment of zero length is its start.
    The offset is ``point - (start + t * along)``: the layouts' clearance is measured so."""
    points = np.asarray(points, dtype=float).reshape(-1, 2)
    px, py = points[:, :1], points[:, 1:]
    dx, dy = ends[:, 0] - starts[:, 0], ends[:, 1] - starts[:, 1]
    length_sq = np.maximum(dx**2 + dy**2, 1e-12)
    t = np.clip(((px - starts[:, 0]) * dx + (py - starts[:, 1]) * dy) / length_sq, 0.0, 1.0)
    return t, px - (starts[:, 0] + t * dx), py - (starts[:, 1] + t * dy)


# numba's cache of a kernel that calls this one does not notice a change here: after changing it,
# delete the callers' cached kernels (``__pycache__/*.nbi``, ``*.nbc``) or they run the old code
@njit(cache=True)
def segment_offset(x, y, start_x, start_y, end_x, end_y):
    """The vector from the nearest point of the segment ``start``-``end`` to the point (x, y), compiled
    for the kernels that take one point and one segment at a time (the lidar, coverage footprints).

    The same nearest point as :func:`segment_projections` (``t`` to the bit), but the offset is taken
    from the start, ``(x - start) - t * along``: a shorter chain that keeps the footprint kernel as
    fast as it was; it agrees with the numpy form to rounding. A segment of zero length is its start.
    """
    along_x, along_y = end_x - start_x, end_y - start_y
    from_x, from_y = x - start_x, y - start_y
    length_sq = along_x * along_x + along_y * along_y
    t = 0.0 if length_sq == 0.0 else min(1.0, max(0.0, (from_x * along_x + from_y * along_y) / length_sq))
    return from_x - t * along_x, from_y - t * along_y


def polyline_length(points: np.ndarray) -> float:
    """Length of a polyline given as an (N, 2) array."""
    return float(np.linalg.norm(np.diff(points, axis=0), axis=1).sum()) if len(points) > 1 else 0.0


def arc_lengths(points: np.ndarray) -> np.ndarray:
    """Distance along a polyline (N, 2) from its first point to each point: shape (N,)."""
    return np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(points, axis=0).T))])


def segment_samples(points: np.ndarray, spacing: float) -> list[np.ndarray]:
    """Each segment of a polyline as evenly spaced points, at most about ``spacing`` apart, both ends
    included (at least 2 points a segment): one (K, 2) array per segment."""
    return [
        np.linspace(a, b, max(2, int(np.hypot(*(b - a)) / spacing) + 1))
        for a, b in zip(points[:-1], points[1:])
    ]


def drop_repeated_points(points: np.ndarray) -> np.ndarray:
    """A polyline without the points that repeat the one before."""
    return points[np.concatenate(([True], np.any(np.diff(points, axis=0) != 0, axis=1)))]


def drop_redundant_points(points: np.ndarray) -> np.ndarray:
    """Remove repeated points and the middle points of straight runs from a polyline."""
    points = drop_repeated_points(points)
    if len(points) <= 2:
        return points
    incoming = points[1:-1] - points[:-2]
    outgoing = points[2:] - points[1:-1]
    cross = incoming[:, 0] * outgoing[:, 1] - incoming[:, 1] * outgoing[:, 0]
    forward = (incoming * outgoing).sum(axis=1) > 0
    keep = np.concatenate(([True], ~((cross == 0) & forward), [True]))
    return points[keep]


def nearest_point(points: np.ndarray, point: np.ndarray) -> np.ndarray:
    """The one of ``points`` (N, 2) nearest to ``point``."""
    return points[np.argmin(np.hypot(*(points - point).T))]


def raster_clearance(free: np.ndarray, resolution: float, at_resolution: float, shape) -> np.ndarray:
    """Distance in metres from the centre of each pixel of a raster of ``at_resolution`` and
    ``shape`` (same origin) to the nearest non-free pixel's square of ``free`` (of ``resolution``; the
    edge of ``free`` counts as non-free), 0 where the pixel under that centre is not free: the walls
    of a raster map are its pixel edges.

    One distance transform finds, for the map pixel under each centre, the non-free pixel of
    nearest centre; the distance to its square is within 0.21 map pixel of the exact nearest."""
    padded = np.pad(free, 1, constant_values=False)
    _, (rows, cols) = ndimage.distance_transform_edt(padded, return_indices=True)
    centre_y = (np.arange(shape[0]) + 0.5) * at_resolution / resolution  # in map pixels
    centre_x = (np.arange(shape[1]) + 0.5) * at_resolution / resolution
    under_y = np.minimum(np.floor(centre_y).astype(int), free.shape[0]) + 1  # + 1: the padding
    under_x = np.minimum(np.floor(centre_x).astype(int), free.shape[1]) + 1
    nearest_y = rows[np.ix_(under_y, under_x)] - 1.0
    nearest_x = cols[np.ix_(under_y, under_x)] - 1.0
    gap_y = np.maximum(np.maximum(nearest_y - centre_y[:, None], centre_y[:, None] - nearest_y - 1), 0.0)
    gap_x = np.maximum(np.maximum(nearest_x - centre_x[None, :], centre_x[None, :] - nearest_x - 1), 0.0)
    on_floor = padded[np.ix_(under_y, under_x)]
    # to the nanometre: a gap drawn to fit the robot exactly should not be decided by rounding
    return np.where(on_floor, np.round(np.hypot(gap_y, gap_x) * resolution, 9), 0.0)


def resample_raster(raster: np.ndarray, resolution: float, new_resolution: float, shape) -> np.ndarray:
    """A raster of ``resolution`` (row 0 the lowest y) at ``new_resolution`` over the same origin, of
    ``shape``: each new pixel takes the pixel under its centre (False past the raster's edge)."""
    if abs(resolution - new_resolution) < 1e-12 and raster.shape == tuple(shape):
        return raster
    rows = np.floor((np.arange(shape[0]) + 0.5) * new_resolution / resolution).astype(int)
    cols = np.floor((np.arange(shape[1]) + 0.5) * new_resolution / resolution).astype(int)
    padded = np.pad(raster, ((0, 1), (0, 1)), constant_values=False)
    return padded[np.ix_(np.minimum(rows, raster.shape[0]), np.minimum(cols, raster.shape[1]))]


def raster_edges(free: np.ndarray, resolution: float, origin: Sequence[float]) -> np.ndarray:
    """The walls of a raster map: every edge between a free and a non-free pixel (or the raster's
    edge), straight runs merged into one segment, as an (S, 4) array x0, y0, x1, y1 in metres."""
    padded = np.pad(free, 1, constant_values=False)
    # horizontal edges: line k (y = k pixels) lies between rows k - 1 and k; vertical ones likewise
    horizontal = padded[1:, 1:-1] != padded[:-1, 1:-1]  # (rows + 1, cols)
    vertical = (padded[1:-1, 1:] != padded[1:-1, :-1]).T  # (cols + 1, rows)
    segments = []
    for edges, along_x in ((horizontal, True), (vertical, False)):
        line, start, end = _runs_per_line(edges)
        fixed, lo, hi = line * resolution, start * resolution, end * resolution
        if along_x:
            segments.append(
                np.column_stack([lo + origin[0], fixed + origin[1], hi + origin[0], fixed + origin[1]])
            )
        else:
            segments.append(
                np.column_stack([fixed + origin[0], lo + origin[1], fixed + origin[0], hi + origin[1]])
            )
    return np.concatenate(segments)


def _runs_per_line(mask: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(line, start, end) of every run of True in each row of ``mask``, end exclusive."""
    padded = np.pad(mask, ((0, 0), (1, 1)), constant_values=False).astype(np.int8)
    line, start = np.nonzero(np.diff(padded, axis=1) == 1)
    _, end = np.nonzero(np.diff(padded, axis=1) == -1)
    return line, start, end
