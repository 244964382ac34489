"""Layouts: the one place that reads layout YAML files and turns them into geometry.

A layout file describes one environment (DESIGN.md, "Layout"). Three kinds build the obstacles:

- ``cabin``: parametric seat rows (see :func:`_build_cabin`);
- ``grid``: an ASCII occupancy map (``#`` obstacle, ``.`` free, ``S`` start);
- ``polygons``: an outer boundary polygon plus obstacle polygons, in metres.

Every kind may also set ``robot``, ``cells`` (not for ``cabin``, which derives its cells from
``rows_per_cell``), ``goals``, ``start``, ``max_steps``, ``success_coverage``, ``description`` and
``source``. :func:`load_layout` validates everything and raises :class:`LayoutError` naming the
file, the field, the problem and the fix.

Coordinates are metres, x to the right (along the cabin, nose to tail), y up (across the cabin).
Rasters are indexed ``[iy, ix]``; pixel ``(iy, ix)`` has its centre at
``origin + ((ix + 0.5) * resolution, (iy + 0.5) * resolution)``.
"""

from __future__ import annotations

import hashlib
import math
import os
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path

import numpy as np
import yaml
from matplotlib.path import Path as PolygonPath
from scipy import ndimage

from .geometry import world_to_pixel

RESOLUTION = 0.05  # metres per coverage-raster pixel, the seed's map resolution
LAYOUT_PATH_VARIABLE = "CABINBENCH_LAYOUT_PATH"
MARKER_RADIUS = 0.08  # goal cubes and exit landmarks, as the lidar sees them
CONTACT_CLEARANCE = 0.01  # metres: a reachable pose keeps this from walls, so covering needs no contact
DEFAULT_SUCCESS_COVERAGE = 0.98  # "all coverable area covered", less the raster's rounding at edges


class LayoutError(ValueError):
    """A layout file is invalid. The message names the file, the field, the problem and the fix."""

    def __init__(self, source: str, field_name: str, problem: str, fix: str):
        self.source, self.field_name, self.problem, self.fix = source, field_name, problem, fix
        super().__init__(f"{source}: field '{field_name}': {problem}. Fix: {fix}")


@dataclass(frozen=True)
class RobotSpec:
    """The disc robot: its cleaning footprint is the disc itself."""

    radius: float = 0.175
    max_speed: float = 0.5  # m/s at action linear = 1
    max_turn_rate: float = 2.0  # rad/s at action angular = 1

    @property
    def tool_width(self) -> float:
        return 2.0 * self.radius


@dataclass(frozen=True)
class Cell:
    """A cleaning cell of the sequential protocol: an axis-aligned rectangle and its goal markers."""

    name: str
    rect: tuple[float, float, float, float]  # xmin, ymin, xmax, ymax
    goals: np.ndarray  # (k, 2) marker points


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

    # ----------------------------------------------------------------------------- geometry
    @cached_property
    def extent(self) -> tuple[float, float, float, float]:
        (xmin, ymin), (xmax, ymax) = self.boundary.min(axis=0), self.boundary.max(axis=0)
        return float(xmin), float(ymin), float(xmax), float(ymax)

    @cached_property
    def walls(self) -> np.ndarray:
        """Every solid edge (boundary and obstacles) as an (S, 4) array of segments."""
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
        xs, ys = self.pixel_centres()
        grid_x, grid_y = np.meshgrid(xs, ys)
        points = np.column_stack([grid_x.ravel(), grid_y.ravel()])
        free = PolygonPath(self.boundary).contains_points(points)
        for polygon in self.obstacles:
            free &= ~PolygonPath(polygon).contains_points(points)
        return free.reshape(grid_x.shape)

    def distance_to_walls(self, points: np.ndarray) -> np.ndarray:
        """Exact distance from each of ``points`` (N, 2) to the nearest solid edge."""
        points = np.asarray(points, dtype=float).reshape(-1, 2)
        starts, ends = self.walls[:, :2], self.walls[:, 2:]
        direction = ends - starts
        length_sq = np.maximum((direction**2).sum(axis=1), 1e-12)
        nearest = np.empty(len(points))
        for begin in range(0, len(points), 4096):  # chunks keep the (points x walls) arrays small
            chunk = points[begin : begin + 4096, None, :]
            t = np.clip(((chunk - starts) * direction).sum(axis=2) / length_sq, 0.0, 1.0)
            offset = starts + t[..., None] * direction - chunk
            nearest[begin : begin + 4096] = np.sqrt((offset**2).sum(axis=2)).min(axis=1)
        return nearest

    @cached_property
    def clearance(self) -> np.ndarray:
        """Exact distance in metres from each free pixel centre to the nearest solid edge (0 off
        the floor). Exact, not a distance transform: obstacle edges need not lie on pixel
        boundaries, and half a pixel of error decides whether a robot fits a legroom gap."""
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

    def obstacle_grid(self, cell_size: float | None = None) -> np.ndarray:
        """Occupancy on cells of ``cell_size`` (default: the robot's diameter), rows bottom to top.

        A cell is occupied when any obstacle touches it, i.e. when any non-free raster pixel centre
        falls in it. The grid covers the extent; cells count whole robot sizes (rounded), so the
        actual cell size is the extent divided by their number.
        """
        cell_size = cell_size or self.robot.tool_width
        xmin, ymin, xmax, ymax = self.extent
        grid_rows = max(1, round((ymax - ymin) / cell_size))
        grid_cols = max(1, round((xmax - xmin) / cell_size))
        xs, ys = self.pixel_centres()
        row_of = np.minimum(((ys - ymin) / (ymax - ymin) * grid_rows).astype(int), grid_rows - 1)
        col_of = np.minimum(((xs - xmin) / (xmax - xmin) * grid_cols).astype(int), grid_cols - 1)
        occupied = np.zeros((grid_rows, grid_cols), dtype=bool)
        on_map = (ys[:, None] < ymax) & (xs[None, :] < xmax)  # the raster's last partial pixels
        blocked_rows, blocked_cols = np.nonzero(~self.free_raster & on_map)
        occupied[row_of[blocked_rows], col_of[blocked_cols]] = True
        return occupied


