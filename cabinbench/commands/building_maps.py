"""Redraw the three building maps the project ships as ROS map files
(:mod:`cabinbench.layouts.building_maps`).

    python -m cabinbench.building_maps [OUT_DIR]
"""

from __future__ import annotations

from cabinbench.cli import ArgumentParser, output_folder, user_errors
from cabinbench.layouts.building_maps import BUILDINGS, write_building


@user_errors
def main(argv: list[str] | None = None) -> int:
    parser = ArgumentParser(prog="python -m cabinbench.building_maps", description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "out",
        nargs="?",
        type=output_folder,
        default="layouts",
        help="the folder to write them to (default: layouts)",
    )
    folder = parser.parse_args(argv).out
    for name, (draw, description) in BUILDINGS.items():
        print(write_building(folder, name, draw(), description))
    return 0
