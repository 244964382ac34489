"""The layout model: a :class:`Layout` is one environment's geometry (boundary, obstacles, cells
with their goals, passages between cells, start, robot, step limit and success criterion) and the
rasters derived from it. :mod:`cabinbench.layouts.load` builds one from a file;
:func:`cabinbench.layouts.resolve.load_layout` finds the file for a name.

Coordinates are metres, x to the right (along the cabin, nose to tail), y up (across the cabin).
Rasters are indexed ``[iy, ix]``; pixel ``(iy, ix)`` has its centre at
``origin + ((ix + 0.5) * resolution, (iy + 0.5) * resolution)``.
"""

from __future__ import annotations

import hashlib
import json
import math
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np
from matplotlib.path import Path as PolygonPath
from scipy import ndimage

from cabinbench.geometry import distances_to_segments, resample_raster, world_to_pixel
from cabinbench.layouts.fields import CONTACT_CLEARANCE, RESOLUTION, Cell, RasterMap, RobotSpec

LAYOUT_PATH_VARIABLE = "CABINBENCH_LAYOUT_PATH"
MARKER_RADIUS = 0.08  # goal cubes and exit landmarks, as the lidar sees them
DEFAULT_SUCCESS_COVERAGE = 0.98  # "all coverable area covered", less the raster's rounding at edges
WALL_TILE = 0.8  # metres: points per tile in Layout.distance_to_walls (about the gap between seat rows)
# tile-to-wall distances Layout.distance_to_walls holds at once (each of its temporaries 32 MiB): a
# long cabin's tiles times its walls would take gigabytes
TILE_WALL_BATCH = 2**22


@dataclass(frozen=True)
class Passage:
    """Where cell ``index`` meets cell ``index + 1``: the bound segments that close it and the exit
    landmarks (just inside the next cell) that the robot reaches to move on."""

    index: int
    bounds: np.ndarray  # (m, 4) segments x0, y0, x1, y1
    exits: np.ndarray  # (m, 2) points


