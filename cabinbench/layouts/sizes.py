"""What loading a layout will cost, estimated from its extent before anything is built.

Every kind (and a family, for the largest cabin it can draw) calls :func:`check_layout_size` as
soon as it knows its floor's extent, before it builds obstacles or allocates a raster, and so
refuses a layout too large for the machine in milliseconds, naming the field that made it large.

Loading measures the floor on the coverage raster (:data:`~cabinbench.layouts.fields.RESOLUTION`)
over the whole extent: the free floor, the clearance, the reachable and coverable pixels, the
cells, the complexity grid, and in an episode the pass counts. Both its memory and its time grow
with that raster's pixels; a polygon floor's clearance also takes time for every wall near each
tile of floor (:meth:`~cabinbench.layouts.model.Layout.distance_to_walls` compares each tile with
every wall, in batches of bounded memory). The rates below were measured (peak RSS by
``resource.getrusage``; load, complexity and a coverage raster) on an idle 2-core machine, and
take up to twice as long when its cores are shared: an empty 300 m square (36 million pixels, 4
walls) in 56 s at 81 bytes a pixel; a cabin of 4,000 rows (4.7 million pixels, 32,004 walls
against 20,000 tiles) in 54 s (cores shared) at 532 MiB; a 200 m occupancy map at 5 cm (16
million pixels) in 18 s at 70 bytes a pixel, and at 1 cm (16 million map pixels, 0.64 million
raster pixels) in 10.5 s at 37 bytes a map pixel.
"""

from __future__ import annotations

import math

from cabinbench.layouts.fields import RESOLUTION, FieldChecker
from cabinbench.layouts.model import WALL_TILE
from cabinbench.memory import too_much_memory

RASTER_BYTES_PER_PIXEL = 200  # peak bytes of loading and running, per coverage-raster pixel
MAP_BYTES_PER_PIXEL = 60  # an occupancy map's own pixels, decoded and cleaned of speckles
WALL_BYTES = 400  # one wall: its obstacle polygon (a NumPy array), its segment, its share of lists
SECONDS_PER_PIXEL = 1.5e-6
SECONDS_PER_MAP_PIXEL = 0.6e-6
SECONDS_PER_TILE_WALL = 6e-8  # one tile of floor compared with one wall
MAX_LOAD_SECONDS = 60  # longer and a layout is refused: a benchmark loads each layout in every run


def raster_pixels(width: float, height: float) -> int:
    """Pixels of the coverage raster over a ``width`` x ``height`` m extent."""
    return _cells(width, RESOLUTION) * _cells(height, RESOLUTION)


def check_layout_size(
    check: FieldChecker,
    field_name: str,
    what: str,
    fix: str,
    width: float,
    height: float,
    walls: int = 0,
    map_pixels: int = 0,
) -> None:
    """Refuse, through ``check`` naming ``field_name``, a floor of ``width`` x ``height`` metres whose
    loading would not fit :func:`~cabinbench.memory.memory_budget` or would take longer than
    :data:`MAX_LOAD_SECONDS`. ``walls``: the polygon walls its clearance is measured against (none
    for a raster map, whose clearance is a distance transform); ``map_pixels``: a raster map's own
    pixels. ``what`` describes the layout in the message ("a 80000 x 3.7 m cabin"); ``fix`` says how
    to make it smaller."""
    pixels = raster_pixels(width, height)
    tiles = _cells(width, WALL_TILE) * _cells(height, WALL_TILE)
    needed = pixels * RASTER_BYTES_PER_PIXEL + map_pixels * MAP_BYTES_PER_PIXEL + walls * WALL_BYTES
    raster = f"{what}, a 5 cm raster of {pixels:.3g} pixels" + (f" against {walls} walls" if walls else "")
    memory = too_much_memory(needed)
    if memory:
        check.fail(field_name, f"{raster} {memory}", fix)
    seconds = (
        pixels * SECONDS_PER_PIXEL
        + map_pixels * SECONDS_PER_MAP_PIXEL
        + tiles * walls * SECONDS_PER_TILE_WALL
    )
    if seconds > MAX_LOAD_SECONDS:
        check.fail(
            field_name,
            f"{raster}, would take about {seconds / 60:,.1f} minutes to load "
            f"(at most {MAX_LOAD_SECONDS} s allowed)",
            fix,
        )


def _cells(length: float, size: float) -> int:
    return max(1, math.ceil(length / size - 1e-9))
