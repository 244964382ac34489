"""Cabin families: seeded generators of ``cabin`` layouts from ranges of real cabin geometry.

A family is a YAML file in ``layouts/families/`` (or any path) that gives, for every parameter of
a cabin, a range ``[low, high]`` (drawn uniformly; whole numbers for counts) or a list of choices:

- ``configurations``: seat configurations (``seats: [3, 3]``), each with the cabin ``width``
  range it comes in (A320 3.70 m 3-3; 767 4.72 m 2-3-2; 777 5.87 m 3-4-3 or 3-3-3);
- ``aisle_width`` (each aisle drawn on its own), ``seat_pitch``, ``seat_depth``, ``cells``,
  ``rows_per_cell``, ``front_clearance``, ``rear_clearance``;
- ``exit_rows``: ``probability`` that a row is an emergency-exit row, and its ``extra_pitch``;
- ``galleys``: ``probability`` of a galley or lavatory block at each end of the cabin, against a
  side wall, with its ``depth`` and ``width``;
- ``bulkheads``: ``probability`` of a bulkhead at each cell end between two cells (a wall across
  every seat block in front of the cell's first row), and its ``thickness``;
- ``clutter``: how many ``bags`` and dropped ``items`` lie on the floor, and the ``trolley``
  probability of a service trolley parked in the aisle at the rear galley;
- ``steps_per_m2``: the step limit per square metre of coverable floor;
- ``seed``: the family's own seed, mixed with the index.

:func:`generate` is pure: ``(family file, index)`` gives the same layout on every machine (NumPy's
PCG64 seeded by ``[seed, index, attempt]``, sizes rounded to the millimetre). The drawn cabin
is a ``cabin`` layout spec (clutter, galleys and bulkheads as its extra ``obstacles``) loaded by
:func:`~cabinbench.layouts.load.build_layout`, the same validation as a hand-written file; a draw that
fails it, or whose floor the robot cannot reach all of from the start, is redrawn with the next
``attempt``. Clutter is placed where it keeps every gap open: in an aisle only against the aisle
side of a seat block (never across a legroom gap) and leaving the robot room to pass, otherwise
in the free zones at the cabin ends. A generated layout's ``content_hash`` is
:func:`~cabinbench.layouts.model.geometry_hash`: the same map has the same hash however it was drawn.
"""

from __future__ import annotations

import hashlib
import math
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import numpy as np

from cabinbench.errors import LayoutError
from cabinbench.layouts.fields import CONTACT_CLEARANCE, FieldChecker, RobotSpec
from cabinbench.layouts.kinds.cabin import check_cabin_size
from cabinbench.layouts.load import build_layout, builtin_layout_dir, parse_yaml, read_text
from cabinbench.layouts.model import Layout, geometry_hash
from cabinbench.values import is_whole_number

MAX_ATTEMPTS = 32  # draws per index before the family is declared unable to make a layout
# A gap the robot must pass is kept at least this wide: the study's legroom gap (1.3 robot
# diameters). Narrower gaps, though wider than the robot, can fall between raster pixels.
MIN_GAP = 0.45
BAG = (0.30, 0.20)  # along x, across y (m): a backpack pushed under a seat
ITEM = (0.08, 0.08)  # a dropped bottle or phone
TROLLEY = (0.80, 0.30)  # a full-size service trolley
RANGES = ("aisle_width", "seat_pitch", "seat_depth", "front_clearance", "rear_clearance")
FAMILY_KEYS = {
    "description",
    "source",
    "seed",
    "configurations",
    *RANGES,
    "cells",
    "rows_per_cell",
    "exit_rows",
    "galleys",
    "bulkheads",
    "clutter",
    "steps_per_m2",
}
FIX = "see layouts/families/cabin_v1.yaml"


@dataclass(frozen=True)
class Family:
    """A parsed, validated family file."""

    name: str
    path: str
    spec: dict  # the file's fields, checked
    text_hash: str  # the file's text identity, for caching draws

    def __hash__(self):
        return hash((self.path, self.text_hash))


def families_dir() -> Path:
    return builtin_layout_dir() / "families"


