"""Layouts: the one place that reads layout YAML files and turns them into geometry.

A layout file describes one environment (README, "Layouts"). Its ``kind`` names the module that
builds its obstacles from the block of that name:

- ``cabin``: parametric seat rows (:mod:`cabinbench.layout_cabin`);
- ``grid``: an ASCII occupancy map, ``#`` obstacle, ``.`` free, optional ``S`` start
  (:mod:`cabinbench.layout_grid`, which also says where a map without ``S`` starts);
- ``polygons``: an outer boundary polygon plus obstacle polygons, in metres
  (:mod:`cabinbench.layout_polygons`);
- ``occupancy``: a ROS map_server occupancy grid (:mod:`cabinbench.layout_occupancy`). A plain ROS
  ``map.yaml`` (``image`` and ``resolution``, no ``kind``) is read as an ``occupancy`` block.

Adding a kind is one module and one registration: write ``cabinbench/layout_<kind>.py`` with a
``build(check, block, robot)`` that returns a :class:`~cabinbench.layout_fields.KindGeometry`
(failing through ``check``, a :class:`~cabinbench.layout_fields.FieldChecker`, on a bad field),
declare it as a :class:`~cabinbench.layout_fields.LayoutKind`, and add that to
:data:`LAYOUT_KINDS` below. Only this module reads layout files; the kinds see parsed YAML.

Every kind may also set ``robot``, ``cells`` (not a kind that derives its own, like ``cabin``
from ``rows_per_cell``; ``cells: auto`` splits an ``occupancy`` map into bays,
:mod:`cabinbench.layout_bays`), ``goals``, ``start``, ``max_steps``, ``success_coverage``,
``cleared_cells``, ``description`` and ``source``. :func:`load_layout` validates everything and
raises :class:`LayoutError` naming the file, the field, the problem and the fix.

Coordinates are metres, x to the right (along the cabin, nose to tail), y up (across the cabin).
Rasters are indexed ``[iy, ix]``; pixel ``(iy, ix)`` has its centre at
``origin + ((ix + 0.5) * resolution, (iy + 0.5) * resolution)``.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path

import numpy as np
import yaml
from matplotlib.path import Path as PolygonPath
from scipy import ndimage

from .geometry import resample_raster, world_to_pixel
from .layout_bays import AUTO, auto_cells
from .layout_cabin import CABIN
from .layout_fields import (
    CONTACT_CLEARANCE,
    RESOLUTION,
    Cell,
    FieldChecker,
    LayoutError,
    LayoutKind,
    RasterMap,
    RobotSpec,
)
from .layout_grid import GRID
from .layout_occupancy import OCCUPANCY
from .layout_polygons import POLYGONS
from .values import is_whole_number

LAYOUT_PATH_VARIABLE = "CABINBENCH_LAYOUT_PATH"
MARKER_RADIUS = 0.08  # goal cubes and exit landmarks, as the lidar sees them
DEFAULT_SUCCESS_COVERAGE = 0.98  # "all coverable area covered", less the raster's rounding at edges
WALL_TILE = 0.8  # metres: points per tile in Layout.distance_to_walls (about the gap between seat rows)


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
        to_centres = _point_segment_distances((lows + highs) / 2, starts, ends)  # every tile's at once
        nearest = np.empty(len(points))
        for members, to_centre, radius in zip(groups, to_centres, radii):
            near = to_centre <= to_centre.min() + 2 * radius + 1e-9
            nearest[members] = _point_segment_distances(points[members], starts[near], ends[near]).min(axis=1)
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
        labels = np.full(self.raster_shape, -1, dtype=np.int8)
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


def _point_segment_distances(points: np.ndarray, starts: np.ndarray, ends: np.ndarray) -> np.ndarray:
    """(N, S) exact distances from each point to each segment."""
    px, py = points[:, :1], points[:, 1:]
    dx, dy = ends[:, 0] - starts[:, 0], ends[:, 1] - starts[:, 1]
    length_sq = np.maximum(dx**2 + dy**2, 1e-12)
    t = np.clip(((px - starts[:, 0]) * dx + (py - starts[:, 1]) * dy) / length_sq, 0.0, 1.0)
    return np.sqrt((starts[:, 0] + t * dx - px) ** 2 + (starts[:, 1] + t * dy - py) ** 2)


# --------------------------------------------------------------------------------- loading
LAYOUT_KINDS: dict[str, LayoutKind] = {kind.name: kind for kind in (CABIN, GRID, POLYGONS, OCCUPANCY)}
COMMON_KEYS = {
    "name",
    "kind",
    "description",
    "source",
    "robot",
    "cells",
    "goals",
    "start",
    "max_steps",
    "success_coverage",
    "cleared_cells",
}


def builtin_layout_dir() -> Path:
    return Path(__file__).parent / "layout_files"  # a link to the repository's layouts/


def layout_search_path() -> list[Path]:
    """Folders searched for ``NAME.yaml``: the user's (``CABINBENCH_LAYOUT_PATH``) first."""
    user = [Path(p) for p in os.environ.get(LAYOUT_PATH_VARIABLE, "").split(os.pathsep) if p]
    return [*user, builtin_layout_dir()]


