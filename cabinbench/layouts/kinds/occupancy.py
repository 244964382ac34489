"""Layout kind ``occupancy``: a ROS ``map_server`` occupancy grid (a plain ``map.yaml`` loads as one).

The block holds the map YAML's fields (:mod:`cabinbench.layouts.rosmap`): ``image`` (relative to the layout
file), ``resolution``, ``origin`` ([x, y, yaw]; the layout uses the map's own frame, so ``yaw`` is
read but does not rotate it), ``negate``, ``occupied_thresh``, ``free_thresh``, ``mode``.

- Floor is what map_server publishes as free; unknown space is not floor.
- Speckles: an island of non-floor smaller than :data:`MIN_SPECKLE_AREA` inside the floor becomes
  floor, and an island of floor that small becomes non-floor, so SLAM noise makes no obstacles.
- The walls are the edges between floor and non-floor map pixels, straight runs merged into one
  segment; the clearance is a distance transform of the map
  (:func:`~cabinbench.geometry.raster_clearance`). The coverage raster (5 cm) takes, for each of
  its pixels, the map pixel under its centre.
- Without a ``start``: the robot starts, heading along +x, at the pixel centre farthest from every
  wall in the largest connected region of the floor where it fits (its disc clear of every wall by
  ``CONTACT_CLEARANCE``); of equally far pixels, the first from the bottom row up, left to right.
- A map too large to load (:mod:`cabinbench.layouts.sizes`) is refused before it is decoded.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from scipy import ndimage

from cabinbench.geometry import raster_clearance, raster_edges, resample_raster
from cabinbench.layouts import rosmap
from cabinbench.layouts.fields import (
    CONTACT_CLEARANCE,
    RESOLUTION,
    FieldChecker,
    KindGeometry,
    LayoutKind,
    RasterMap,
    RobotSpec,
    rectangle,
)
from cabinbench.layouts.sizes import check_layout_size

MIN_SPECKLE_AREA = 0.01  # m²: islands smaller than this (4 pixels at 5 cm) are SLAM noise
KEYS = ("image", "resolution", "origin", "negate", "occupied_thresh", "free_thresh", "mode")


def build_occupancy(check: FieldChecker, block, robot: RobotSpec) -> KindGeometry:
    block = check.mapping(block, "occupancy")
    check.known_keys(block, set(KEYS), "occupancy.")
    for key in ("image", "resolution", "origin"):
        if key not in block:
            check.fail(f"occupancy.{key}", "missing", "give the map's image, resolution and origin")
    resolution = check.number(block["resolution"], "occupancy.resolution")
    origin = check.point(block["origin"], "occupancy.origin", size=3)
    negate = block.get("negate", 0)
    if negate not in (0, 1):  # True and False are 1 and 0
        check.fail(
            "occupancy.negate", f"expected 0 or 1, got {negate!r}", "write negate: 0 (black is occupied)"
        )
    occupied = _threshold(check, block, "occupied_thresh", rosmap.DEFAULT_OCCUPIED_THRESH)
    free = _threshold(check, block, "free_thresh", rosmap.DEFAULT_FREE_THRESH)
    if free >= occupied:
        check.fail(
            "occupancy.free_thresh",
            f"{free} is not below occupied_thresh {occupied}",
            "use e.g. free_thresh: 0.196 and occupied_thresh: 0.65",
        )
    mode = block.get("mode", "trinary")
    if mode not in rosmap.MODES:
        check.fail("occupancy.mode", f"is {mode!r}", f"use one of {', '.join(rosmap.MODES)}")
    image_name = check.string(block["image"], "occupancy.image")
    folder = Path(check.source).parent if Path(check.source).is_file() else Path.cwd()
    path = folder / image_name
    image, data = rosmap.open_image(check, path, "occupancy.image")
    width, height = image.size
    check_layout_size(
        check,
        "occupancy.image",
        f"{path} ({width} x {height} px of {resolution:g} m)",
        "crop the map to the floor to be cleaned, or check its resolution",
        width * resolution,
        height * resolution,
        map_pixels=width * height,
    )
    shape = (_cells(height * resolution), _cells(width * resolution))
    values = rosmap.occupancy_values(
        rosmap.decode_image(check, image, path, "occupancy.image"), mode, bool(negate), occupied, free
    )
    map_floor = remove_speckles(np.flipud(values == rosmap.FREE), round(MIN_SPECKLE_AREA / resolution**2))
    if not map_floor.any():
        check.fail("occupancy.image", f"{path} has no free pixel", "check negate and the thresholds")
    x0, y0 = origin[0], origin[1]
    floor = resample_raster(map_floor, resolution, RESOLUTION, shape)
    clearance = raster_clearance(map_floor, resolution, RESOLUTION, shape)
    start = largest_region_start(clearance, (x0, y0), robot)
    if start is None:
        check.fail(
            "robot.radius",
            f"the robot (diameter {robot.tool_width} m) is wider than every gap of {path}",
            "use a smaller robot, or check the map's resolution",
        )
    raster = RasterMap(map_floor, resolution, raster_edges(map_floor, resolution, (x0, y0)), floor, clearance)
    boundary = rectangle(x0, y0, x0 + width * resolution, y0 + height * resolution)
    return KindGeometry(boundary, [], start=start, raster=raster, content=data)


def _threshold(check: FieldChecker, block: dict, key: str, default: float) -> float:
    value = check.number(block.get(key, default), f"occupancy.{key}", allow_zero=True)
    if value > 1:
        check.fail(f"occupancy.{key}", f"must be in [0, 1], got {value}", f"use e.g. {default}")
    return value


def _cells(length: float) -> int:
    return max(1, int(np.ceil(length / RESOLUTION - 1e-9)))


def remove_speckles(floor: np.ndarray, min_pixels: int) -> np.ndarray:
    """Non-floor islands of fewer than ``min_pixels`` become floor, then such floor islands
    non-floor (8-connected)."""
    floor = floor.copy()
    for value in (False, True):
        labels, count = ndimage.label(floor == value, structure=np.ones((3, 3)))
        small = np.bincount(labels.ravel(), minlength=count + 1) < min_pixels
        small[0] = False
        floor[small[labels]] = not value
    return floor


def largest_region_start(
    clearance: np.ndarray, origin: tuple[float, float], robot: RobotSpec
) -> tuple[float, float, float] | None:
    """The default start (see the module doc) on a raster's ``clearance``; None where the robot fits
    nowhere."""
    feasible = clearance >= robot.radius + CONTACT_CLEARANCE
    labels, count = ndimage.label(feasible, structure=np.ones((3, 3)))
    if count == 0:
        return None
    largest = 1 + int(np.argmax(np.bincount(labels.ravel())[1:]))
    row, col = np.unravel_index(int(np.argmax(np.where(labels == largest, clearance, -1.0))), clearance.shape)
    return float(origin[0] + (col + 0.5) * RESOLUTION), float(origin[1] + (row + 0.5) * RESOLUTION), 0.0


OCCUPANCY = LayoutKind("occupancy", build_occupancy)