def load_family(name_or_path: str | Path) -> Family:
    """A family by name (``layouts/families/<name>.yaml``) or by path; errors name file, field and fix."""
    path = Path(name_or_path)
    if path.suffix not in (".yaml", ".yml"):
        path = families_dir() / f"{name_or_path}.yaml"
        if not path.exists():
            known = ", ".join(sorted(p.stem for p in families_dir().glob("*.yaml")))
            raise LayoutError(
                str(name_or_path), "<family>", "unknown family", f"use one of {known} or a path"
            )
    return _parsed_family(str(path), read_text(path))


@lru_cache(maxsize=32)
def _parsed_family(path: str, text: str) -> Family:
    """A family file's content parsed and checked once (keyed by its text, so an edited file is read
    anew): a suite names its family by name, and parsing the YAML again for every layout loaded was a
    fifth of a layout's generation time."""
    spec = parse_yaml(text, path)
    _check_family(FieldChecker(path), spec)
    return Family(Path(path).stem, path, spec, hashlib.sha256(text.encode()).hexdigest())


def _check_range(check: FieldChecker, value, field: str, integer: bool = False) -> None:
    if not isinstance(value, list) or len(value) != 2:
        check.fail(field, f"expected a range [low, high], got {value!r}", "write [low, high]")
    for index, bound in enumerate(value):
        if integer and not (is_whole_number(bound) and bound >= 0):
            check.fail(f"{field}[{index}]", f"expected a whole number >= 0, got {bound!r}", "write e.g. 2")
        elif not integer:
            check.number(bound, f"{field}[{index}]", allow_zero=True)
    if value[1] < value[0]:
        check.fail(field, f"high {value[1]} is below low {value[0]}", "write [low, high] with low <= high")


def _check_block(check: FieldChecker, spec: dict, field: str, ranges: dict[str, bool], numbers=()) -> None:
    """A mapping of ranges (name -> whole numbers?) and plain numbers, all required."""
    block = check.mapping(spec.get(field), field)
    check.known_keys(block, set(ranges) | set(numbers), f"{field}.")
    for key, integer in ranges.items():
        if key not in block:
            check.fail(f"{field}.{key}", "missing", FIX)
        _check_range(check, block[key], f"{field}.{key}", integer)
    for key in numbers:
        if key not in block:
            check.fail(f"{field}.{key}", "missing", FIX)
        check.number(block[key], f"{field}.{key}", allow_zero=True)


def _check_family(check: FieldChecker, spec: dict) -> None:
    check.known_keys(spec, FAMILY_KEYS, "")
    for key in ("seed", "configurations", *RANGES, "cells", "rows_per_cell", "steps_per_m2"):
        if key not in spec:
            check.fail(key, "missing", FIX)
    if not (is_whole_number(spec["seed"]) and spec["seed"] >= 0):
        check.fail("seed", f"expected a whole number >= 0, got {spec['seed']!r}", "write e.g. seed: 18")
    configurations = spec["configurations"]
    if not isinstance(configurations, list) or not configurations:
        check.fail("configurations", "expected a list", "list {seats: [3, 3], width: [3.6, 3.8]} entries")
    for index, item in enumerate(configurations):
        field = f"configurations[{index}]"
        item = check.mapping(item, field)
        check.known_keys(item, {"seats", "width"}, f"{field}.")
        seats = item.get("seats")
        if not isinstance(seats, list) or not seats or not all(isinstance(s, int) and s > 0 for s in seats):
            check.fail(f"{field}.seats", f"expected seat counts, got {seats!r}", "write e.g. [3, 4, 3]")
        _check_range(check, item.get("width"), f"{field}.width")
    for key in RANGES:
        _check_range(check, spec[key], key)
    _check_range(check, spec["cells"], "cells", integer=True)
    _check_range(check, spec["rows_per_cell"], "rows_per_cell", integer=True)
    check.number(spec["steps_per_m2"], "steps_per_m2")
    optional = {
        "exit_rows": ({"extra_pitch": False}, ("probability",)),
        "galleys": ({"depth": False, "width": False}, ("probability",)),
        "bulkheads": ({}, ("probability", "thickness")),
        "clutter": ({"bags": True, "items": True}, ("trolley",)),
    }
    for field, (ranges, numbers) in optional.items():
        if field in spec:
            _check_block(check, spec, field, ranges, numbers)
    for field in ("exit_rows.probability", "galleys.probability", "bulkheads.probability", "clutter.trolley"):
        block, key = field.split(".")
        if block in spec and spec[block][key] > 1:
            check.fail(field, f"a probability, got {spec[block][key]}", "write a number from 0 to 1")
    for key in ("cells", "rows_per_cell"):
        if spec[key][0] < 1:
            check.fail(
                f"{key}[0]", f"at least 1, got {spec[key][0]}", "a cabin has at least one cell and row"
            )
    _check_largest_cabin(check, spec)


