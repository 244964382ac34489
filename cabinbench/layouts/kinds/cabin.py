"""Layout kind ``cabin``: parametric seat rows across a rectangular cabin floor (see :func:`build_cabin`)."""

from __future__ import annotations

import numpy as np

from cabinbench.layouts.fields import Cell, FieldChecker, KindGeometry, LayoutKind, RobotSpec, rectangle
from cabinbench.layouts.sizes import check_layout_size
from cabinbench.values import is_whole_number

CABIN_KEYS = {
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
    "exit_rows",
    "exit_row_pitch",
    "obstacles",
}


def build_cabin(check: FieldChecker, block, robot: RobotSpec) -> KindGeometry:
    """Seat rows across a rectangular cabin floor.

    Along x: a free ``front_clearance`` zone, then ``rows`` pitch slots, each a legroom gap of
    ``seat_pitch - seat_depth`` followed by the seat block (depth ``seat_depth``), then a free
    ``rear_clearance`` zone. The rows listed in ``exit_rows`` (0 = the front row) have the pitch
    ``exit_row_pitch`` instead: the extra legroom of an emergency-exit row. Across y: seat blocks
    attached to the side walls, separated by aisles (``aisle_width``: one width, or one per aisle);
    ``seat_blocks`` gives the seats per block (port to starboard) and the blocks share the width
    left by the aisles in proportion to their seats, unless ``block_widths`` fixes them.
    ``obstacles`` adds rectangles ``[xmin, ymin, xmax, ymax]`` inside the cabin: galleys,
    lavatories, bulkheads, bags, a trolley. Cells group ``rows_per_cell`` rows; their goals are
    the wall-side dead ends of each legroom gap in the cell (the study's white cubes) and the
    middle of gaps between two aisles.
    """
    block = check.mapping(block, "cabin")
    check.known_keys(block, CABIN_KEYS, "cabin.")
    for required in ("width", "seat_blocks", "aisle_width", "rows", "seat_pitch", "seat_depth"):
        if required not in block:
            check.fail(f"cabin.{required}", "missing", f"add cabin.{required} (see layouts/a320_cell.yaml)")
    width = check.number(block["width"], "cabin.width")
    seats = block["seat_blocks"]
    if not isinstance(seats, list) or not seats or not all(is_whole_number(s) and s > 0 for s in seats):
        check.fail(
            "cabin.seat_blocks",
            f"expected a list of seat counts, got {seats!r}",
            "write e.g. [3, 3] or [3, 4, 3]",
        )
    aisles = _aisle_widths(check, block["aisle_width"], len(seats) - 1)
    rows = check.positive_int(block["rows"], "cabin.rows")
    pitch = check.number(block["seat_pitch"], "cabin.seat_pitch")
    depth = check.number(block["seat_depth"], "cabin.seat_depth")
    exit_rows, exit_pitch = _exit_rows(check, block, rows, pitch)
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
    widths = _block_widths(check, block, seats, width - sum(aisles), width)
    lengths = {  # metres along the cabin, by the field that makes them
        "cabin.rows": rows * pitch,
        "cabin.exit_row_pitch": len(set(exit_rows)) * (exit_pitch - pitch),
        "cabin.front_clearance": front,
        "cabin.rear_clearance": rear,
    }
    extra_obstacles = block.get("obstacles", [])
    walls = 4 * (1 + rows * len(seats) + (len(extra_obstacles) if isinstance(extra_obstacles, list) else 0))
    check_cabin_size(check, ("cabin.width", width), lengths, walls)
    pitches = np.full(rows, pitch)
    if exit_rows:
        pitches[exit_rows] = exit_pitch
    return _cabin_floor(
        check, block, robot, (width, widths, aisles), (pitches, pitch, depth, front, rear), rows_per_cell
    )


def check_cabin_size(check: FieldChecker, width: tuple[str, float], lengths: dict[str, float], walls: int):
    """Refuse a cabin too large to load (:func:`~cabinbench.layouts.sizes.check_layout_size`), naming
    the field of the largest of its ``width`` and the ``lengths`` that add up to its length (each
    keyed by the field that makes it)."""
    length = sum(lengths.values())
    field_name, _ = max([width, *lengths.items()], key=lambda item: item[1])
    check_layout_size(
        check,
        field_name,
        f"a {length:,.1f} x {width[1]:,.1f} m cabin",
        f"make {field_name} smaller: a layout is one cabin, or a few cells of it",
        length,
        width[1],
        walls,
    )