# --------------------------------------------------------------------------------- loading
_COMMON_KEYS = {
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
    "cabin",
    "grid",
    "polygons",
}
_CABIN_KEYS = {
    "width",
    "seat_blocks",
    "block_widths",
    "aisle_width",
    "rows",
    "seat_pitch",
    "seat_depth",
    "rows_per_cell",
    "front_clearance",
    "rear_clearance",
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
    """Load a layout by registered name or by path to a YAML file."""
    candidate = Path(name_or_path)
    if candidate.suffix in (".yaml", ".yml") or candidate.exists():
        if not candidate.is_file():
            raise LayoutError(
                str(candidate), "<file>", "no such file", "give an existing .yaml path or a layout name"
            )
        return parse_layout(candidate.read_text(), source=str(candidate), default_name=candidate.stem)
    layouts = available_layouts()
    if str(name_or_path) not in layouts:
        raise LayoutError(
            str(name_or_path),
            "<name>",
            "unknown layout",
            f"use one of {', '.join(layouts)}, or a path to a .yaml file",
        )
    path = layouts[str(name_or_path)]
    return parse_layout(path.read_text(), source=str(path), default_name=path.stem)


def parse_layout(text: str, source: str = "<string>", default_name: str = "layout") -> Layout:
    """Validate layout YAML text and build its geometry."""
    try:
        spec = yaml.safe_load(text)
    except yaml.YAMLError as error:
        raise LayoutError(
            source, "<file>", f"not valid YAML ({error})".replace("\n", " "), "fix the YAML syntax"
        ) from None
    check = _Checker(source)
    if not isinstance(spec, dict):
        raise LayoutError(
            source,
            "<file>",
            "the file is not a mapping of fields",
            "write 'kind: cabin|grid|polygons' and its block",
        )
    check.known_keys(spec, _COMMON_KEYS, "")
    kind = spec.get("kind")
    if kind not in ("cabin", "grid", "polygons"):
        raise LayoutError(source, "kind", f"is {kind!r}", "set kind to one of cabin, grid, polygons")
    if kind not in spec:
        raise LayoutError(source, kind, "missing", f"add a '{kind}:' block with the {kind} parameters")
    for other in {"cabin", "grid", "polygons"} - {kind}:
        if other in spec:
            raise LayoutError(source, other, f"given but kind is {kind}", f"remove the '{other}' block")
    robot = check.robot(spec.get("robot", {}))

    if kind == "cabin":
        if "cells" in spec:
            raise LayoutError(
                source,
                "cells",
                "cabin layouts derive their cells",
                "remove 'cells' and set cabin.rows_per_cell",
            )
        boundary, obstacles, cells, default_start = _build_cabin(check, spec["cabin"], robot)
    elif kind == "grid":
        boundary, obstacles, default_start = _build_grid(check, spec["grid"])
        cells = None
    else:
        boundary, obstacles = _build_polygons(check, spec["polygons"])
        default_start, cells = None, None
    if cells is None:
        cells = check.cells(spec.get("cells"), boundary)
    if "goals" in spec:
        cells = _assign_goals(check, spec["goals"], cells)

    start = check.start(spec.get("start"), default_start)
    layout = Layout(
        name=check.string(spec.get("name", default_name), "name"),
        kind=kind,
        description=check.string(spec.get("description", ""), "description"),
        source=check.string(spec.get("source", ""), "source"),
        path=source,
        content_hash=hashlib.sha256(text.encode()).hexdigest()[:16],
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
        parameters=dict(spec[kind]) if isinstance(spec[kind], dict) else {"map": spec[kind]},
    )
    _validate_geometry(check, layout)
    layout.passages = _build_passages(layout)
    _validate_reachability(check, layout)
    return layout


class _Checker:
    """Field validation with error messages that name the file and the field."""

    def __init__(self, source: str):
        self.source = source

    def fail(self, field_name: str, problem: str, fix: str):
        raise LayoutError(self.source, field_name, problem, fix)

    def known_keys(self, mapping: dict, allowed: set[str], prefix: str):
        for key in mapping:
            if key not in allowed:
                self.fail(
                    f"{prefix}{key}", "unknown key", f"remove it; allowed here: {', '.join(sorted(allowed))}"
                )

    def number(self, value, field_name: str, positive: bool = True, allow_zero: bool = False) -> float:
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            self.fail(field_name, f"expected a number, got {value!r}", "write a number in metres/seconds")
        if positive and (value < 0 or (value == 0 and not allow_zero)):
            self.fail(
                field_name,
                f"must be {'non-negative' if allow_zero else 'positive'}, got {value}",
                "use a size greater than zero",
            )
        return float(value)

    def positive_int(self, value, field_name: str) -> int:
        if isinstance(value, bool) or not isinstance(value, int) or value <= 0:
            self.fail(field_name, f"expected a positive integer, got {value!r}", "write a whole number ≥ 1")
        return int(value)

    def fraction(self, value, field_name: str) -> float:
        value = self.number(value, field_name)
        if value > 1:
            self.fail(field_name, f"must be in (0, 1], got {value}", "write a fraction such as 0.95")
        return value

    def string(self, value, field_name: str) -> str:
        if not isinstance(value, str):
            self.fail(field_name, f"expected text, got {value!r}", "quote the value")
        return value

    def mapping(self, value, field_name: str) -> dict:
        if not isinstance(value, dict):
            self.fail(
                field_name,
                f"expected a mapping, got {type(value).__name__}",
                "write 'key: value' lines under it",
            )
        return value

    def point(self, value, field_name: str, size: int = 2) -> list[float]:
        if not isinstance(value, (list, tuple)) or len(value) != size:
            self.fail(
                field_name,
                f"expected [{', '.join('xyz'[:size])}], got {value!r}",
                f"write a list of {size} numbers",
            )
        return [self.number(v, f"{field_name}[{i}]", positive=False) for i, v in enumerate(value)]

    def polygon(self, value, field_name: str) -> np.ndarray:
        if not isinstance(value, list) or len(value) < 3:
            self.fail(field_name, "a polygon needs at least 3 points", "list the corners as [[x, y], ...]")
        points = np.array([self.point(p, f"{field_name}[{i}]") for i, p in enumerate(value)])
        if np.allclose(points[0], points[-1]):
            points = points[:-1]  # a repeated first point closes the ring explicitly
        if len(points) >= 4 and _self_intersects(points):
            self.fail(
                field_name,
                "the polygon intersects itself",
                "order the corners around the outline without crossings",
            )
        if len(points) < 3 or abs(_signed_area(points)) < 1e-9:
            self.fail(
                field_name,
                "the polygon is not closed (zero area)",
                "give at least 3 distinct, non-collinear corners",
            )
        return points

    def robot(self, value) -> RobotSpec:
        value = self.mapping(value, "robot")
        self.known_keys(value, {"radius", "max_speed", "max_turn_rate"}, "robot.")
        return RobotSpec(**{k: self.number(v, f"robot.{k}") for k, v in value.items()})

    def rect(self, value, field_name: str) -> tuple[float, float, float, float]:
        xmin, ymin, xmax, ymax = self.point(value, field_name, size=4)
        if xmax <= xmin or ymax <= ymin:
            self.fail(field_name, f"empty rectangle {value}", "write [xmin, ymin, xmax, ymax] with max > min")
        return xmin, ymin, xmax, ymax

    def cells(self, value, boundary: np.ndarray) -> list[Cell]:
        if value is None:
            (xmin, ymin), (xmax, ymax) = boundary.min(axis=0), boundary.max(axis=0)
            return [Cell("cell_0", (xmin, ymin, xmax, ymax), np.zeros((0, 2)))]
        if not isinstance(value, list) or not value:
            self.fail(
                "cells",
                "expected a non-empty list",
                "list cells in visit order as {name, rect: [xmin, ymin, xmax, ymax]}",
            )
        cells = []
        for index, item in enumerate(value):
            item = self.mapping(item, f"cells[{index}]")
            self.known_keys(item, {"name", "rect"}, f"cells[{index}].")
            if "rect" not in item:
                self.fail(f"cells[{index}].rect", "missing", "give the cell as [xmin, ymin, xmax, ymax]")
            name = self.string(item.get("name", f"cell_{index}"), f"cells[{index}].name")
            cells.append(Cell(name, self.rect(item["rect"], f"cells[{index}].rect"), np.zeros((0, 2))))
        return cells

    def start(self, value, default) -> tuple[float, float, float]:
        if value is None:
            if default is None:
                self.fail("start", "missing", "give start: [x, y] or [x, y, heading] in metres / radians")
            return default
        if isinstance(value, list) and len(value) == 2:
            value = [*value, 0.0]
        x, y, heading = self.point(value, "start", size=3)
        return x, y, heading


def _cleared_cells(check: _Checker, value, cell_count: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value < cell_count:
        check.fail(
            "cleared_cells",
            f"expected 0 to {cell_count - 1}, got {value!r}",
            "leave at least the last cell to clean",
        )
    return value


def _signed_area(points: np.ndarray) -> float:
    x, y = points[:, 0], points[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))


def _segments_cross(p1, p2, q1, q2) -> bool:
    def orient(a, b, c):
        return np.sign((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]))

    return orient(p1, p2, q1) * orient(p1, p2, q2) < 0 and orient(q1, q2, p1) * orient(q1, q2, p2) < 0