def _check_largest_cabin(check: FieldChecker, spec: dict) -> None:
    """Refuse a family whose largest cabin (every range at its high end) is too large to load, before
    a draw makes a row at a time of it."""
    rows = spec["cells"][1] * spec["rows_per_cell"][1]
    pitch = spec["seat_pitch"][1] + (spec["exit_rows"]["extra_pitch"][1] if "exit_rows" in spec else 0.0)
    widths = [item["width"][1] for item in spec["configurations"]]
    widest = int(np.argmax(widths))
    blocks = max(len(item["seats"]) for item in spec["configurations"])
    clutter = sum(spec["clutter"][key][1] for key in ("bags", "items")) if "clutter" in spec else 0
    lengths = {
        "cells": rows * pitch,
        "front_clearance": spec["front_clearance"][1],
        "rear_clearance": spec["rear_clearance"][1],
    }
    walls = 4 * (
        1 + rows * blocks + 2 * blocks * spec["cells"][1] + clutter + 3
    )  # bulkheads, galleys, trolley
    check_cabin_size(check, (f"configurations[{widest}].width", widths[widest]), lengths, walls)


class _Draw:
    """Uniform draws from one generator, rounded to the millimetre (the same on every machine)."""

    def __init__(self, rng: np.random.Generator):
        self.rng = rng

    def uniform(self, bounds) -> float:
        return round(float(self.rng.uniform(bounds[0], bounds[1])), 3)

    def integer(self, bounds) -> int:
        return int(self.rng.integers(bounds[0], bounds[1] + 1))

    def chance(self, probability: float) -> bool:
        return bool(self.rng.random() < probability)


def draw_spec(family: Family, index: int, attempt: int) -> dict:
    """The ``cabin`` layout spec of draw ``attempt`` for ``index`` (before validation), for the
    default robot."""
    spec, robot = family.spec, RobotSpec()
    draw = _Draw(np.random.default_rng([spec["seed"], index, attempt]))
    configuration = spec["configurations"][int(draw.rng.integers(len(spec["configurations"])))]
    seats = list(configuration["seats"])
    width = draw.uniform(configuration["width"])
    aisles = [draw.uniform(spec["aisle_width"]) for _ in seats[1:]]
    pitch, depth = draw.uniform(spec["seat_pitch"]), draw.uniform(spec["seat_depth"])
    depth = min(depth, round(pitch - MIN_GAP, 3))  # legroom the robot fits
    rows_per_cell = draw.integer(spec["rows_per_cell"])
    rows = rows_per_cell * draw.integer(spec["cells"])
    front, rear = draw.uniform(spec["front_clearance"]), draw.uniform(spec["rear_clearance"])
    exit_rows, exit_pitch = [], pitch
    if "exit_rows" in spec:
        exit_rows = [row for row in range(rows) if draw.chance(spec["exit_rows"]["probability"])]
        exit_pitch = round(pitch + draw.uniform(spec["exit_rows"]["extra_pitch"]), 3)
    pitches = np.where(np.isin(np.arange(rows), exit_rows), exit_pitch, pitch)
    slot_starts = front + np.concatenate([[0.0], np.cumsum(pitches)])
    length = round(float(slot_starts[-1]) + rear, 3)

    block_widths = np.array(seats) * (width - sum(aisles)) / sum(seats)
    edges = np.concatenate([[0.0], np.cumsum(np.ravel(np.column_stack([block_widths, [*aisles, 0.0]])))])
    blocks = [(edges[2 * i], edges[2 * i + 1]) for i in range(len(seats))]  # y spans, port to starboard
    aisle_spans = [(edges[2 * i + 1], edges[2 * i + 2]) for i in range(len(aisles))]
    start_y = sum(aisle_spans[0]) / 2 if aisle_spans else width / 2
    start = (front / 2, start_y)

    obstacles: list[list[float]] = []
    if "galleys" in spec:
        obstacles += _draw_galleys(draw, spec["galleys"], front, rear, length, width)
    if "bulkheads" in spec:
        cell_firsts = range(rows_per_cell, rows, rows_per_cell)
        obstacles += _draw_bulkheads(
            draw, spec["bulkheads"], cell_firsts, pitches, depth, slot_starts, blocks
        )
    if "clutter" in spec:
        cabin_ends = [(0.0, front), (length - rear, length)]
        obstacles += _draw_clutter(
            draw, spec["clutter"], aisle_spans, slot_starts, depth, cabin_ends, width, start, robot
        )
        obstacles += _draw_trolley(draw, spec["clutter"]["trolley"], aisle_spans, length, rear)

    cabin = {
        "width": width,
        "seat_blocks": seats,
        "aisle_width": aisles,
        "rows": rows,
        "seat_pitch": pitch,
        "seat_depth": depth,
        "rows_per_cell": rows_per_cell,
        "front_clearance": front,
        "rear_clearance": rear,
    }
    if exit_rows:
        cabin |= {"exit_rows": exit_rows, "exit_row_pitch": exit_pitch}
    if obstacles:
        cabin["obstacles"] = [[round(float(v), 3) for v in rect] for rect in obstacles]
    configuration_name = "-".join(map(str, seats))
    return {
        "kind": "cabin",
        "description": (
            f"Generated {configuration_name} cabin: {rows} rows in {rows // rows_per_cell} cells, "
            f"{len(exit_rows)} exit rows, {len(obstacles)} extra obstacles "
            f"(family {family.name}, index {index})."
        ),
        "source": f"{family.path} index {index} draw {attempt}",
        "cabin": cabin,
    }


