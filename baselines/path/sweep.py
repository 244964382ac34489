"""What a plan promises before it is driven: the static footprint sweep of waypoint paths.

The robot's disc (radius ``layout.robot.radius``) is swept along each polyline, with no dynamics:
a coverage-raster pixel is planned covered when its centre lies within the radius of the
polyline and it is floor (the rule :func:`~cabinbench.sim.coverage.stamp_footprint` applies to
the executed poses). Beside the executed metrics of ``run`` it shows what the plan itself is
worth, and where a controller lost or gained on it.
"""

from __future__ import annotations

import inspect

import numpy as np
from cabinbench.baselines.path_following import PathFollower

from cabinbench.errors import BaselineError
from cabinbench.geometry import distances_to_segments, drop_repeated_points, segment_samples, wrap_angle
from cabinbench.layouts.fields import RESOLUTION
from cabinbench.layouts.model import Layout

TURN_ANGLE = inspect.signature(PathFollower).parameters["align_tolerance"].default
"""A waypoint turning by more than this (rad) is a turn: the path follower stops there and turns in place."""
BLOCK_SAMPLE = RESOLUTION / 4  # metres between the points at which a path is looked up on the rasters


def check_in_layout(layout: Layout, paths: list[np.ndarray], names: list[str]) -> None:
    """Raise a ``BaselineError`` naming the file (``names[i]`` holds path ``i``) when a waypoint lies
    outside the layout's extent."""
    xmin, ymin, xmax, ymax = layout.extent
    for points, name in zip(paths, names):
        outside = (
            (points[:, 0] < xmin) | (points[:, 0] > xmax) | (points[:, 1] < ymin) | (points[:, 1] > ymax)
        )
        if outside.any():
            index = int(np.argmax(outside))
            x, y = points[index]
            raise BaselineError(
                f"{name}: waypoint {index + 1} ({x:.3f}, {y:.3f}) lies outside layout {layout.name} "
                f"(x {xmin:.3f}..{xmax:.3f}, y {ymin:.3f}..{ymax:.3f}); give metres in the layout's frame"
            )


def swept_raster(layout: Layout, paths: list[np.ndarray]) -> np.ndarray:
    """Floor pixels whose centre lies within the robot radius of some path (a bool raster)."""
    radius, (x0, y0) = layout.robot.radius, layout.origin
    rows, cols = layout.raster_shape
    swept = np.zeros((rows, cols), dtype=bool)
    for points in paths:
        for start, end in zip(points[:-1], points[1:]):
            low, high = np.minimum(start, end) - radius, np.maximum(start, end) + radius
            col_lo, row_lo = np.maximum(np.floor((low - (x0, y0)) / RESOLUTION).astype(int), 0)
            col_hi, row_hi = np.minimum(
                np.floor((high - (x0, y0)) / RESOLUTION).astype(int), (cols - 1, rows - 1)
            )
            if col_lo > col_hi or row_lo > row_hi:
                continue
            grid_x, grid_y = np.meshgrid(
                x0 + (np.arange(col_lo, col_hi + 1) + 0.5) * RESOLUTION,
                y0 + (np.arange(row_lo, row_hi + 1) + 0.5) * RESOLUTION,
            )
            centres = np.column_stack([grid_x.ravel(), grid_y.ravel()])
            near = distances_to_segments(centres, start[None], end[None])[:, 0] <= radius
            swept[row_lo : row_hi + 1, col_lo : col_hi + 1] |= near.reshape(grid_x.shape)
    return swept & layout.free_raster


def turning(points: np.ndarray) -> tuple[int, float]:
    """(turns, total turning in rad) of a polyline: the heading changes at its waypoints (repeated
    points skipped), a turn being one of more than ``TURN_ANGLE``."""
    segments = np.diff(drop_repeated_points(points), axis=0)
    if len(segments) < 2:
        return 0, 0.0
    changes = np.abs(wrap_angle(np.diff(np.arctan2(segments[:, 1], segments[:, 0]))))
    return int((changes > TURN_ANGLE).sum()), float(changes.sum())


def blocked_lengths(layout: Layout, points: np.ndarray) -> tuple[float, float]:
    """(metres with the robot centre off the floor, metres with it on floor where the robot centre
    cannot be) along a polyline: on an obstacle or outside the boundary; closer to a wall than the
    radius plus the contact clearance, or cut off from the start (``layout.centre_free``)."""
    off_floor = on_unreachable = 0.0
    rows, cols = layout.raster_shape
    for samples in segment_samples(points, BLOCK_SAMPLE):
        pieces = np.hypot(*np.diff(samples, axis=0).T)
        middles = (samples[:-1] + samples[1:]) / 2
        col = np.clip(np.floor((middles[:, 0] - layout.origin[0]) / RESOLUTION).astype(int), 0, cols - 1)
        row = np.clip(np.floor((middles[:, 1] - layout.origin[1]) / RESOLUTION).astype(int), 0, rows - 1)
        floor, reachable = layout.free_raster[row, col], layout.centre_free[row, col]
        off_floor += float(pieces[~floor].sum())
        on_unreachable += float(pieces[floor & ~reachable].sum())
    return off_floor, on_unreachable


def planned_sweep(layout: Layout, paths: list[np.ndarray]) -> dict:
    """The planned figures of one path per robot on ``layout``, as plain numbers:

    - ``planned_coverage``: the share of the coverable area (``layout.coverable_raster``) the swept
      discs cover, as ``coverage`` measures the executed episode;
    - ``planned_length`` (m, all robots) and ``planned_path_lengths`` (m, per robot);
    - ``planned_turns`` (waypoints turning by more than ``TURN_ANGLE``) and ``planned_turning``
      (rad, the sum of the heading changes at the waypoints; the executed ``rotation`` also counts
      the turn from the start heading to the path);
    - ``planned_off_floor_length`` (m of path with the robot centre on an obstacle or outside the
      boundary) and ``planned_unreachable_length`` (m of path on floor where the robot centre
      cannot be: too near a wall for its disc, or not connected to the start).
    """
    coverable = layout.coverable_raster
    swept = swept_raster(layout, paths)
    lengths = [float(np.hypot(*np.diff(points, axis=0).T).sum()) for points in paths]
    turns = [turning(points) for points in paths]
    blocked = [blocked_lengths(layout, points) for points in paths]
    return {
        "planned_coverage": float((swept & coverable).sum() / max(1, coverable.sum())),
        "planned_length": sum(lengths),
        "planned_path_lengths": lengths,
        "planned_turns": sum(count for count, _ in turns),
        "planned_turning": sum(total for _, total in turns),
        "planned_off_floor_length": sum(off for off, _ in blocked),
        "planned_unreachable_length": sum(unreachable for _, unreachable in blocked),
    }
