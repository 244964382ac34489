"""Stage 5, path: the routed sweeps joined into one path, and the corners that cover nothing cut out.

Input: the sweeps in route order (raster (row, col) polylines); output: one (row, col) polyline.
``join`` links the sweeps by A* transits; ``drop_idle_corners`` then cuts out every corner whose
shortcut loses no coverage. A pixel counts as covered when its centre lies within the tool
radius of the path (``segment_footprint``, ``path_coverage``). ``driving_time`` estimates how long
the robot takes to drive a path in metres.
"""

from __future__ import annotations

import numpy as np

from cabinbench.geometry import drop_redundant_points, points_to_segment, polyline_length, wrap_angle

from .free_space import FreeSpace, segment_is_free

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
    path: np.ndarray,
    free: np.ndarray,
    radius_px: float,
    margin_px: float = 0.0,
    max_corners: int = 1,
    max_passes: int = 4,
) -> np.ndarray:
    """Shortcut the corners of a path wherever the shortcut loses no coverage.

    Up to ``max_corners`` consecutive inner waypoints are cut out when the straight segment that
    replaces them lies on free pixels and covers, within ``radius_px - margin_px``, every pixel
    that only the replaced segments covered. This removes the detours that cover nothing new:
    turns into cell corners that neighbouring passes already reach, staircases along edges that
    other lanes sweep, and the corners between transits and sweeps. The first and last waypoints
    stay.
    """
    points = [np.asarray(point, dtype=float) for point in path]
    if len(points) < 3:
        return path
    shape = free.shape
    footprints = [segment_footprint(a, b, radius_px, shape) for a, b in zip(points[:-1], points[1:])]
    counts = np.zeros(free.size, dtype=np.int32)
    for footprint in footprints:
        counts[footprint] += 1  # a segment's footprint has no repeated pixel

    def try_cut(first: int, count: int) -> bool:
        """Replace corners first .. first + count - 1 by one segment if that loses nothing."""
        before, after = points[first - 1], points[first + count]
        detour = polyline_length(np.array(points[first - 1 : first + count + 1]))
        if detour - np.hypot(*(after - before)) <= 1e-6 or not segment_is_free(free, before, after):
            return False
        replaced = footprints[first - 1 : first + count]
        pixels, times = np.unique(np.concatenate(replaced), return_counts=True)
        lost_rows, lost_cols = np.divmod(pixels[counts[pixels] == times], shape[1])
        distances = points_to_segment(np.column_stack((lost_rows, lost_cols)), before, after)
        if np.any(distances > radius_px - margin_px + 1e-9):
            return False
        shortcut = segment_footprint(before, after, radius_px, shape)
        for footprint in replaced:
            counts[footprint] -= 1
        counts[shortcut] += 1
        footprints[first - 1 : first + count] = [shortcut]
        del points[first : first + count]
        return True

    for _ in range(max_passes):
        changed = False
        k = 1
        while k < len(points) - 1:
            if any(try_cut(k, count) for count in range(1, max_corners + 1) if k + count < len(points)):
                changed = True
                continue  # the new corner at k may go as well
            k += 1
        if not changed:
            break
    return np.array(points)


def segment_footprint(
    start: np.ndarray, end: np.ndarray, radius_px: float, shape: tuple[int, int]
) -> np.ndarray:
    """Flat indices of the pixels whose centre lies within ``radius_px`` of the segment."""
    start, end = np.asarray(start, dtype=float), np.asarray(end, dtype=float)
    low = np.maximum(np.floor(np.minimum(start, end) - radius_px), 0).astype(int)
    high = np.minimum(np.ceil(np.maximum(start, end) + radius_px), np.array(shape) - 1).astype(int)
    rows = np.arange(low[0], high[0] + 1, dtype=float)[:, None] - start[0]
    cols = np.arange(low[1], high[1] + 1, dtype=float)[None, :] - start[1]
    delta = end - start
    length2 = float(delta @ delta)
    t = 0.0 if length2 == 0 else np.clip((rows * delta[0] + cols * delta[1]) / length2, 0.0, 1.0)
    inside = (rows - t * delta[0]) ** 2 + (cols - t * delta[1]) ** 2 <= radius_px**2 + 1e-9
    hit_rows, hit_cols = np.nonzero(inside)
    return (hit_rows + low[0]) * shape[1] + hit_cols + low[1]


def path_coverage(pixel_path: np.ndarray, coverable: np.ndarray, radius_px: float) -> float:
    """Fraction of the ``coverable`` pixels within ``radius_px`` of a (row, col) polyline."""
    covered = np.zeros(coverable.size, dtype=bool)
    points = np.asarray(pixel_path, dtype=float)
    for a, b in zip(points[:-1], points[1:]) if len(points) > 1 else [(points[0], points[0])]:
        covered[segment_footprint(a, b, radius_px, coverable.shape)] = True
    return float((covered & coverable.ravel()).sum() / max(int(coverable.sum()), 1))