def _draw_galleys(draw: _Draw, galleys: dict, front: float, rear: float, length: float, width: float) -> list:
    """A galley or lavatory block against a side wall in each end zone, by chance; none too shallow to
    matter (5 cm), and each leaves ``MIN_GAP`` of its zone free."""
    obstacles = []
    for x_lo, zone in ((0.0, front), (length - rear, rear)):
        if draw.chance(galleys["probability"]):
            galley_depth = min(draw.uniform(galleys["depth"]), zone - MIN_GAP)
            galley_width = draw.uniform(galleys["width"])
            at_port = draw.chance(0.5)
            y_lo = 0.0 if at_port else width - galley_width
            x0 = x_lo if x_lo == 0.0 else length - galley_depth
            if galley_depth > 0.05:
                obstacles.append([x0, y_lo, x0 + galley_depth, y_lo + galley_width])
    return obstacles


def _draw_bulkheads(draw: _Draw, bulkheads: dict, cell_firsts, pitches, depth, slot_starts, blocks) -> list:
    """By chance, a wall across every seat block in front of the first row of each cell but the
    first (``cell_firsts``), where it leaves that row ``MIN_GAP`` of legroom."""
    obstacles = []
    thickness = bulkheads["thickness"]
    for first_row in cell_firsts:
        room = pitches[first_row] - depth - thickness
        if draw.chance(bulkheads["probability"]) and room >= MIN_GAP:
            x0 = float(slot_starts[first_row])
            obstacles += [[x0, lo, x0 + thickness, hi] for lo, hi in blocks]
    return obstacles


def _draw_clutter(
    draw: _Draw, clutter: dict, aisle_spans, slot_starts, depth, cabin_ends, width, start, robot
):
    """Bags and dropped items, each where :func:`_place_clutter` finds room for it."""
    obstacles = []
    for piece_size, count in ((BAG, draw.integer(clutter["bags"])), (ITEM, draw.integer(clutter["items"]))):
        for _ in range(count):
            piece = _place_clutter(
                draw, piece_size, aisle_spans, slot_starts, depth, cabin_ends, width, start, robot
            )
            if piece is not None:
                obstacles.append(piece)
    return obstacles