def _self_intersects(points: np.ndarray) -> bool:
    n = len(points)
    edges = [(points[i], points[(i + 1) % n]) for i in range(n)]
    return any(
        _segments_cross(*edges[i], *edges[j])
        for i in range(n)
        for j in range(i + 2, n)
        if not (i == 0 and j == n - 1)  # neighbours share a corner
    )


def _rectangle(xmin: float, ymin: float, xmax: float, ymax: float) -> np.ndarray:
    return np.array([[xmin, ymin], [xmax, ymin], [xmax, ymax], [xmin, ymax]], dtype=float)


def _build_cabin(check: _Checker, block: dict, robot: RobotSpec):
    """Seat rows across a rectangular cabin floor.

    Along x: a free ``front_clearance`` zone, then ``rows`` pitch slots, each a legroom gap of
    ``seat_pitch - seat_depth`` followed by the seat block (depth ``seat_depth``), then a free
    ``rear_clearance`` zone. Across y: seat blocks attached to the side walls, separated by aisles;
    ``seat_blocks`` gives the seats per block (port to starboard) and the blocks share the width
    left by the aisles in proportion to their seats, unless ``block_widths`` fixes them.
    Cells group ``rows_per_cell`` rows; their goals are the wall-side dead ends of each legroom
    gap in the cell (the seed's white cubes) and the middle of gaps between two aisles.
    """
    block = check.mapping(block, "cabin")
    check.known_keys(block, _CABIN_KEYS, "cabin.")
    for required in ("width", "seat_blocks", "aisle_width", "rows", "seat_pitch", "seat_depth"):
        if required not in block:
            check.fail(f"cabin.{required}", "missing", f"add cabin.{required} (see layouts/a320_cell.yaml)")
    width = check.number(block["width"], "cabin.width")
    seats = block["seat_blocks"]
    if (
        not isinstance(seats, list)
        or not seats
        or not all(isinstance(s, int) and not isinstance(s, bool) and s > 0 for s in seats)
    ):
        check.fail(
            "cabin.seat_blocks",
            f"expected a list of seat counts, got {seats!r}",
            "write e.g. [3, 3] or [3, 4, 3]",
        )
    aisle = check.number(block["aisle_width"], "cabin.aisle_width")
    rows = check.positive_int(block["rows"], "cabin.rows")
    pitch = check.number(block["seat_pitch"], "cabin.seat_pitch")
    depth = check.number(block["seat_depth"], "cabin.seat_depth")
    rows_per_cell = check.positive_int(block.get("rows_per_cell", rows), "cabin.rows_per_cell")
    front = check.number(block.get("front_clearance", 0.0), "cabin.front_clearance", allow_zero=True)
    rear = check.number(block.get("rear_clearance", 0.0), "cabin.rear_clearance", allow_zero=True)
    if depth >= pitch:
        check.fail(
            "cabin.seat_depth",
            f"{depth} leaves no legroom at pitch {pitch}",
            "make seat_depth smaller than seat_pitch",
        )
    if rows % rows_per_cell:
        check.fail(
            "cabin.rows_per_cell",
            f"{rows} rows do not split into cells of {rows_per_cell}",
            "use a divisor of rows",
        )
    seats_width = width - aisle * (len(seats) - 1)
    if "block_widths" in block:
        widths = block["block_widths"]
        if not isinstance(widths, list) or len(widths) != len(seats):
            check.fail("cabin.block_widths", f"expected {len(seats)} widths", "give one width per seat block")
        widths = [check.number(w, f"cabin.block_widths[{i}]") for i, w in enumerate(widths)]
        if abs(sum(widths) - seats_width) > 1e-6:
            check.fail(
                "cabin.block_widths",
                f"blocks {sum(widths):.3f} m + aisles do not make the width {width} m",
                f"make the widths sum to {seats_width:.3f}",
            )
    else:
        widths = [seats_width * s / sum(seats) for s in seats]
    if seats_width <= 0:
        check.fail(
            "cabin.aisle_width", "the aisles take the whole width", "narrow the aisles or widen the cabin"
        )

    length = front + rows * pitch + rear
    legroom = pitch - depth
    block_spans, aisle_spans, y = [], [], 0.0
    for index, block_width in enumerate(widths):
        block_spans.append((y, y + block_width))
        y += block_width
        if index < len(widths) - 1:
            aisle_spans.append((y, y + aisle))
            y += aisle
    obstacles, cells = [], []
    for row in range(rows):
        seat_start = front + row * pitch + legroom
        obstacles += [_rectangle(seat_start, lo, seat_start + depth, hi) for lo, hi in block_spans]
    inset = robot.radius + 0.02  # goal cubes sit where the robot centre can just reach
    for cell_index in range(rows // rows_per_cell):
        first_row = cell_index * rows_per_cell
        xmin = 0.0 if cell_index == 0 else front + first_row * pitch
        xmax = length if first_row + rows_per_cell == rows else front + (first_row + rows_per_cell) * pitch
        goals = []
        for row in range(first_row, first_row + rows_per_cell):
            gap_x = front + row * pitch + legroom / 2
            for index, (lo, hi) in enumerate(block_spans):
                if index == 0:
                    goals.append((gap_x, lo + inset))
                elif index == len(block_spans) - 1:
                    goals.append((gap_x, hi - inset))
                else:
                    goals.append((gap_x, (lo + hi) / 2))
        cells.append(Cell(f"cell_{cell_index}", (xmin, 0.0, xmax, width), np.array(goals, dtype=float)))
    start_x = front / 2 if front >= 2 * robot.radius else front + legroom / 2
    start = (start_x, sum(aisle_spans[0]) / 2 if aisle_spans else width / 2, 0.0)
    return _rectangle(0.0, 0.0, length, width), obstacles, cells, start


def _build_grid(check: _Checker, block: dict):
    """ASCII map: each ``#`` a square obstacle of ``cell_size``; the first text line is the top row."""
    block = check.mapping(block, "grid")
    check.known_keys(block, {"cell_size", "map"}, "grid.")
    cell_size = check.number(block.get("cell_size"), "grid.cell_size")
    text = block.get("map")
    if not isinstance(text, str) or not text.strip():
        check.fail("grid.map", "empty map", "write rows of '#' (obstacle), '.' (free) and 'S' (start)")
    lines = [line.strip() for line in text.strip().splitlines()]
    if any(len(line) != len(lines[0]) for line in lines):
        lengths = sorted({len(line) for line in lines})
        check.fail(
            "grid.map", f"ragged rows (lengths {lengths})", "make every row the same number of characters"
        )
    bad = set("".join(lines)) - set("#.S")
    if bad:
        check.fail("grid.map", f"unknown characters {sorted(bad)}", "use only '#', '.' and 'S'")
    rows, cols = len(lines), len(lines[0])
    obstacles, start = [], None
    for text_row, line in enumerate(lines):
        y0 = (rows - 1 - text_row) * cell_size
        col = 0
        while col < cols:  # merge runs of '#' into one rectangle: fewer edges for the lidar
            if line[col] == "#":
                end = col
                while end < cols and line[end] == "#":
                    end += 1
                obstacles.append(_rectangle(col * cell_size, y0, end * cell_size, y0 + cell_size))
                col = end
            else:
                if line[col] == "S":
                    start = ((col + 0.5) * cell_size, y0 + 0.5 * cell_size, 0.0)
                col += 1
    if len(obstacles) and sum(line.count("#") for line in lines) == rows * cols:
        check.fail("grid.map", "no free cell", "mark free floor with '.'")
    return _rectangle(0.0, 0.0, cols * cell_size, rows * cell_size), obstacles, start


def _build_polygons(check: _Checker, block: dict):
    block = check.mapping(block, "polygons")
    check.known_keys(block, {"boundary", "obstacles"}, "polygons.")
    if "boundary" not in block:
        check.fail("polygons.boundary", "missing", "give the outer outline as [[x, y], ...]")
    boundary = check.polygon(block["boundary"], "polygons.boundary")
    obstacles_spec = block.get("obstacles", [])
    if not isinstance(obstacles_spec, list):
        check.fail(
            "polygons.obstacles", "expected a list of polygons", "write obstacles: [[[x, y], ...], ...]"
        )
    obstacles = [check.polygon(p, f"polygons.obstacles[{i}]") for i, p in enumerate(obstacles_spec)]
    return boundary, obstacles


def _assign_goals(check: _Checker, value, cells: list[Cell]) -> list[Cell]:
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


def _validate_geometry(check: _Checker, layout: Layout):
    x, y, _ = layout.start
    xmin, ymin, xmax, ymax = layout.extent
    if not PolygonPath(layout.boundary).contains_point((x, y)):
        check.fail("start", f"({x}, {y}) is outside the map {layout.extent}", "move the start onto the floor")
    if any(PolygonPath(polygon).contains_point((x, y)) for polygon in layout.obstacles):
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
        clear = np.array([_clearance_at(layout, axis, position, s) >= layout.robot.radius for s in samples])
        bounds, exits = [], []
        for run_lo, run_hi in _runs(clear):
            # extend the run to the walls on both sides so the bound closes the whole opening
            a, b = samples[run_lo], samples[run_hi - 1]
            while a - RESOLUTION / 2 > lo and _clearance_at(layout, axis, position, a - RESOLUTION / 2) > 0:
                a -= RESOLUTION / 2
            while b + RESOLUTION / 2 < hi and _clearance_at(layout, axis, position, b + RESOLUTION / 2) > 0:
                b += RESOLUTION / 2
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


def _clearance_at(layout: Layout, axis: int, position: float, along: float) -> float:
    """Clearance where the shared edge crosses ``along``: the smaller of the pixels either side,
    since an obstacle that ends exactly on the edge blocks it as much as one that straddles it."""
    sides = (position - RESOLUTION / 2, position + RESOLUTION / 2)
    points = [(side, along) if axis == 0 else (along, side) for side in sides]
    return float(min(layout.clearance[layout.to_pixel(x, y)] for x, y in points))


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """Half-open index ranges of consecutive True values."""
    padded = np.concatenate([[False], mask, [False]]).astype(int)
    changes = np.flatnonzero(np.diff(padded))
    return list(zip(changes[::2], changes[1::2]))


def _validate_reachability(check: _Checker, layout: Layout):
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
                    f"goal {goal_index} of cell '{cell.name}' at ({x:.2f}, {y:.2f}) is out of the robot's reach",
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