@dataclass(eq=False)
class Layout:
    """A loaded, validated layout: geometry plus the rasters the benchmark measures on."""

    name: str
    kind: str
    description: str
    source: str
    path: str  # where it was loaded from ("<string>" for text)
    content_hash: str
    boundary: np.ndarray  # (n, 2) outer polygon
    obstacles: list[np.ndarray]  # polygons, each (n, 2)
    cells: list[Cell]
    passages: list[Passage]
    start: tuple[float, float, float]  # x, y, heading
    robot: RobotSpec
    max_steps: int
    success_coverage: float
    cleared_cells: int  # cells that count as cleaned at reset (the tracking cell starts with one)
    parameters: dict = field(default_factory=dict)  # the kind's own block, as written
    written_map: np.ndarray | None = None  # a grid's map as its author wrote it (True = obstacle)
    raster: RasterMap | None = None  # a raster kind's map (None: the floor is the polygons)

    # ----------------------------------------------------------------------------- geometry
    @cached_property
    def extent(self) -> tuple[float, float, float, float]:
        (xmin, ymin), (xmax, ymax) = self.boundary.min(axis=0), self.boundary.max(axis=0)
        return float(xmin), float(ymin), float(xmax), float(ymax)

    @cached_property
    def walls(self) -> np.ndarray:
        """Every solid edge (boundary and obstacles) as an (S, 4) array of segments."""
        if self.raster is not None:
            return self.raster.walls
        rings = [self.boundary, *self.obstacles]
        return np.concatenate([np.hstack([ring, np.roll(ring, -1, axis=0)]) for ring in rings])

    @property
    def goals(self) -> np.ndarray:
        return np.concatenate([cell.goals for cell in self.cells]).reshape(-1, 2)

    # ----------------------------------------------------------------------------- rasters
    @cached_property
    def raster_shape(self) -> tuple[int, int]:
        xmin, ymin, xmax, ymax = self.extent
        # ceil: the raster covers the whole map; a last partial pixel whose centre is off the
        # map is simply not floor
        return (
            max(1, math.ceil((ymax - ymin) / RESOLUTION - 1e-9)),
            max(1, math.ceil((xmax - xmin) / RESOLUTION - 1e-9)),
        )

    @cached_property
    def origin(self) -> tuple[float, float]:
        return self.extent[0], self.extent[1]

    def pixel_centres(self) -> tuple[np.ndarray, np.ndarray]:
        rows, cols = self.raster_shape
        x0, y0 = self.origin
        return x0 + (np.arange(cols) + 0.5) * RESOLUTION, y0 + (np.arange(rows) + 0.5) * RESOLUTION

    def to_pixel(self, x: float, y: float) -> tuple[int, int]:
        """(row, col) of the raster pixel holding (x, y), or of the nearest edge pixel for a point outside."""
        rows, cols = self.raster_shape
        row, col = world_to_pixel((x, y), RESOLUTION, self.origin)
        return min(rows - 1, max(0, row)), min(cols - 1, max(0, col))

    @cached_property
    def free_raster(self) -> np.ndarray:
        """True where the floor is free (inside the boundary, outside every obstacle)."""
        return self.raster.floor if self.raster is not None else self.floor_at(RESOLUTION)

    def floor_at(self, resolution: float) -> np.ndarray:
        """The free raster at any ``resolution`` over the extent: pixels whose centre is on the floor
        (a raster kind's map pixel under it)."""
        xmin, ymin, xmax, ymax = self.extent
        shape = (
            max(1, math.ceil((ymax - ymin) / resolution - 1e-9)),
            max(1, math.ceil((xmax - xmin) / resolution - 1e-9)),
        )
        if self.raster is not None:
            return resample_raster(self.raster.map_floor, self.raster.map_resolution, resolution, shape)
        xs, ys = (
            xmin + (np.arange(shape[1]) + 0.5) * resolution,
            ymin + (np.arange(shape[0]) + 0.5) * resolution,
        )
        free = _inside(self.boundary, xs, ys)
        for polygon in self.obstacles:
            free &= ~_inside(polygon, xs, ys)
        return free

    def distance_to_walls(self, points: np.ndarray) -> np.ndarray:
        """Exact distance from each of ``points`` (N, 2) to the nearest solid edge.

        Points are taken a tile at a time against only the walls that can be nearest to some
        point of the tile (a wall farther from the tile's centre than the nearest wall plus the
        tile's diameter cannot be), so the cost grows with the map's area, not area x walls.
        """
        points = np.asarray(points, dtype=float).reshape(-1, 2)
        starts, ends = self.walls[:, :2], self.walls[:, 2:]
        tiles = np.floor((points - points.min(axis=0)) / WALL_TILE).astype(np.int64)
        tile_of = tiles[:, 0] * (tiles[:, 1].max() + 1) + tiles[:, 1]
        order = np.argsort(tile_of, kind="stable")
        bounds = np.flatnonzero(np.diff(tile_of[order])) + 1
        groups = np.split(order, bounds)
        lows = np.array([points[members].min(axis=0) for members in groups])
        highs = np.array([points[members].max(axis=0) for members in groups])
        radii = np.hypot(*(highs - lows).T) / 2
        centres = (lows + highs) / 2
        nearest = np.empty(len(points))
        batch = max(1, TILE_WALL_BATCH // len(starts))  # tiles measured against every wall at once
        for first in range(0, len(groups), batch):
            to_centres = distances_to_segments(centres[first : first + batch], starts, ends)
            for members, to_centre, radius in zip(groups[first : first + batch], to_centres, radii[first:]):
                near = to_centre <= to_centre.min() + 2 * radius + 1e-9
                nearest[members] = distances_to_segments(points[members], starts[near], ends[near]).min(
                    axis=1
                )
        return nearest

    @cached_property
    def clearance(self) -> np.ndarray:
        """Exact distance in metres from each free pixel centre to the nearest solid edge (0 off
        the floor). Exact, not a distance transform: obstacle edges need not lie on pixel
        boundaries, and half a pixel of error decides whether a robot fits a legroom gap. A raster
        kind measures its own on its map (:func:`~cabinbench.geometry.raster_clearance`)."""
        if self.raster is not None:
            return self.raster.clearance
        xs, ys = self.pixel_centres()
        grid_x, grid_y = np.meshgrid(xs, ys)
        nearest = self.distance_to_walls(np.column_stack([grid_x.ravel(), grid_y.ravel()]))
        return np.where(self.free_raster, nearest.reshape(grid_x.shape), 0.0)

    @cached_property
    def centre_free(self) -> np.ndarray:
        """Pixels where the robot centre may be without touching anything (its disc keeps
        ``CONTACT_CLEARANCE`` from every wall) and that the start connects to."""
        feasible = self.clearance >= self.robot.radius + CONTACT_CLEARANCE
        if not feasible.any():
            return feasible
        labels, _ = ndimage.label(feasible, structure=np.ones((3, 3)))
        # the start is checked exactly; its own pixel centre may still sit a little too close
        _, (rows, cols) = ndimage.distance_transform_edt(~feasible, return_indices=True)
        start_row, start_col = self.to_pixel(*self.start[:2])
        return labels == labels[rows[start_row, start_col], cols[start_row, start_col]]

    @cached_property
    def coverable_raster(self) -> np.ndarray:
        """Pixels some reachable robot pose covers: reachable centres dilated by the radius."""
        distance = ndimage.distance_transform_edt(~self.centre_free) * RESOLUTION
        return (distance <= self.robot.radius) & self.free_raster

    @cached_property
    def cell_raster(self) -> np.ndarray:
        """Index of the cell each pixel belongs to (-1 outside every cell)."""
        xs, ys = self.pixel_centres()
        labels = np.full(
            self.raster_shape, -1, dtype=np.min_scalar_type(-len(self.cells))
        )  # int8 to 128 cells
        for index, cell in enumerate(self.cells):
            xmin, ymin, xmax, ymax = cell.rect
            inside_x = (xs >= xmin) & (xs < xmax)
            inside_y = (ys >= ymin) & (ys < ymax)
            labels[np.ix_(inside_y, inside_x)] = np.where(
                labels[np.ix_(inside_y, inside_x)] < 0, index, labels[np.ix_(inside_y, inside_x)]
            )
        return labels

    @property
    def free_area(self) -> float:
        return float(self.free_raster.sum()) * RESOLUTION**2

    @property
    def coverable_area(self) -> float:
        return float(self.coverable_raster.sum()) * RESOLUTION**2

    def normalized_map(self) -> np.ndarray:
        """The layout on robot-sized cells, True where the robot cannot be (the study's "normalized
        map", §4.2.1, Fig. 4.4(b)); rows bottom to top.

        A ``grid`` layout's map is the one its author wrote, cell for cell, whatever the robot's
        radius. Any other layout is rasterised: a cell is free when the robot's centre can stand
        somewhere in it (a pixel of :attr:`centre_free`: clear of every wall by the radius plus
        ``CONTACT_CLEARANCE``, and reachable from the start). So a legroom gap the robot can enter
        stays free however thin a strip its centre has there, and floor the robot never reaches
        counts as obstacle. The cells cover the extent; their number along each axis is the extent
        in robot diameters, rounded, so a cell is the extent divided by that number.
        """
        if self.written_map is not None:
            return self.written_map.copy()
        xmin, ymin, xmax, ymax = self.extent
        grid_rows = max(1, round((ymax - ymin) / self.robot.tool_width))
        grid_cols = max(1, round((xmax - xmin) / self.robot.tool_width))
        xs, ys = self.pixel_centres()
        row_of = np.minimum(((ys - ymin) / (ymax - ymin) * grid_rows).astype(int), grid_rows - 1)
        col_of = np.minimum(((xs - xmin) / (xmax - xmin) * grid_cols).astype(int), grid_cols - 1)
        cell_of = row_of[:, None] * grid_cols + col_of[None, :]
        standable = np.bincount(cell_of[self.centre_free], minlength=grid_rows * grid_cols)
        return (standable == 0).reshape(grid_rows, grid_cols)


def geometry_hash(layout: Layout) -> str:
    """SHA-256 (16 hex) of a layout's canonical geometry, to the millimetre: boundary, obstacles
    (in sorted order), cells and their goals, start, robot, step limit and success criterion. Two
    layouts that are the same map share it whatever their names, files or the parameters that
    drew them."""

    def rounded(array) -> list:
        return np.round(np.asarray(array, dtype=float), 3).tolist()

    canonical = {
        "boundary": rounded(layout.boundary),
        "obstacles": sorted(rounded(polygon) for polygon in layout.obstacles),
        "cells": [[rounded(cell.rect), rounded(cell.goals)] for cell in layout.cells],
        "start": rounded(layout.start),
        "robot": rounded([layout.robot.radius, layout.robot.max_speed, layout.robot.max_turn_rate]),
        "limits": [layout.max_steps, layout.success_coverage, layout.cleared_cells],
    }
    return hashlib.sha256(json.dumps(canonical, separators=(",", ":")).encode()).hexdigest()[:16]


def _inside(polygon: np.ndarray, xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
    """Which centres of the grid ``xs`` x ``ys`` lie inside ``polygon`` (rows by ``ys``); only those in
    its bounding box are tested, each as the whole grid would test it."""
    (xmin, ymin), (xmax, ymax) = polygon.min(axis=0), polygon.max(axis=0)
    columns = np.flatnonzero((xs >= xmin - 1e-9) & (xs <= xmax + 1e-9))
    rows = np.flatnonzero((ys >= ymin - 1e-9) & (ys <= ymax + 1e-9))
    inside = np.zeros((len(ys), len(xs)), dtype=bool)
    if len(columns) and len(rows):
        grid_x, grid_y = np.meshgrid(xs[columns], ys[rows])
        hits = PolygonPath(polygon).contains_points(np.column_stack([grid_x.ravel(), grid_y.ravel()]))
        inside[rows[0] : rows[-1] + 1, columns[0] : columns[-1] + 1] = hits.reshape(grid_x.shape)
    return inside