def available_layouts() -> dict[str, Path]:
    """Layout name → file, user folders shadowing built-ins."""
    found: dict[str, Path] = {}
    for folder in reversed(layout_search_path()):
        for path in sorted(folder.glob("*.yaml")):
            found[path.stem] = path
    return dict(sorted(found.items()))


def load_layout(name_or_path: str | os.PathLike) -> Layout:
    """Load a layout by registered name, by suite layout name (``cabin-v1-test/0007``, see
    :mod:`cabinbench.suites`) or by path to a YAML file."""
    candidate = Path(name_or_path)
    if candidate.suffix in (".yaml", ".yml") or candidate.exists():
        return read_layout(candidate)
    layouts = available_layouts()
    if str(name_or_path) in layouts:
        return read_layout(layouts[str(name_or_path)])
    if "/" in str(name_or_path):
        from .suites import suite_layout  # the suites build on this module

        return suite_layout(str(name_or_path))
    raise LayoutError(
        str(name_or_path),
        "<name>",
        "unknown layout",
        f"use one of {', '.join(layouts)}, a suite layout (cabin-v1-test/0007) or a .yaml path",
    )


def read_text(path: Path) -> str:
    """The text of a layout, family or suite file; one that cannot be read is a :class:`LayoutError`."""
    if path.is_dir():
        raise LayoutError(str(path), "<file>", "is a folder", "give a layout file, e.g. a .yaml inside it")
    try:
        return path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise LayoutError(
            str(path), "<file>", "no such file", "give an existing .yaml path or a layout name"
        ) from None
    except UnicodeDecodeError as error:
        line = error.object[: error.start].count(b"\n") + 1
        raise LayoutError(
            str(path), "<file>", f"not UTF-8 text (line {line})", "save the file as UTF-8"
        ) from None
    except OSError as error:
        raise LayoutError(
            str(path), "<file>", f"cannot be read ({error.strerror})", "check the file"
        ) from None


def parse_yaml(text: str, source: str) -> dict:
    """YAML text that must hold a mapping of fields (safe loader only)."""
    try:
        spec = yaml.safe_load(text)
    except yaml.YAMLError as error:
        raise LayoutError(
            source, "<file>", f"not valid YAML ({error})".replace("\n", " "), "fix the YAML syntax"
        ) from None
    if not isinstance(spec, dict):
        raise LayoutError(source, "<file>", "the file is not a mapping of fields", "write 'key: value' lines")
    return spec


def read_layout(path: Path) -> Layout:
    """Load the layout file at ``path``; a file that cannot be read is a :class:`LayoutError` too."""
    return parse_layout(read_text(path), source=str(path), default_name=path.stem)


def parse_layout(text: str, source: str = "<string>", default_name: str = "layout") -> Layout:
    """Validate layout YAML text and build its geometry; its ``content_hash`` is the text's."""
    return build_layout(parse_yaml(text, source), source, default_name, text)


