"""Stage 5, path: the routed sweeps joined into one path, and the corners that cover nothing cut out.

Input: the sweeps in route order (raster (row, col) polylines); output: one (row, col) polyline.
``join`` links the sweeps by A* transits; ``drop_idle_corners`` then cuts out every corner whose
shortcut loses no coverage. A pixel counts as covered when its centre lies within the tool
radius of the path (``segment_footprint``, ``path_coverage``). ``driving_time`` estimates how long
the robot takes to drive a path in metres.
"""

from __future__ import annotations

import numpy as np
from cabinbench.baselines.coverage_planning.free_space import FreeSpace, _segment_is_free
from numba import njit

from cabinbench.geometry import drop_redundant_points, polyline_length, segment_offset, wrap_angle

# A corner is only cut out when the shortcut covers what the corner alone covered with this much
# to spare (metres), so that a robot tracking the path a centimetre off still covers it.
SHORTCUT_MARGIN_M = 0.01


def driving_time(waypoints: np.ndarray, max_speed: float, max_turn_rate: float) -> float:
    """Time (s) to drive a polyline at full speed, turning in place at full rate at each waypoint.

    A differential-drive robot in tight spaces turns in place at the corners, and on a
    boustrophedon path those turns take about as long as the straight driving.
    """
    segments = np.diff(waypoints, axis=0)
    segments = segments[np.any(segments != 0, axis=1)]
    headings = np.arctan2(segments[:, 1], segments[:, 0])
    turns = np.abs(wrap_angle(np.diff(headings)))
    return polyline_length(waypoints) / max_speed + float(turns.sum()) / max_turn_rate


def join(free_space: FreeSpace, start_pixel: tuple[int, int], sweeps: list[np.ndarray]) -> np.ndarray:
    """The sweeps in route order, joined by A* transits, as one (row, col) polyline."""
    pieces = [np.array([start_pixel])]
    position = start_pixel
    for sweep in sweeps:
        pieces += [free_space.transit(position, tuple(sweep[0])), sweep]
        position = tuple(sweep[-1])
    return drop_redundant_points(np.vstack(pieces))


def drop_idle_corners(
    path: np.ndarray, free: np.ndarray, radius_px: float, margin_px: float = 0.0, max_passes: int = 4
) -> np.ndarray:
    """Shortcut the corners of a path wherever the shortcut loses no coverage.

    An inner waypoint is cut out when the straight segment between its neighbours lies on free
    pixels and covers, within ``radius_px - margin_px``, every pixel that only the two segments it
    joined covered. This removes the detours that cover nothing new: turns into cell corners that
    neighbouring passes already reach, staircases along edges that other lanes sweep, and the
    corners between transits and sweeps. The waypoints are tried in order, a waypoint again after
    its neighbour went, in up to ``max_passes`` passes over the path. The first and last waypoints
    stay.
    """
    points = np.asarray(path, dtype=float)
    if len(points) < 3:
        return path
    kept = _drop_idle_corners(points, free, float(radius_px), float(radius_px - margin_px), max_passes)
    return points[kept]


@njit(cache=True)
def _drop_idle_corners(points, free, radius, reach, max_passes):
    """``drop_idle_corners`` compiled (a building's path has tens of thousands of corners): the
    indices of the waypoints kept. The path is a linked list (``following``, ``preceding``);
    ``footprints[i]`` is the footprint of the segment from waypoint i to the next kept one and
    ``counts`` how many segments cover each pixel."""
    height, width = free.shape
    count = len(points)
    following, preceding = np.arange(1, count + 1), np.arange(-1, count - 1)
    footprints = [_footprint_between(points, i, i + 1, radius, height, width) for i in range(count - 1)]
    counts = np.zeros(free.size, dtype=np.int32)
    for footprint in footprints:
        for pixel in footprint:
            counts[pixel] += 1  # a segment's footprint has no repeated pixel
    mine = np.zeros(free.size, dtype=np.int32)  # how many of the two replaced segments cover a pixel
    for _ in range(max_passes):
        changed = False
        corner = following[0]
        while following[corner] < count:
            before, after = preceding[corner], following[corner]
            if (
                not _is_detour(points, before, corner, after)
                or not _segment_is_free(
                    free, points[before, 0], points[before, 1], points[after, 0], points[after, 1]
                )
                or _shortcut_loses_coverage(
                    points[before],
                    points[after],
                    footprints[before],
                    footprints[corner],
                    counts,
                    mine,
                    width,
                    reach,
                )
            ):
                corner = after
                continue
            shortcut = _footprint_between(points, before, after, radius, height, width)
            for footprint in (footprints[before], footprints[corner]):
                for pixel in footprint:
                    counts[pixel] -= 1
            for pixel in shortcut:
                counts[pixel] += 1
            footprints[before] = shortcut
            following[before], preceding[after] = after, before
            changed = True
            corner = after  # the new corner there may go as well
        if not changed:
            break
    kept = [0]
    while following[kept[-1]] < count:
        kept.append(following[kept[-1]])
    return np.array(kept)


