"""Layout kind ``cabin``: parametric seat rows across a rectangular cabin floor (see :func:`build_cabin`)."""

from __future__ import annotations

import numpy as np

from cabinbench.layouts.fields import Cell, FieldChecker, KindGeometry, LayoutKind, RobotSpec, rectangle
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
    the wall-side dead ends of each legroom gap in the cell (the seed's white cubes) and the
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
    pitches = _row_pitches(check, block, rows, pitch)
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
    seats_width = width - sum(aisles)
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
    obstacles, cells = [], []
    for row in range(rows):
        seat_start = slot_starts[row] + (pitches[row] - depth)
        obstacles += [rectangle(seat_start, lo, seat_start + depth, hi) for lo, hi in block_spans]
    obstacles += _extra_obstacles(check, block.get("obstacles", []), length, width)
    inset = robot.radius + 0.02  # goal cubes sit where the robot centre can just reach
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
    start_x = front / 2 if front >= 2 * robot.radius else front + (pitches[0] - depth) / 2
    start = (start_x, sum(aisle_spans[0]) / 2 if aisle_spans else width / 2, 0.0)
    return KindGeometry(rectangle(0.0, 0.0, length, width), obstacles, cells, start)


def _aisle_widths(check: FieldChecker, value, count: int) -> list[float]:
    """One width for every aisle, or a list with one per aisle (port to starboard)."""
    if not isinstance(value, list):
        return [check.number(value, "cabin.aisle_width")] * count
    if len(value) != count:
        check.fail(
            "cabin.aisle_width", f"{len(value)} widths for {count} aisles", "give one width, or one per aisle"
        )
    return [check.number(w, f"cabin.aisle_width[{i}]") for i, w in enumerate(value)]


def _row_pitches(check: FieldChecker, block: dict, rows: int, pitch: float) -> np.ndarray:
    """The pitch of every row: ``seat_pitch``, or ``exit_row_pitch`` for the ``exit_rows``."""
    exit_rows = block.get("exit_rows", [])
    if not isinstance(exit_rows, list) or not all(is_whole_number(r) and 0 <= r < rows for r in exit_rows):
        check.fail(
            "cabin.exit_rows", f"expected row numbers 0 to {rows - 1}, got {exit_rows!r}", "fix the list"
        )
    pitches = np.full(rows, pitch)
    if exit_rows:
        if "exit_row_pitch" not in block:
            check.fail("cabin.exit_row_pitch", "missing", "give the exit rows' pitch in metres")
        exit_pitch = check.number(block["exit_row_pitch"], "cabin.exit_row_pitch")
        if exit_pitch < pitch:
            check.fail(
                "cabin.exit_row_pitch",
                f"{exit_pitch} is less than seat_pitch {pitch}",
                "exit rows have extra legroom: make it at least seat_pitch",
            )
        pitches[exit_rows] = exit_pitch
    return pitches


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