def build_layout(spec: dict, source: str, default_name: str, text: str) -> Layout:
    """Validate a parsed layout spec (the fields of a layout file) and build its geometry; its
    ``content_hash`` is that of ``text`` (the file's) and of any file the kind reads besides."""
    kinds = ", ".join(LAYOUT_KINDS)
    plain_ros_map = "kind" not in spec and "image" in spec
    if plain_ros_map:  # a map_server map.yaml as it is: its fields are an occupancy block
        spec = {"kind": OCCUPANCY.name, OCCUPANCY.name: spec}
    check = FieldChecker(source, OCCUPANCY.name if plain_ros_map else "")
    check.known_keys(spec, COMMON_KEYS | set(LAYOUT_KINDS), "")
    kind_name = spec.get("kind")
    if not isinstance(kind_name, str) or kind_name not in LAYOUT_KINDS:
        raise LayoutError(source, "kind", f"is {kind_name!r}", f"set kind to one of {kinds}")
    if kind_name not in spec:
        raise LayoutError(
            source, kind_name, "missing", f"add a '{kind_name}:' block with the {kind_name} parameters"
        )
    for other in LAYOUT_KINDS:
        if other != kind_name and other in spec:
            raise LayoutError(source, other, f"given but kind is {kind_name}", f"remove the '{other}' block")
    kind = LAYOUT_KINDS[kind_name]
    if kind.derives_cells and "cells" in spec:
        raise LayoutError(source, "cells", f"{kind_name} layouts derive their cells", kind.derives_cells)
    robot = check.robot(spec.get("robot", {}))
    geometry = kind.build(check, spec[kind_name], robot)
    boundary, obstacles, cells = geometry.boundary, geometry.obstacles, geometry.cells
    given_start = check.start(spec["start"], None) if "start" in spec else None
    if cells is None and spec.get("cells") == AUTO:
        if geometry.raster is None:
            check.fail("cells", f"auto needs a map, and a {kind_name} layout has none", "list the cells")
        (xmin, ymin), (xmax, ymax) = boundary.min(axis=0), boundary.max(axis=0)
        extent = (float(xmin), float(ymin), float(xmax), float(ymax))
        cells, start = auto_cells(check, geometry.raster.clearance, extent, robot, given_start)
    else:
        cells = cells if cells is not None else check.cells(spec.get("cells"), boundary)
        start = given_start or check.start(None, geometry.start)
    if "goals" in spec:
        cells = _assign_goals(check, spec["goals"], cells)
    layout = Layout(
        name=check.string(spec.get("name", default_name), "name"),
        kind=kind_name,
        description=check.string(spec.get("description", ""), "description"),
        source=check.string(spec.get("source", ""), "source"),
        path=source,
        content_hash=hashlib.sha256(text.encode() + geometry.content).hexdigest()[:16],
        boundary=boundary,
        obstacles=obstacles,
        cells=cells,
        passages=[],
        start=start,
        robot=robot,
        max_steps=check.positive_int(spec.get("max_steps", 3000), "max_steps"),
        success_coverage=check.fraction(
            spec.get("success_coverage", DEFAULT_SUCCESS_COVERAGE), "success_coverage"
        ),
        cleared_cells=_cleared_cells(check, spec.get("cleared_cells", 0), len(cells)),
        parameters=dict(spec[kind_name]) if isinstance(spec[kind_name], dict) else {"map": spec[kind_name]},
        written_map=geometry.written_map,
        raster=geometry.raster,
    )
    _validate_geometry(check, layout)
    layout.passages = _build_passages(layout)
    _validate_reachability(check, layout)
    return layout


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


def _cleared_cells(check: FieldChecker, value, cell_count: int) -> int:
    if not (is_whole_number(value) and 0 <= value < cell_count):
        check.fail(
            "cleared_cells",
            f"expected 0 to {cell_count - 1}, got {value!r}",
            "leave at least the last cell to clean",
        )
    return value


