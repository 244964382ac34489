"""Layout kind ``grid``: an ASCII occupancy map, ``#`` obstacle, ``.`` free, ``S`` the start.

The ``S`` is optional. Without it the robot starts, heading along +x, at the centre of the free
cell nearest the centre of the map on which it fits (its disc clear of every obstacle by
``CONTACT_CLEARANCE``); of cells equally near, the first in reading order (top row first, left to
right).
"""

from __future__ import annotations

import re

import numpy as np

from cabinbench.geometry import distances_to_segments
from cabinbench.layouts.fields import (
    CONTACT_CLEARANCE,
    FieldChecker,
    KindGeometry,
    LayoutKind,
    RobotSpec,
    rectangle,
)
from cabinbench.layouts.sizes import check_layout_size


def build_grid(check: FieldChecker, block, robot: RobotSpec) -> KindGeometry:
    """Each ``#`` a square obstacle of ``cell_size``; the first text line is the top row."""
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
    if text.count("S") > 1:
        check.fail("grid.map", f"{text.count('S')} start cells 'S'", "mark at most one start with 'S'")
    rows, cols = len(lines), len(lines[0])
    check_layout_size(
        check,
        "grid.map",
        f"a {rows} x {cols} map of {cell_size:g} m cells",
        "use fewer rows and columns, or a smaller cell_size",
        cols * cell_size,
        rows * cell_size,
        walls=4 * (1 + len(re.findall("#+", text))),  # a run of '#' in a row is one rectangle
        map_pixels=rows * cols,
    )
    obstacles, start = [], None
    for text_row, line in enumerate(lines):
        y0 = (rows - 1 - text_row) * cell_size
        col = 0
        while col < cols:  # merge runs of '#' into one rectangle: fewer edges for the lidar
            if line[col] == "#":
                end = col
                while end < cols and line[end] == "#":
                    end += 1
                obstacles.append(rectangle(col * cell_size, y0, end * cell_size, y0 + cell_size))
                col = end
            else:
                if line[col] == "S":
                    start = ((col + 0.5) * cell_size, y0 + 0.5 * cell_size, 0.0)
                col += 1
    if len(obstacles) and sum(line.count("#") for line in lines) == rows * cols:
        check.fail("grid.map", "no free cell", "mark free floor with '.'")
    boundary = rectangle(0.0, 0.0, cols * cell_size, rows * cell_size)
    if start is None:
        start = central_start(check, lines, cell_size, [boundary, *obstacles], robot)
    written = np.array([[mark == "#" for mark in line] for line in reversed(lines)], dtype=bool)
    return KindGeometry(boundary, obstacles, start=start, written_map=written)


def central_start(
    check: FieldChecker, lines: list[str], cell_size: float, rings: list[np.ndarray], robot: RobotSpec
) -> tuple[float, float, float]:
    """The start of a map without ``S`` (see the module doc)."""
    rows, cols = len(lines), len(lines[0])
    walls = np.concatenate([np.hstack([ring, np.roll(ring, -1, axis=0)]) for ring in rings])
    free = [
        (text_row, col) for text_row, line in enumerate(lines) for col, mark in enumerate(line) if mark != "#"
    ]
    # squared distance from the map centre in half cells: whole numbers, so equal distances tie exactly
    for text_row, col in sorted(
        free, key=lambda cell: ((2 * cell[0] + 1 - rows) ** 2 + (2 * cell[1] + 1 - cols) ** 2, cell)
    ):
        centre = np.array([(col + 0.5) * cell_size, (rows - 0.5 - text_row) * cell_size])
        if (
            distances_to_segments(centre, walls[:, :2], walls[:, 2:]).min()
            >= robot.radius + CONTACT_CLEARANCE
        ):
            return float(centre[0]), float(centre[1]), 0.0
    check.fail(
        "grid.map",
        f"no free cell holds the robot (diameter {robot.tool_width} m)",
        "widen the free floor, or use a smaller robot",
    )


GRID = LayoutKind("grid", build_grid)
