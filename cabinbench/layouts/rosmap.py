"""ROS ``map_server`` occupancy maps: an image's pixels classified as map_server does, and any
floor raster written back as a map pair (``NAME.yaml`` + ``NAME.pgm``).

A map YAML holds ``image`` (path relative to the YAML), ``resolution`` (m/pixel), ``origin``
([x, y, yaw] of the lower-left pixel), ``negate``, ``occupied_thresh``, ``free_thresh`` and
``mode``. The classification follows ROS 2's map_server (nav2_map_server ``map_io``): with
``shade = pixel / 255`` and ``occ = shade`` if ``negate`` else ``1 - shade``,

- ``trinary`` (default): occupied (100) if ``occ > occupied_thresh``, free (0) if
  ``occ < free_thresh``, else unknown (-1);
- ``scale``: as trinary, but between the thresholds the value is
  ``rint((occ - free_thresh) / (occupied_thresh - free_thresh) * 100)``;
- ``raw``: the pixel value itself when it is 0 to 100, else unknown (``negate`` is not applied).

The layout's floor is what map_server publishes as free (0); unknown and every occupied value
are not floor. Images are 8-bit grey: PGM (binary P5 or ASCII P2) or PNG.
"""

from __future__ import annotations

import io
import warnings
from pathlib import Path

import numpy as np
import yaml
from PIL import Image

from cabinbench.layouts.fields import FieldChecker

MODES = ("trinary", "scale", "raw")
DEFAULT_OCCUPIED_THRESH, DEFAULT_FREE_THRESH = 0.65, 0.196  # map_server's own defaults
FREE, OCCUPIED, UNKNOWN = 0, 100, -1
SAVED_FREE, SAVED_OCCUPIED = 254, 0  # the grey values ROS's map_saver writes


def occupancy_values(
    pixels: np.ndarray, mode: str, negate: bool, occupied_thresh: float, free_thresh: float
) -> np.ndarray:
    """The int8 occupancy map_server publishes for each 8-bit grey pixel (see the module doc)."""
    shade = np.arange(256) / 255.0
    if mode == "raw":
        table = np.where(shade * 255 <= OCCUPIED, np.round(shade * 255), UNKNOWN)
    else:
        occ = shade if negate else 1.0 - shade
        between = (
            np.rint((occ - free_thresh) / (occupied_thresh - free_thresh) * 100.0)
            if mode == "scale"
            else np.full(256, UNKNOWN)
        )
        table = np.where(occ > occupied_thresh, OCCUPIED, np.where(occ < free_thresh, FREE, between))
    return table.astype(np.int8)[pixels]  # one lookup per pixel: 256 entries, not a float per pixel


def open_image(check: FieldChecker, path: Path, field_name: str) -> tuple[Image.Image, bytes]:
    """The image at ``path``, opened but not yet decoded (its size is known), and its bytes."""
    try:
        data = path.read_bytes()
    except FileNotFoundError:
        check.fail(field_name, f"image {path} not found", "give the map image's path, relative to the YAML")
    except OSError as error:
        check.fail(field_name, f"image {path} cannot be read ({error.strerror})", "check the file")
    try:
        with warnings.catch_warnings():  # the loader checks the size against the memory it needs
            warnings.simplefilter("ignore", Image.DecompressionBombWarning)
            image = Image.open(io.BytesIO(data))
    except Image.DecompressionBombError:
        check.fail(
            field_name,
            f"{path} has more than {2 * Image.MAX_IMAGE_PIXELS:,} pixels, the most Pillow opens",
            "crop the map to the floor to be cleaned",
        )
    except (OSError, ValueError):
        check.fail(field_name, f"{path} is not an image", "give an 8-bit grey PGM or PNG map image")
    if image.mode != "L":
        check.fail(
            field_name,
            f"{path} is not an 8-bit grey image (mode {image.mode})",
            "save the map as 8-bit greyscale PGM or PNG, as ROS map_saver writes it",
        )
    return image, data


def decode_image(check: FieldChecker, image: Image.Image, path: Path, field_name: str) -> np.ndarray:
    """The pixels of an image from :func:`open_image`, top row first."""
    try:
        return np.asarray(image)
    except (OSError, ValueError, SyntaxError) as error:
        check.fail(field_name, f"{path} is damaged ({error})", "save the map image again")


def write_map(folder: Path, name: str, floor: np.ndarray, resolution: float, origin: tuple[float, float]):
    """Write ``floor`` (bool, row 0 the lowest y) as ``folder/name.pgm`` + ``folder/name.yaml``:
    floor 254 and everything else 0, as map_saver writes free and occupied. Returns both paths."""
    folder.mkdir(parents=True, exist_ok=True)
    image_path, yaml_path = folder / f"{name}.pgm", folder / f"{name}.yaml"
    pixels = np.where(np.flipud(floor), SAVED_FREE, SAVED_OCCUPIED).astype(np.uint8)
    Image.fromarray(pixels, mode="L").save(image_path)
    spec = {
        "image": image_path.name,
        "mode": "trinary",
        "resolution": float(resolution),
        "origin": [float(origin[0]), float(origin[1]), 0.0],
        "negate": 0,
        "occupied_thresh": DEFAULT_OCCUPIED_THRESH,
        "free_thresh": DEFAULT_FREE_THRESH,
    }
    yaml_path.write_text(yaml.safe_dump(spec, sort_keys=False), encoding="utf-8")
    return yaml_path, image_path
