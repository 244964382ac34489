"""List the layouts: ``python -m cabinbench.layouts [--json]``; write one as a ROS map:
``python -m cabinbench.layouts export LAYOUT OUT_DIR``.

Built-in layouts come from the package's ``layouts/`` folder; folders named in the
``CABINBENCH_LAYOUT_PATH`` environment variable (``:``-separated) add or shadow layouts by file
name. A file that does not load, or a folder in the variable that does not exist, is reported in
one line on stderr; every other layout is still listed, and the exit status is then 2.

``export`` writes ``OUT_DIR/<name>.yaml`` and ``OUT_DIR/<name>.pgm`` in ROS map_server's format
(:func:`cabinbench.layouts.rosmap.write_map`): the layout's floor at 1 cm (an occupancy map's at its own
resolution; ``--resolution`` to choose), so ROS tools see the same floor;
loading the pair back gives the same coverable area within 1% (tests/test_occupancy.py). Cells,
goals and the start are not part of a ROS map and are not written.
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

from cabinbench.cli import ArgumentParser, output_folder, positive_number, user_errors
from cabinbench.errors import EXIT_USAGE, LayoutError, UsageError
from cabinbench.layouts.complexity import layout_summary
from cabinbench.layouts.load import available_layouts, layout_search_path
from cabinbench.layouts.model import LAYOUT_PATH_VARIABLE
from cabinbench.layouts.resolve import load_layout
from cabinbench.layouts.rosmap import write_map
from cabinbench.memory import too_much_memory

# 1 cm: a polygon layout's walls move at most half a centimetre onto the pixel edges, which keeps its
# coverable area within 1% (at 5 cm a legroom gap can lose the robot's width)
EXPORT_RESOLUTION = 0.01
EXPORT_BYTES_PER_PIXEL = (
    41  # peak memory of an export, measured: the pixel centres' coordinates and the tests
)
COLUMNS = (  # title, width, the row's field and its number format
    ("name", 20, "name", ""),
    ("kind", 9, "kind", ""),
    ("size (m)", 12, "size", ""),
    ("cells", 5, "cells", ""),
    ("goals", 5, "goals", ""),
    ("free m²", 8, "free_area_m2", ".2f"),
    ("coverable m²", 12, "coverable_area_m2", ".2f"),
    ("complexity", 10, "complexity_total", ".4f"),
    ("normalized", 10, "complexity_normalized", ".4f"),
)


def table(rows: list[dict]) -> str:
    def cell(row: dict, width: int, field: str, number_format: str) -> str:
        if field == "size":
            return f"{row['size_m'][0]:.2f}x{row['size_m'][1]:.2f}".rjust(width)
        return f"{row[field]:{'<' if field in ('name', 'kind') else '>'}{width}{number_format}}"

    header = " ".join(
        f"{title:{'<' if i < 2 else '>'}{width}}" for i, (title, width, *_) in enumerate(COLUMNS)
    )
    lines = [header, "-" * len(header)]
    lines += [" ".join(cell(row, width, field, fmt) for _, width, field, fmt in COLUMNS) for row in rows]
    return "\n".join(lines)


def export_map(name: str, folder: Path, resolution: float | None) -> int:
    """Write the layout ``name`` as a ROS map into ``folder``, its raster's memory checked first."""
    layout = load_layout(name)
    resolution = resolution or (
        layout.raster.map_resolution if layout.raster is not None else EXPORT_RESOLUTION
    )
    xmin, ymin, xmax, ymax = layout.extent
    pixels = math.ceil((xmax - xmin) / resolution) * math.ceil((ymax - ymin) / resolution)
    problem = too_much_memory(pixels * EXPORT_BYTES_PER_PIXEL)
    if problem:
        raise UsageError(
            f"--resolution {resolution:g}: {layout.name} ({xmax - xmin:.1f} x {ymax - ymin:.1f} m) at "
            f"{resolution:g} m a pixel is {pixels:,} px and {problem}; give a coarser --resolution "
            f"(the default is {EXPORT_RESOLUTION})"
        )
    for path in write_map(folder, layout.name, layout.floor_at(resolution), resolution, layout.origin):
        print(path)
    return 0


@user_errors
def main(argv: list[str] | None = None) -> int:
    parser = ArgumentParser(
        prog="python -m cabinbench.layouts", description="List the available layouts, or export one."
    )
    parser.add_argument("--json", action="store_true", help="print a JSON list")
    commands = parser.add_subparsers(dest="command", parser_class=ArgumentParser)
    export = commands.add_parser("export", help="write a layout as a ROS map (OUT_DIR/<name>.yaml + .pgm)")
    export.add_argument("layout", help="a layout name or a path to a layout file")
    export.add_argument("out_dir", type=output_folder, help="folder to write into (created if missing)")
    export.add_argument(
        "--resolution",
        type=positive_number,
        help=f"metres per pixel (default: a map's own; {EXPORT_RESOLUTION} for other layouts)",
    )
    args = parser.parse_args(argv)
    if args.command == "export":
        return export_map(args.layout, args.out_dir, args.resolution)
    problems = [
        f"error: {LAYOUT_PATH_VARIABLE} names {folder}, which is not a folder: fix or remove that entry"
        for folder in layout_search_path()
        if not folder.is_dir()
    ]
    rows = []
    for path in available_layouts().values():
        try:
            rows.append(layout_summary(load_layout(path)))
        except LayoutError as error:
            problems.append(f"error: {error}")
    print(json.dumps(rows, indent=1) if args.json else table(rows))
    for problem in problems:
        print(problem, file=sys.stderr)
    return EXIT_USAGE if problems else 0