def _assign_goals(check: FieldChecker, value, cells: list[Cell]) -> list[Cell]:
    """Explicit goal points replace the defaults; each goes to the cell that contains it."""
    if not isinstance(value, list):
        check.fail("goals", "expected a list of [x, y] points", "write goals: [[x, y], ...]")
    points = [check.point(p, f"goals[{i}]") for i, p in enumerate(value)]
    per_cell: list[list] = [[] for _ in cells]
    for index, (x, y) in enumerate(points):
        owner = next(
            (i for i, c in enumerate(cells) if c.rect[0] <= x < c.rect[2] and c.rect[1] <= y < c.rect[3]),
            None,
        )
        if owner is None:
            check.fail(f"goals[{index}]", f"point {[x, y]} lies in no cell", "move it inside a cell")
        per_cell[owner].append((x, y))
    return [Cell(c.name, c.rect, np.array(g, dtype=float).reshape(-1, 2)) for c, g in zip(cells, per_cell)]


def _validate_geometry(check: FieldChecker, layout: Layout):
    x, y, _ = layout.start
    xmin, ymin, xmax, ymax = layout.extent
    if not PolygonPath(layout.boundary).contains_point((x, y)):
        check.fail("start", f"({x}, {y}) is outside the map {layout.extent}", "move the start onto the floor")
    if any(PolygonPath(polygon).contains_point((x, y)) for polygon in layout.obstacles) or (
        layout.raster is not None and not layout.free_raster[layout.to_pixel(x, y)]
    ):
        check.fail("start", f"({x}, {y}) is inside an obstacle", "move the start onto free floor")
    if not layout.free_raster.any():
        check.fail("<geometry>", "the map has no free floor", "remove obstacles or enlarge the boundary")
    if layout.clearance.max() < layout.robot.radius + CONTACT_CLEARANCE:
        check.fail(
            "robot.radius",
            f"the robot (diameter {layout.robot.tool_width} m) is wider than every gap",
            "use a smaller robot or wider gaps",
        )
    if layout.distance_to_walls([x, y])[0] < layout.robot.radius + CONTACT_CLEARANCE:
        check.fail(
            "start",
            f"({x}, {y}) is closer than the robot radius (+{CONTACT_CLEARANCE} m) to an obstacle",
            "move the start into open floor",
        )
    for index, cell in enumerate(layout.cells):
        cxmin, cymin, cxmax, cymax = cell.rect
        if cxmin < xmin - 1e-9 or cymin < ymin - 1e-9 or cxmax > xmax + 1e-9 or cymax > ymax + 1e-9:
            check.fail(
                f"cells[{index}].rect",
                f"{cell.rect} reaches outside the map {layout.extent}",
                "keep cells inside the map",
            )


def _build_passages(layout: Layout) -> list[Passage]:
    """Bounds and exits between consecutive cells, found where their rectangles share an edge.

    The shared edge is sampled on the raster; each run of floor the robot could drive across
    becomes one bound segment, with one exit landmark beyond it in the next cell.
    """
    passages = []
    offset = layout.robot.radius + 0.1  # exits sit clear of the bound so it can close behind
    for index, (here, there) in enumerate(zip(layout.cells, layout.cells[1:])):
        edge = _shared_edge(here.rect, there.rect)
        if edge is None:
            continue
        axis, position, lo, hi, direction = edge
        samples = np.arange(lo + RESOLUTION / 2, hi, RESOLUTION / 2)
        clear = _clearance_along(layout, axis, position, samples) >= layout.robot.radius
        bounds, exits = [], []
        for run_lo, run_hi in _runs(clear):
            # extend the run to the walls on both sides so the bound closes the whole opening
            a, b = samples[run_lo], samples[run_hi - 1]
            a = _extend_to_wall(layout, axis, position, a, -RESOLUTION / 2, lo)
            b = _extend_to_wall(layout, axis, position, b, RESOLUTION / 2, hi)
            a, b = max(lo, a - RESOLUTION), min(hi, b + RESOLUTION)  # overlap the walls: no sub-pixel slit
            middle = (samples[run_lo] + samples[run_hi - 1]) / 2
            if axis == 0:  # vertical shared edge x = position
                bounds.append((position, a, position, b))
                exits.append((position + direction * offset, middle))
            else:
                bounds.append((a, position, b, position))
                exits.append((middle, position + direction * offset))
        passages.append(
            Passage(
                index,
                np.array(bounds, dtype=float).reshape(-1, 4),
                np.array(exits, dtype=float).reshape(-1, 2),
            )
        )
    return passages