def _draw_trolley(draw: _Draw, probability: float, aisle_spans, length: float, rear: float) -> list:
    """By chance, a service trolley parked in an aisle at the rear galley, where the rear zone has
    room for it and a way past."""
    if draw.chance(probability) and rear >= TROLLEY[0] + MIN_GAP + 0.02 and aisle_spans:
        lo, hi = aisle_spans[int(draw.rng.integers(len(aisle_spans)))]
        y0 = round((lo + hi - TROLLEY[1]) / 2, 3)
        x1 = round(length - 0.02, 3)
        return [[round(x1 - TROLLEY[0], 3), y0, x1, round(y0 + TROLLEY[1], 3)]]
    return []


def _place_clutter(draw, size, aisle_spans, slot_starts, depth, zones, width, start, robot):
    """A rectangle for one piece of clutter: against the aisle side of a seat block (within the
    block's length, so no legroom gap is crossed, and leaving the robot room to pass), or, when
    the aisle has no room, against the end wall of a free zone at a cabin end, clear of the
    start; None when neither has room."""
    along, across = size
    if aisle_spans and draw.chance(0.7):
        aisle = int(draw.rng.integers(len(aisle_spans)))
        lo, hi = aisle_spans[aisle]
        room = (hi - lo) - MIN_GAP
        protrusion = min(across, room / 2)  # two pieces side by side still leave the room
        if protrusion >= 0.02:
            row = int(draw.rng.integers(len(slot_starts) - 1))
            seat_x0 = float(slot_starts[row + 1]) - depth
            length = min(along, depth)
            x0 = seat_x0 + draw.uniform([0.0, depth - length])
            if draw.chance(0.5):  # against the port-side block, protruding into the aisle
                return [x0, lo, x0 + length, lo + protrusion]
            return [x0, hi - protrusion, x0 + length, hi]
    zone_lo, zone_hi = zones[int(draw.rng.integers(len(zones)))]
    if zone_hi - zone_lo - along < MIN_GAP + 0.05:
        return None  # the zone is too shallow: a piece there would cut it
    x0 = zone_lo if zone_lo == 0.0 else zone_hi - along  # against the end wall, off the way through
    y0 = draw.uniform([0.0, width - across])
    if math.hypot(x0 + along / 2 - start[0], y0 + across / 2 - start[1]) < robot.tool_width + 0.3:
        y0 = 0.0 if start[1] > width / 2 else width - across  # off the start, in the corner
    return [x0, y0, x0 + along, y0 + across]


def _reachable_everywhere(layout: Layout) -> bool:
    """Every pose the robot fits in is reachable from the start (no floor cut off by clutter)."""
    feasible = layout.clearance >= layout.robot.radius + CONTACT_CLEARANCE
    return int(feasible.sum()) == int(layout.centre_free.sum())


def generate(family: Family | str | Path, index: int, name: str | None = None) -> Layout:
    """The layout number ``index`` of ``family`` (a :class:`Family`, a family name or a path).

    Pure and deterministic (see the module doc); the same (family file, index) is cached in this
    process. ``name`` names the layout (default ``<family>#<index>``); it is not part of its hash.
    """
    if not isinstance(family, Family):
        family = load_family(family)
    if isinstance(index, bool) or not isinstance(index, (int, np.integer)) or index < 0:
        raise ValueError(f"a family index is a whole number >= 0, got {index!r}")
    return _generate(family, int(index), name or f"{family.name}#{index}")


@lru_cache(maxsize=256)
def _generate(family: Family, index: int, name: str) -> Layout:
    problems = []
    for attempt in range(MAX_ATTEMPTS):
        spec = draw_spec(family, index, attempt)
        try:
            layout = build_layout(spec, spec["source"], name, text="")
        except LayoutError as error:
            problems.append(f"{error.field_name}: {error.problem}")
            continue
        if not _reachable_everywhere(layout):
            problems.append("clutter cuts off floor")
            continue
        layout.max_steps = 100 * math.ceil(family.spec["steps_per_m2"] * layout.coverable_area / 100)
        layout.content_hash = geometry_hash(layout)
        return layout
    raise LayoutError(
        family.path,
        "<family>",
        f"index {index}: no valid layout in {MAX_ATTEMPTS} draws (last: {problems[-1]})",
        "widen the ranges that fail (legroom = seat_pitch - seat_depth must fit the robot)",
    )