def _cabin_floor(
    check: FieldChecker,
    block: dict,
    robot: RobotSpec,
    across: tuple[float, list[float], list[float]],
    along: tuple[np.ndarray, float, float, float, float],
    rows_per_cell: int,
) -> KindGeometry:
    """The cabin's floor, seats, extra obstacles, cells and start from its checked fields (see
    :func:`build_cabin`): ``across`` y the width, the seat blocks' widths and the aisles' (which
    alternate with the blocks); ``along`` x every row's pitch, ``seat_pitch``, ``seat_depth`` and
    the front and rear clearances."""
    width, widths, aisles = across
    pitches, pitch, depth, front, rear = along
    rows = len(pitches)
    # Row r spans [slot_starts[r], slot_starts[r + 1]). Written as front + r * pitch plus the exit
    # rows' extra legroom before r (not a cumulative sum), so a cabin without exit rows has the
    # very same floating-point geometry as before exit rows existed.
    extra = np.concatenate([[0.0], np.cumsum(pitches - pitch)])
    slot_starts = [front + row * pitch + extra[row] for row in range(rows + 1)]
    length = float(slot_starts[-1]) + rear
    block_spans, aisle_spans, y = [], [], 0.0
    for index, block_width in enumerate(widths):
        block_spans.append((y, y + block_width))
        y += block_width
        if index < len(widths) - 1:
            aisle_spans.append((y, y + aisles[index]))
            y += aisles[index]
    obstacles = []
    for row in range(rows):
        seat_start = slot_starts[row] + (pitches[row] - depth)
        obstacles += [rectangle(seat_start, lo, seat_start + depth, hi) for lo, hi in block_spans]
    obstacles += _extra_obstacles(check, block.get("obstacles", []), length, width)
    inset = robot.radius + 0.02  # goal cubes sit where the robot centre can just reach
    cells = _row_cells(slot_starts, pitches, depth, block_spans, rows_per_cell, length, width, inset)
    start_x = front / 2 if front >= 2 * robot.radius else front + (pitches[0] - depth) / 2
    start = (start_x, sum(aisle_spans[0]) / 2 if aisle_spans else width / 2, 0.0)
    return KindGeometry(rectangle(0.0, 0.0, length, width), obstacles, cells, start)


def _row_cells(slot_starts, pitches, depth, block_spans, rows_per_cell, length, width, inset) -> list[Cell]:
    """Cells of ``rows_per_cell`` rows across the whole width, each with its goals: the wall-side
    dead ends of its legroom gaps (``inset`` from the wall) and the middle of gaps between aisles."""
    rows, cells = len(pitches), []
    for cell_index in range(rows // rows_per_cell):
        first_row = cell_index * rows_per_cell
        xmin = 0.0 if cell_index == 0 else float(slot_starts[first_row])
        xmax = length if first_row + rows_per_cell == rows else float(slot_starts[first_row + rows_per_cell])
        goals = []
        for row in range(first_row, first_row + rows_per_cell):
            gap_x = slot_starts[row] + (pitches[row] - depth) / 2
            for index, (lo, hi) in enumerate(block_spans):
                if index == 0:
                    goals.append((gap_x, lo + inset))
                elif index == len(block_spans) - 1:
                    goals.append((gap_x, hi - inset))
                else:
                    goals.append((gap_x, (lo + hi) / 2))
        cells.append(Cell(f"cell_{cell_index}", (xmin, 0.0, xmax, width), np.array(goals, dtype=float)))
    return cells


def _block_widths(check: FieldChecker, block: dict, seats: list, seats_width: float, width: float) -> list:
    """The width of each seat block: ``block_widths``, or ``seats_width`` (the width less the aisles)
    shared in proportion to the seats."""
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
    return widths


def _aisle_widths(check: FieldChecker, value, count: int) -> list[float]:
    """One width for every aisle, or a list with one per aisle (port to starboard)."""
    if not isinstance(value, list):
        return [check.number(value, "cabin.aisle_width")] * count
    if len(value) != count:
        check.fail(
            "cabin.aisle_width", f"{len(value)} widths for {count} aisles", "give one width, or one per aisle"
        )
    return [check.number(w, f"cabin.aisle_width[{i}]") for i, w in enumerate(value)]


def _exit_rows(check: FieldChecker, block: dict, rows: int, pitch: float) -> tuple[list[int], float]:
    """The ``exit_rows`` and their pitch ``exit_row_pitch`` (``seat_pitch`` when there are none)."""
    exit_rows = block.get("exit_rows", [])
    if not isinstance(exit_rows, list) or not all(is_whole_number(r) and 0 <= r < rows for r in exit_rows):
        check.fail(
            "cabin.exit_rows", f"expected row numbers 0 to {rows - 1}, got {exit_rows!r}", "fix the list"
        )
    if not exit_rows:
        return exit_rows, pitch
    if "exit_row_pitch" not in block:
        check.fail("cabin.exit_row_pitch", "missing", "give the exit rows' pitch in metres")
    exit_pitch = check.number(block["exit_row_pitch"], "cabin.exit_row_pitch")
    if exit_pitch < pitch:
        check.fail(
            "cabin.exit_row_pitch",
            f"{exit_pitch} is less than seat_pitch {pitch}",
            "exit rows have extra legroom: make it at least seat_pitch",
        )
    return exit_rows, exit_pitch


def _extra_obstacles(check: FieldChecker, value, length: float, width: float) -> list[np.ndarray]:
    """Rectangles ``[xmin, ymin, xmax, ymax]`` that lie inside the cabin floor."""
    if not isinstance(value, list):
        check.fail(
            "cabin.obstacles", f"expected a list, got {value!r}", "write [[xmin, ymin, xmax, ymax], ...]"
        )
    rectangles = []
    for index, item in enumerate(value):
        xmin, ymin, xmax, ymax = check.rect(item, f"cabin.obstacles[{index}]")
        if xmin < 0 or ymin < 0 or xmax > length + 1e-9 or ymax > width + 1e-9:
            check.fail(
                f"cabin.obstacles[{index}]",
                f"{item} reaches outside the cabin (0, 0, {length:.3f}, {width:.3f})",
                "keep obstacles inside the cabin",
            )
        rectangles.append(rectangle(xmin, ymin, xmax, ymax))
    return rectangles


CABIN = LayoutKind("cabin", build_cabin, derives_cells="remove 'cells' and set cabin.rows_per_cell")
