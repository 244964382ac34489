"""The building maps the project draws itself, as ROS map files: ``python -m cabinbench.building_maps
[OUT_DIR]`` writes ``office_floor``, ``mall_corridor`` and ``meeting_area`` (default: ``layouts/``).

No third-party map is shipped (the licences of published SLAM maps are unclear or restrictive):
these are drawn here, deterministically, in the grey values ROS's map_saver writes (254 free,
0 occupied, 205 unknown), at 5 cm a pixel. :func:`office_floor` also draws floors of any size
(the bench's 50 m x 40 m and 100 m x 100 m maps).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import yaml
from PIL import Image

from cabinbench.layouts.fields import RESOLUTION
from cabinbench.layouts.rosmap import DEFAULT_FREE_THRESH, DEFAULT_OCCUPIED_THRESH, SAVED_FREE, SAVED_OCCUPIED

UNKNOWN_GREY = 205
WALL = 0.15  # m, interior wall thickness
MAX_STEPS = 30000  # the boustrophedon plan of meeting_area takes about 20,000 steps


class Floor:
    """A map being drawn, in metres from its lower-left corner (the image's top row is the far edge)."""

    def __init__(self, width: float, height: float):
        self.pixels = np.full((round(height / RESOLUTION), round(width / RESOLUTION)), SAVED_FREE, np.uint8)

    def _fill(self, x0: float, y0: float, x1: float, y1: float, grey: int):
        rows = self.pixels.shape[0]
        c0, c1 = round(min(x0, x1) / RESOLUTION), round(max(x0, x1) / RESOLUTION)
        r0, r1 = round(min(y0, y1) / RESOLUTION), round(max(y0, y1) / RESOLUTION)
        self.pixels[max(0, rows - r1) : max(0, rows - r0), max(0, c0) : max(0, c1)] = grey

    def box(self, x0: float, y0: float, x1: float, y1: float):
        """A solid obstacle (a wall, a desk, a pillar)."""
        self._fill(x0, y0, x1, y1, SAVED_OCCUPIED)

    def clear(self, x0: float, y0: float, x1: float, y1: float):
        """Free floor (a doorway)."""
        self._fill(x0, y0, x1, y1, SAVED_FREE)

    def unknown(self, x0: float, y0: float, x1: float, y1: float):
        """Space the robot never saw (outside the building)."""
        self._fill(x0, y0, x1, y1, UNKNOWN_GREY)

    def disc(self, x: float, y: float, radius: float):
        """A round obstacle (a chair, a round table leg)."""
        rows, cols = self.pixels.shape
        ys = (rows - 1 - np.arange(rows) + 0.5) * RESOLUTION
        xs = (np.arange(cols) + 0.5) * RESOLUTION
        r0, r1 = (
            max(0, int((rows * RESOLUTION - y - radius) / RESOLUTION)),
            int((rows * RESOLUTION - y + radius) / RESOLUTION) + 1,
        )
        c0, c1 = max(0, int((x - radius) / RESOLUTION)), int((x + radius) / RESOLUTION) + 1
        inside = (xs[None, c0:c1] - x) ** 2 + (ys[r0:r1, None] - y) ** 2 <= radius**2
        self.pixels[r0:r1, c0:c1][inside] = SAVED_OCCUPIED

    def outline(self, width: float, height: float, thickness: float = 0.2):
        """The building's outer walls, with a margin of unknown space outside them."""
        self.unknown(0, 0, width, 0.3)
        self.unknown(0, height - 0.3, width, height)
        self.unknown(0, 0, 0.3, height)
        self.unknown(width - 0.3, 0, width, height)
        self.box(0.3, 0.3, width - 0.3, 0.3 + thickness)
        self.box(0.3, height - 0.3 - thickness, width - 0.3, height - 0.3)
        self.box(0.3, 0.3, 0.3 + thickness, height - 0.3)
        self.box(width - 0.3 - thickness, 0.3, width - 0.3, height - 0.3)


def office_floor(width: float = 20.0, height: float = 13.0) -> Floor:
    """Offices of 4 m x 5 m on both sides of 2 m corridors, each with a door, two desks and their
    chairs; a floor of any size repeats the pattern (one corridor every 12 m). A 2 m corridor along
    the east wall joins the corridors, and the floor left over at the top is open-plan."""
    floor = Floor(width, height)
    floor.outline(width, height)
    inner_x0, inner_x1 = 0.5, width - 2.5
    y = 0.5
    while y + 12.0 <= height - 0.5 + 1e-9:
        for row_y0, door_at_top in ((y, True), (y + 7.0, False)):  # rooms below and above the corridor
            row_y1 = row_y0 + 5.0
            floor.box(inner_x0, row_y1 - WALL / 2, inner_x1, row_y1 + WALL / 2)
            floor.box(inner_x0, row_y0 - WALL / 2, inner_x1, row_y0 + WALL / 2)
            x = inner_x0
            while x + 4.0 <= inner_x1 + 1e-9:
                floor.box(x - WALL / 2, row_y0, x + WALL / 2, row_y1)
                door_y = row_y1 if door_at_top else row_y0
                floor.clear(x + 1.2, door_y - WALL, x + 2.2, door_y + WALL)  # 1 m door
                desk_y = row_y0 + 0.6 if door_at_top else row_y1 - 1.4
                for desk_x in (x + 0.4, x + 2.3):
                    floor.box(desk_x, desk_y, desk_x + 1.4, desk_y + 0.8)
                    chair_y = desk_y + 1.2 if door_at_top else desk_y - 0.4
                    floor.disc(desk_x + 0.7, chair_y, 0.25)
                x += 4.0
            floor.box(x - WALL / 2, row_y0, x + WALL / 2, row_y1)  # the last office's east wall
        y += 12.0
    return floor


def mall_corridor(width: float = 24.0, height: float = 12.0) -> Floor:
    """A 5 m wide mall corridor with pillars and benches, shop fronts on both sides opening into
    shallow shops with counters and shelves."""
    floor = Floor(width, height)
    floor.outline(width, height)
    for front_y, back_y in ((3.5, 0.5), (8.5, 11.5)):  # lower and upper row of shops, 3 m deep
        floor.box(0.5, front_y - WALL / 2, width - 0.5, front_y + WALL / 2)
        x = 0.5
        while x + 5.0 <= width - 0.5 + 1e-9:
            floor.box(x - WALL / 2, min(front_y, back_y), x + WALL / 2, max(front_y, back_y))
            floor.clear(x + 1.0, front_y - WALL, x + 4.0, front_y + WALL)  # a 3 m shop front
            depth = 1.0 if back_y > front_y else -1.0
            floor.box(x + 0.5, back_y - depth * 0.9, x + 4.5, back_y - depth * 0.5)  # shelves
            floor.box(x + 3.6, front_y + depth * 0.9, x + 4.2, front_y + depth * 1.6)  # counter
            x += 5.0
        floor.box(x - WALL / 2, min(front_y, back_y), x + WALL / 2, max(front_y, back_y))
    for x in np.arange(3.0, width - 4.0, 6.0):  # pillars on the corridor's axis, benches between
        floor.box(x - 0.25, 5.75, x + 0.25, 6.25)
        floor.box(x + 2.4, 4.8, x + 3.6, 5.2)
        floor.box(x + 2.4, 6.8, x + 3.6, 7.2)
    return floor


def meeting_area(width: float = 16.0, height: float = 12.0) -> Floor:
    """An open meeting area: long tables with chairs along both sides, round tables with chairs
    around them, and a lectern."""
    floor = Floor(width, height)
    floor.outline(width, height)
    for x0 in (2.0, 7.0):  # two rows of long tables
        for y0 in (2.0, 5.5):
            floor.box(x0, y0, x0 + 3.6, y0 + 0.9)
            for chair_x in np.arange(x0 + 0.45, x0 + 3.6, 0.9):
                floor.disc(chair_x, y0 - 0.45, 0.22)
                floor.disc(chair_x, y0 + 1.35, 0.22)
    for cx, cy in ((13.0, 3.5), (13.0, 8.8), (4.0, 9.6), (8.8, 9.6)):  # round tables
        floor.disc(cx, cy, 0.6)
        for angle in np.arange(6) * np.pi / 3:
            floor.disc(cx + 1.05 * np.cos(angle), cy + 1.05 * np.sin(angle), 0.22)
    floor.box(15.0, 5.4, 15.3, 6.6)  # lectern by the wall
    return floor


BUILDINGS = {
    "office_floor": (office_floor, "An office floor: 4 m x 5 m offices with doors, desks and chairs"),
    "mall_corridor": (mall_corridor, "A mall corridor with shop fronts, shops, pillars and benches"),
    "meeting_area": (meeting_area, "A meeting area with long and round tables and their chairs"),
}


def write_building(
    folder: Path, name: str, floor: Floor, description: str = "", max_steps: int = MAX_STEPS
) -> Path:
    """Write ``folder/name.pgm`` and the map YAML ``folder/name.yaml`` (map_server's fields, plus a
    cabinbench description); returns the YAML's path."""
    folder.mkdir(parents=True, exist_ok=True)
    Image.fromarray(floor.pixels, mode="L").save(folder / f"{name}.pgm")
    spec = {
        "image": f"{name}.pgm",
        "resolution": RESOLUTION,
        "origin": [0.0, 0.0, 0.0],
        "negate": 0,
        "occupied_thresh": DEFAULT_OCCUPIED_THRESH,
        "free_thresh": DEFAULT_FREE_THRESH,
    }
    if description:  # a cabinbench occupancy layout: the map's fields in its block
        spec = {
            "kind": "occupancy",
            "description": description,
            "source": "drawn by cabinbench.building_maps",
            "max_steps": max_steps,
            "occupancy": spec,
        }
    path = folder / f"{name}.yaml"
    path.write_text(yaml.safe_dump(spec, sort_keys=False), encoding="utf-8")
    return path
