"""Navigation complexity of a layout (the study's §4.1, :mod:`cabinbench.layouts.complexity`).

    python -m cabinbench.complexity LAYOUT [--json] [--png FILE]

``--json`` prints ``layout``, ``grid`` ([rows, cols]), ``total``, ``normalized`` and ``map``: the
robot-cell map, one string per row, top row first, ``#`` obstacle and ``.`` free.
"""

from __future__ import annotations

import json

from cabinbench.cli import ArgumentParser, output_file, user_errors
from cabinbench.layouts.complexity import layout_complexity, map_rows, save_complexity_png
from cabinbench.layouts.resolve import load_layout


@user_errors
def main(argv: list[str] | None = None) -> int:
    parser = ArgumentParser(prog="python -m cabinbench.complexity", description=__doc__.split("\n\n")[0])
    parser.add_argument("layout", help="layout name or YAML path")
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    parser.add_argument(
        "--png", metavar="FILE", type=output_file(".png"), help="draw the complexity map to FILE"
    )
    args = parser.parse_args(argv)
    layout = load_layout(args.layout)
    result = layout_complexity(layout)
    summary = {
        "layout": layout.name,
        "grid": list(result.cell_map.shape),
        "total": round(result.total, 4),
        "normalized": round(result.normalized, 4),
        "map": map_rows(result.occupancy),
    }
    if args.png:
        save_complexity_png(result, args.png, layout.name)
        summary["png"] = str(args.png)
    if args.json:
        print(json.dumps(summary))
    else:
        rows, cols = result.cell_map.shape
        print(
            f"{layout.name}: {rows}x{cols} robot cells, "
            f"total {result.total:.4f}, normalized {result.normalized:.4f}"
        )
    return 0