@njit(cache=True)
def _footprint_between(points, first, second, radius, height, width):
    """The footprint of the segment from waypoint ``first`` to waypoint ``second``."""
    return _segment_footprint(
        points[first, 0], points[first, 1], points[second, 0], points[second, 1], radius, height, width
    )


@njit(cache=True)
def _is_detour(points, before, corner, after):
    """Whether going through waypoint ``corner`` is longer (by more than a micro-pixel) than going
    straight from ``before`` to ``after``."""
    detour = np.sqrt(
        (points[corner, 0] - points[before, 0]) ** 2 + (points[corner, 1] - points[before, 1]) ** 2
    ) + np.sqrt((points[after, 0] - points[corner, 0]) ** 2 + (points[after, 1] - points[corner, 1]) ** 2)
    straight = np.hypot(points[after, 0] - points[before, 0], points[after, 1] - points[before, 1])
    return detour - straight > 1e-6


@njit(cache=True)
def _shortcut_loses_coverage(start, end, first, second, counts, mine, width, reach):
    """Whether some pixel that only the two footprints ``first`` and ``second`` cover (``counts``:
    how many segments cover each flat pixel index, rows ``width`` long) lies farther than ``reach``
    from the shortcut ``start``-``end``. ``mine``, of ``counts``' size, is scratch space: all zeros
    before and after."""
    loses = False
    for footprint in (first, second):
        for pixel in footprint:
            mine[pixel] += 1
    for footprint in (first, second):
        for pixel in footprint:
            if loses or counts[pixel] != mine[pixel]:
                continue
            off_row, off_col = segment_offset(
                pixel // width, pixel % width, start[0], start[1], end[0], end[1]
            )
            loses = np.hypot(off_row, off_col) > reach + 1e-9
    for footprint in (first, second):
        for pixel in footprint:
            mine[pixel] = 0
    return loses


def segment_footprint(
    start: np.ndarray, end: np.ndarray, radius_px: float, shape: tuple[int, int]
) -> np.ndarray:
    """Flat indices of the pixels whose centre lies within ``radius_px`` of the segment (row by row)."""
    start, end = np.asarray(start, dtype=float), np.asarray(end, dtype=float)
    return _segment_footprint(start[0], start[1], end[0], end[1], float(radius_px), shape[0], shape[1])


@njit(cache=True)
def _segment_footprint(start_row, start_col, end_row, end_col, radius, height, width):
    """``segment_footprint`` compiled: a building's plan takes the footprints of tens of thousands of
    segments."""
    low_row = max(int(np.floor(min(start_row, end_row) - radius)), 0)
    low_col = max(int(np.floor(min(start_col, end_col) - radius)), 0)
    high_row = min(int(np.ceil(max(start_row, end_row) + radius)), height - 1)
    high_col = min(int(np.ceil(max(start_col, end_col) + radius)), width - 1)
    pixels = np.empty(max(high_row - low_row + 1, 0) * max(high_col - low_col + 1, 0), dtype=np.int64)
    count = 0
    for row in range(low_row, high_row + 1):
        for col in range(low_col, high_col + 1):
            off_row, off_col = segment_offset(row, col, start_row, start_col, end_row, end_col)
            if off_row * off_row + off_col * off_col <= radius * radius + 1e-9:
                pixels[count] = row * width + col
                count += 1
    return pixels[:count]


def path_coverage(pixel_path: np.ndarray, coverable: np.ndarray, radius_px: float) -> float:
    """Fraction of the ``coverable`` pixels within ``radius_px`` of a (row, col) polyline."""
    covered = np.zeros(coverable.size, dtype=bool)
    points = np.asarray(pixel_path, dtype=float)
    for a, b in zip(points[:-1], points[1:]) if len(points) > 1 else [(points[0], points[0])]:
        covered[segment_footprint(a, b, radius_px, coverable.shape)] = True
    return float((covered & coverable.ravel()).sum() / max(int(coverable.sum()), 1))