def _shared_edge(a, b):
    """(axis, position, lo, hi, direction from a to b) of the edge two rectangles share, or None."""
    for axis, (a_lo, a_hi, b_lo, b_hi) in ((0, (a[0], a[2], b[0], b[2])), (1, (a[1], a[3], b[1], b[3]))):
        other = 1 - axis
        lo, hi = max(a[other], b[other]), min(a[other + 2], b[other + 2])
        if hi - lo <= 0:
            continue
        if abs(a_hi - b_lo) < 1e-9:
            return axis, a_hi, lo, hi, 1.0
        if abs(a_lo - b_hi) < 1e-9:
            return axis, a_lo, lo, hi, -1.0
    return None


def _extend_to_wall(
    layout: Layout, axis: int, position: float, along: float, step: float, limit: float
) -> float:
    """``along`` moved step by step while the next point stays strictly short of ``limit`` and off the
    walls (the steps are taken one at a time, so the floats are those of a plain loop)."""
    reached = [along]
    while (reached[-1] + step > limit) if step < 0 else (reached[-1] + step < limit):
        reached.append(reached[-1] + step)
    open_ = _clearance_along(layout, axis, position, np.array(reached[1:])) > 0
    blocked = np.flatnonzero(~open_)
    return reached[int(blocked[0]) if len(blocked) else len(reached) - 1]


def _clearance_along(layout: Layout, axis: int, position: float, along):
    """Clearance where the shared edge crosses ``along`` (a number or an array of them): the smaller
    of the pixels either side, since an obstacle that ends exactly on the edge blocks it as much as
    one that straddles it."""
    along = np.asarray(along, dtype=float)
    rows, cols = layout.raster_shape
    x0, y0 = layout.origin
    sides = []
    for side in (position - RESOLUTION / 2, position + RESOLUTION / 2):
        x, y = (side, along) if axis == 0 else (along, side)
        row = np.clip(np.floor((y - y0) / RESOLUTION).astype(np.int64), 0, rows - 1)
        col = np.clip(np.floor((x - x0) / RESOLUTION).astype(np.int64), 0, cols - 1)
        sides.append(layout.clearance[row, col])
    return np.minimum(*sides)


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """Half-open index ranges of consecutive True values."""
    padded = np.concatenate([[False], mask, [False]]).astype(int)
    changes = np.flatnonzero(np.diff(padded))
    return list(zip(changes[::2], changes[1::2]))


def _validate_reachability(check: FieldChecker, layout: Layout):
    centre_free = layout.centre_free
    distance_to_reachable = ndimage.distance_transform_edt(~centre_free) * RESOLUTION
    for cell_index, cell in enumerate(layout.cells):
        if not (layout.coverable_raster & (layout.cell_raster == cell_index)).any():
            check.fail(
                f"cells[{cell_index}]",
                f"cell '{cell.name}' has no floor the robot can reach",
                "remove the cell or open a way into it",
            )
        for goal_index, (x, y) in enumerate(cell.goals):
            iy, ix = layout.to_pixel(x, y)
            if not layout.free_raster[iy, ix] or distance_to_reachable[iy, ix] > layout.robot.radius:
                check.fail(
                    "goals",
                    f"goal {goal_index} of cell '{cell.name}' at ({x:.2f}, {y:.2f}) "
                    "is out of the robot's reach",
                    "move it where the robot can drive over it",
                )
    for index, (here, there) in enumerate(zip(layout.cells, layout.cells[1:])):
        passage = next((p for p in layout.passages if p.index == index), None)
        if passage is None or not len(passage.exits):
            check.fail(
                f"cells[{index + 1}]",
                f"cell '{there.name}' has no opening from '{here.name}'",
                "make consecutive cells share an edge with floor the robot fits through",
            )
