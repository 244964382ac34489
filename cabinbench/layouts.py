"""List the layouts: ``python -m cabinbench.layouts [--json]``.

Built-in layouts come from the package's ``layouts/`` folder; folders named in the
``CABINBENCH_LAYOUT_PATH`` environment variable (``:``-separated) add or shadow layouts by file
name.
"""

from __future__ import annotations

import argparse
import json

from .complexity import layout_complexity
from .layout import available_layouts, load_layout


def layout_summary(name: str) -> dict:
    layout = load_layout(name)
    complexity = layout_complexity(layout)
    xmin, ymin, xmax, ymax = layout.extent
    return {
        "name": layout.name,
        "kind": layout.kind,
        "size_m": [round(xmax - xmin, 3), round(ymax - ymin, 3)],
        "cells": len(layout.cells),
        "goals": len(layout.goals),
        "free_area_m2": round(layout.free_area, 3),
        "coverable_area_m2": round(layout.coverable_area, 3),
        "complexity_total": round(complexity.total, 4),
        "complexity_normalized": round(complexity.normalized, 4),
        "max_steps": layout.max_steps,
        "file": layout.path,
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m cabinbench.layouts", description="List the available layouts."
    )
    parser.add_argument("--json", action="store_true", help="print a JSON list")
    args = parser.parse_args(argv)
    rows = [layout_summary(name) for name in available_layouts()]
    if args.json:
        print(json.dumps(rows, indent=1))
        return 0
    header = f"{'name':<20} {'kind':<6} {'size (m)':>12} {'cells':>5} {'goals':>5} {'free m²':>8} {'coverable m²':>12} {'complexity':>10} {'normalized':>10}"
    print(header)
    print("-" * len(header))
    for row in rows:
        size = f"{row['size_m'][0]:.2f}x{row['size_m'][1]:.2f}"
        print(
            f"{row['name']:<20} {row['kind']:<6} {size:>12} {row['cells']:>5} {row['goals']:>5} {row['free_area_m2']:>8.2f} "
            f"{row['coverable_area_m2']:>12.2f} {row['complexity_total']:>10.4f} {row['complexity_normalized']:>10.4f}"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
