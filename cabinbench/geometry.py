"""Plane geometry shared by the layouts, the world and the planners: one definition each.

Conventions: metres; headings in radians, counter-clockwise from +x. The coverage raster's pixel
(row, col) covers x in [origin_x + col * res, origin_x + (col + 1) * res) and y likewise with
row; row 0 is the lowest y (images drawn from it are flipped to put it at the bottom).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np


def wrap_angle(angle: float | np.ndarray) -> float | np.ndarray:
    """Angle wrapped to [-pi, pi); elementwise for an array."""
    return (angle + math.pi) % (2.0 * math.pi) - math.pi


def distances_to_segments(point: np.ndarray, starts: np.ndarray, ends: np.ndarray) -> np.ndarray:
    """Distance from ``point`` (x, y) to each segment ``starts[i]``-``ends[i]`` (arrays (M, 2)); a segment of
    zero length is its start point."""
    direction = ends - starts
    length_sq = np.maximum((direction**2).sum(axis=1), 1e-12)
    t = np.clip(((point - starts) * direction).sum(axis=1) / length_sq, 0.0, 1.0)
    return np.hypot(*(starts + t[:, None] * direction - point).T)


def points_to_segment(points: np.ndarray, start: np.ndarray, end: np.ndarray) -> np.ndarray:
    """Distance from each of ``points`` (N, 2) to the one segment ``start``-``end``."""
    offsets = np.asarray(points, dtype=float) - start
    delta = end - start
    length2 = float(delta @ delta)
    t = np.zeros(len(offsets)) if length2 == 0 else np.clip(offsets @ delta / length2, 0.0, 1.0)
    return np.hypot(*(offsets - t[:, None] * delta).T)


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


def offsets_from_segments(points: np.ndarray, starts: np.ndarray, ends: np.ndarray) -> np.ndarray:
    """For each of ``points`` (N, 2) and each segment ``starts[i]``-``ends[i]`` (M, 2), the vector from
    the segment's nearest point to the point: shape (N, M, 2)."""
    direction = ends - starts
    length_sq = np.maximum((direction**2).sum(axis=1), 1e-12)
    t = np.clip(((points[:, None, :] - starts[None]) * direction[None]).sum(axis=2) / length_sq[None], 0, 1)
    return points[:, None, :] - (starts[None] + t[..., None] * direction[None])


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
