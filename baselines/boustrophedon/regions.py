"""Regions of the layout's robot-centre raster, and paths through them, in metres.

Every stage of the planner works on boolean masks over ``layout.centre_free`` (the pixels where
the robot centre may be): a cell less what lies near its closed bounds (``cell_region``), what
is connected to the start (``reachable``), the pixels near points or a polyline. Points are
world (x, y) metres; ``transit`` is an A* path between two points through a mask, and
``geodesic_map`` / ``geodesic_from`` are free-space distances within one.
"""

from __future__ import annotations

import numpy as np
from cabinbench.baselines.coverage_planning import FreeSpace
from scipy import ndimage
from scipy.sparse.csgraph import dijkstra

from cabinbench.geometry import distances_to_segments, pixels_to_world, segment_projections, world_to_pixel
from cabinbench.layouts.fields import RESOLUTION
from cabinbench.layouts.model import Layout

BOUND_MARGIN = 0.03  # metres kept between the robot's disc and a closed bound


def near_points(layout: Layout, points: np.ndarray, distance: float) -> np.ndarray:
    """Pixels whose centre lies closer than ``distance`` to one of ``points`` (N, 2)."""
    grid_x, grid_y = np.meshgrid(*layout.pixel_centres())
    near = np.zeros(layout.raster_shape, dtype=bool)
    for x, y in points:
        near |= np.hypot(grid_x - x, grid_y - y) < distance
    return near


def transit(
    layout: Layout, region: np.ndarray, start: np.ndarray, end: np.ndarray, fallback: np.ndarray | None = None
) -> np.ndarray:
    """An A* path (metres) from ``start`` to ``end`` through ``region`` (else through ``fallback``)."""
    begin, goal = (
        world_to_pixel(start, RESOLUTION, layout.origin),
        world_to_pixel(end, RESOLUTION, layout.origin),
    )
    if fallback is not None:
        try:
            pixels = FreeSpace(region).transit(begin, goal)
        except ValueError:
            pixels = FreeSpace(fallback).transit(begin, goal)
    else:
        pixels = FreeSpace(region).transit(begin, goal)
    return np.vstack([start, pixels_to_world(pixels, RESOLUTION, layout.origin)[1:-1], end])


def near_bounds(layout: Layout, passage: int) -> np.ndarray:
    """Pixels where the robot's disc would touch the bounds of ``passage`` (none if out of range)."""
    if not 0 <= passage < len(layout.passages):
        return np.zeros(layout.raster_shape, dtype=bool)
    bounds = layout.passages[passage].bounds
    centres = mask_points(layout, np.ones(layout.raster_shape, dtype=bool))
    distances = distances_to_segments(centres, bounds[:, :2], bounds[:, 2:]).min(axis=1)
    return (distances < layout.robot.radius + BOUND_MARGIN).reshape(layout.raster_shape)


def cell_region(layout: Layout, cell: int) -> np.ndarray:
    """Robot-centre pixels of ``cell`` that keep the disc off the bounds on either side."""
    return (
        layout.centre_free
        & (layout.cell_raster == cell)
        & ~near_bounds(layout, cell - 1)
        & ~near_bounds(layout, cell)
    )


def reachable(layout: Layout) -> np.ndarray:
    """Robot-centre pixels connected to the start (4-connected, as the planner sees them)."""
    labels, _ = ndimage.label(layout.centre_free)
    start = layout.to_pixel(*layout.start[:2])
    return labels == labels[start] if labels[start] else layout.centre_free.copy()


def arc_position(way: np.ndarray, layout: Layout, mask: np.ndarray) -> np.ndarray:
    """For each pixel of ``mask``, how far along ``way`` (metres) its nearest point lies."""
    points = mask_points(layout, mask)
    t, offsets = segment_projections(points, way[:-1], way[1:])
    segment = np.argmin((offsets**2).sum(axis=2), axis=1)
    length = np.sqrt(np.maximum((np.diff(way, axis=0) ** 2).sum(axis=1), 1e-12))
    along = np.concatenate([[0.0], np.cumsum(length)])
    return along[segment] + t[np.arange(len(points)), segment] * length[segment]


def near_polyline(layout: Layout, points: np.ndarray, distance: float) -> np.ndarray:
    """Pixels whose centre lies within ``distance`` of the polyline ``points`` (N, 2)."""
    centres = mask_points(layout, np.ones(layout.raster_shape, dtype=bool))
    near = np.zeros(layout.raster_shape, dtype=bool)
    if len(points) == 1:
        points = np.vstack([points, points])
    for start, end in zip(points[:-1], points[1:]):
        near |= distances_to_segments(centres, start[None], end[None]).reshape(near.shape) <= distance
    return near


def nearest_pixel(region: np.ndarray, layout: Layout, point: np.ndarray) -> tuple[int, int]:
    """The pixel of ``region`` nearest to ``point`` (metres)."""
    rows, cols = np.nonzero(region)
    xs, ys = layout.pixel_centres()
    k = int(np.argmin((xs[cols] - point[0]) ** 2 + (ys[rows] - point[1]) ** 2))
    return int(rows[k]), int(cols[k])


def geodesic_map(layout: Layout, region: np.ndarray, point: np.ndarray) -> np.ndarray:
    """Free-space distance (pixels) from ``point`` to every pixel of ``region`` (inf elsewhere)."""
    free = FreeSpace(region)
    distances = np.full(region.shape, np.inf)
    distances[region] = dijkstra(
        free.graph, directed=False, indices=free.node_id[nearest_pixel(region, layout, point)]
    )
    return distances


def geodesic_from(layout: Layout, region: np.ndarray, point: np.ndarray, masks) -> np.ndarray:
    """Free-space distance (metres) from ``point`` to the nearest pixel of each mask."""
    distances = geodesic_map(layout, region, point)
    return np.array([distances[mask].min() if mask.any() else np.inf for mask in masks]) * RESOLUTION


def pixel_centre(layout: Layout, pixel: tuple[int, int]) -> np.ndarray:
    """World (x, y) of the centre of pixel (row, col)."""
    xs, ys = layout.pixel_centres()
    return np.array([xs[pixel[1]], ys[pixel[0]]])


def mask_points(layout: Layout, mask: np.ndarray) -> np.ndarray:
    """World (x, y) of the centre of every pixel of ``mask``, (N, 2) in ``np.nonzero`` order."""
    xs, ys = layout.pixel_centres()
    rows, cols = np.nonzero(mask)
    return np.column_stack([xs[cols], ys[rows]])
