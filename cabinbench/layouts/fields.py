"""What every part of the layout loader shares: the error, the field checker, the robot and
cell types, and the shape of a layout kind (see :mod:`cabinbench.layouts.model`)."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from cabinbench.errors import LayoutError
from cabinbench.values import is_real_number, is_whole_number

CONTACT_CLEARANCE = 0.01  # metres: a reachable pose keeps this from walls, so covering needs no contact
RESOLUTION = 0.05  # metres per coverage-raster pixel, the study's map resolution
MAX_POLYGON_CORNERS = 10_000


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


class FieldChecker:
    """Field validation with error messages that name the file and the field."""

    def __init__(self, source: str, block_in_file: str = ""):
        # ``block_in_file``: a kind's block whose fields the file writes at the top level (a plain
        # ROS map.yaml is an ``occupancy`` block): errors name them as the file spells them
        self.source, self.block_in_file = source, block_in_file

    def fail(self, field_name: str, problem: str, fix: str):
        if self.block_in_file:
            field_name = field_name.removeprefix(f"{self.block_in_file}.")
        raise LayoutError(self.source, field_name, problem, fix)

    def known_keys(self, mapping: dict, allowed: set[str], prefix: str):
        for key in mapping:
            if key not in allowed:
                self.fail(
                    f"{prefix}{key}", "unknown key", f"remove it; allowed here: {', '.join(sorted(allowed))}"
                )

    def number(self, value, field_name: str, positive: bool = True, allow_zero: bool = False) -> float:
        if not is_real_number(value):
            fix = "write a number in metres/seconds"
            if _exponent_as_text(value):
                fix = f"YAML reads {value} as text: write a point and a signed exponent, as 1.0e+6"
            self.fail(field_name, f"expected a number, got {value!r}", fix)
        if positive and (value < 0 or (value == 0 and not allow_zero)):
            self.fail(
                field_name,
                f"must be {'non-negative' if allow_zero else 'positive'}, got {value}",
                "use a size greater than zero",
            )
        return float(value)

    def positive_int(self, value, field_name: str) -> int:
        if not (is_whole_number(value) and value > 0):
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
        if len(value) > MAX_POLYGON_CORNERS:
            self.fail(
                field_name,
                f"{len(value)} corners, more than the {MAX_POLYGON_CORNERS} a polygon may have (checking "
                "that its edges do not cross takes seconds per 10,000)",
                "simplify the outline: a corner every few centimetres is as exact as the 5 cm raster",
            )
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
                "list cells in visit order as {name, rect: [xmin, ymin, xmax, ymax]}, or (an occupancy "
                "map) write cells: auto",
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


def _signed_area(points: np.ndarray) -> float:
    x, y = points[:, 0], points[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))


def _orientation(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Sign of the turn a → b → c (+1 left, -1 right, 0 straight), for points or arrays of them."""
    return np.sign(
        (b[..., 0] - a[..., 0]) * (c[..., 1] - a[..., 1]) - (b[..., 1] - a[..., 1]) * (c[..., 0] - a[..., 0])
    )


def _self_intersects(points: np.ndarray) -> bool:
    """Whether two edges of the ring ``points`` that are not neighbours cross (each edge against all
    later ones at once: a traced outline of thousands of corners takes a second, not minutes)."""
    n = len(points)
    starts, ends = points, np.roll(points, -1, axis=0)
    for i in range(n - 2):
        later = np.arange(i + 2, n if i else n - 1)  # neighbours share a corner: edge 0 and edge n - 1 too
        p1, p2, q1, q2 = starts[i], ends[i], starts[later], ends[later]
        crossing = (_orientation(p1, p2, q1) * _orientation(p1, p2, q2) < 0) & (
            _orientation(q1, q2, p1) * _orientation(q1, q2, p2) < 0
        )
        if crossing.any():
            return True
    return False


def rectangle(xmin: float, ymin: float, xmax: float, ymax: float) -> np.ndarray:
    return np.array([[xmin, ymin], [xmax, ymin], [xmax, ymax], [xmin, ymax]], dtype=float)


@dataclass(frozen=True)
class RasterMap:
    """A raster kind's floor (an occupancy map) as it is, not as polygons: the map, its walls, and
    what the layout measures on its raster."""

    map_floor: np.ndarray  # bool, the map's pixels (row 0 the lowest y)
    map_resolution: float  # metres per map pixel
    walls: np.ndarray  # (S, 4): the edges between floor and non-floor map pixels
    floor: np.ndarray  # the free raster: at RESOLUTION over the layout's extent
    clearance: np.ndarray  # metres from each free raster pixel centre to the nearest wall (0 off the floor)


@dataclass
class KindGeometry:
    """What a kind builds from its block: the map, and optionally its cells and a default start."""

    boundary: np.ndarray  # (n, 2) outer polygon
    obstacles: list[np.ndarray]  # polygons, each (n, 2)
    cells: list[Cell] | None = None  # None: the file's ``cells``, or one cell over the whole map
    start: tuple[float, float, float] | None = None  # used when the file gives no ``start``
    # a map the author wrote in robot-sized cells (True = obstacle, rows bottom to top): the
    # normalised map complexity is measured on, instead of one rasterised from the geometry
    written_map: np.ndarray | None = None
    raster: RasterMap | None = None  # a raster kind's map (then ``obstacles`` is empty)
    content: bytes = b""  # files the layout reads besides its own (a map image): part of its hash


@dataclass(frozen=True)
class LayoutKind:
    """One kind of layout file: ``kind: <name>`` with a ``<name>:`` block that ``build(check, block,
    robot)`` turns into a :class:`KindGeometry`, raising through ``check`` on a bad field."""

    name: str
    build: Callable[[FieldChecker, object, RobotSpec], KindGeometry]
    derives_cells: str | None = None  # the kind makes its own cells; the fix for a file giving ``cells``


def _exponent_as_text(value) -> bool:
    """A finite number in exponent form that YAML 1.1 (PyYAML) reads as a string, such as ``1e6``."""
    if not isinstance(value, str) or "e" not in value.lower():
        return False
    try:
        return math.isfinite(float(value))
    except ValueError:
        return False
