"""Reading layout files: the one place that turns layout YAML into a
:class:`~cabinbench.layouts.model.Layout`.

A layout file describes one environment (README, "Layouts"). Its ``kind`` names the module that
builds its obstacles from the block of that name:

- ``cabin``: parametric seat rows (:mod:`cabinbench.layouts.kinds.cabin`);
- ``grid``: an ASCII occupancy map, ``#`` obstacle, ``.`` free, optional ``S`` start
  (:mod:`cabinbench.layouts.kinds.grid`, which also says where a map without ``S`` starts);
- ``polygons``: an outer boundary polygon plus obstacle polygons, in metres
  (:mod:`cabinbench.layouts.kinds.polygons`);
- ``occupancy``: a ROS map_server occupancy grid (:mod:`cabinbench.layouts.kinds.occupancy`). A plain ROS
  ``map.yaml`` (``image`` and ``resolution``, no ``kind``) is read as an ``occupancy`` block.

Adding a kind is one module and one registration: write ``cabinbench/layout_<kind>.py`` with a
``build(check, block, robot)`` that returns a :class:`~cabinbench.layouts.fields.KindGeometry`
(failing through ``check``, a :class:`~cabinbench.layouts.fields.FieldChecker`, on a bad field),
declare it as a :class:`~cabinbench.layouts.fields.LayoutKind`, and add that to
:data:`LAYOUT_KINDS` below. Only this module reads layout files; the kinds see parsed YAML.

Every kind may also set ``robot``, ``cells`` (not a kind that derives its own, like ``cabin``
from ``rows_per_cell``; ``cells: auto`` splits an ``occupancy`` map into bays,
:mod:`cabinbench.layouts.bays`), ``goals``, ``start``, ``max_steps``, ``success_coverage``,
``cleared_cells``, ``description`` and ``source``. :func:`load_layout` validates everything and
raises :class:`LayoutError` naming the file, the field, the problem and the fix.
"""

from __future__ import annotations

import hashlib
import importlib.util
import os
from functools import cache
from pathlib import Path

import numpy as np
import yaml
from matplotlib.path import Path as PolygonPath
from scipy import ndimage

from cabinbench.errors import LayoutError
from cabinbench.layouts.bays import AUTO, auto_cells
from cabinbench.layouts.fields import CONTACT_CLEARANCE, RESOLUTION, Cell, FieldChecker, LayoutKind
from cabinbench.layouts.kinds.cabin import CABIN
from cabinbench.layouts.kinds.grid import GRID
from cabinbench.layouts.kinds.occupancy import OCCUPANCY
from cabinbench.layouts.kinds.polygons import POLYGONS
from cabinbench.layouts.model import DEFAULT_SUCCESS_COVERAGE, LAYOUT_PATH_VARIABLE, Layout, Passage
from cabinbench.values import is_whole_number

LAYOUT_KINDS: dict[str, LayoutKind] = {kind.name: kind for kind in (CABIN, GRID, POLYGONS, OCCUPANCY)}
MAX_LAYOUT_FILE_BYTES = 2**20
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


@cache
def builtin_layout_dir() -> Path:
    """The built-in layouts: the repository's ``layouts/``, installed as ``cabinbench.layouts.builtin``."""
    return Path(importlib.util.find_spec("cabinbench.layouts.builtin").origin).parent


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
    """Load the layout file at ``path``; a file that cannot be read, or too large to read in seconds
    (:data:`MAX_LAYOUT_FILE_BYTES`), is a :class:`LayoutError` too."""
    if path.is_file() and path.stat().st_size > MAX_LAYOUT_FILE_BYTES:
        raise LayoutError(
            str(path),
            "<file>",
            f"is {path.stat().st_size / 2**20:,.1f} MiB, more than the {MAX_LAYOUT_FILE_BYTES // 2**20} MiB "
            "a layout file may be (YAML of numbers reads at about 30 KiB a second)",
            "draw a large map as an image (kind: occupancy), or a grid with fewer, larger cells",
        )
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
    cell_of = layout.cell_raster
    coverable_by_cell = np.bincount(
        cell_of[layout.coverable_raster & (cell_of >= 0)], minlength=len(layout.cells)
    )
    for cell_index, cell in enumerate(layout.cells):
        if not coverable_by_cell[cell_index]:
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
