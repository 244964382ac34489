"""Layout kind ``cabin``: parametric seat rows across a rectangular cabin floor (see :func:`build_cabin`)."""

from __future__ import annotations

import numpy as np

from .layout_fields import Cell, FieldChecker, KindGeometry, LayoutKind, RobotSpec, rectangle

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
}


def build_cabin(check: FieldChecker, block, robot: RobotSpec) -> KindGeometry:
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
    check.known_keys(block, CABIN_KEYS, "cabin.")
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
        obstacles += [rectangle(seat_start, lo, seat_start + depth, hi) for lo, hi in block_spans]
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
    return KindGeometry(rectangle(0.0, 0.0, length, width), obstacles, cells, start)


CABIN = LayoutKind("cabin", build_cabin, derives_cells="remove 'cells' and set cabin.rows_per_cell")
