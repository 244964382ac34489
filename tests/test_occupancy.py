"""ROS occupancy maps as layouts: map_server's pixel classes, the image formats, speckles, the default
start, every entry point that takes a layout, the export round trip of every built-in layout, a
building split into bays by ``cells: auto``, and the lidar on a building map (tests/test_lidar.py
compares rays with pymunk's)."""

import subprocess
import sys
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
import yaml
from PIL import Image
from scipy import ndimage

import cabinbench  # noqa: F401  (registers the envs)
from cabinbench import env as aec_env
from cabinbench import parallel_env
from cabinbench.commands.layouts import main as layouts_main
from cabinbench.episodes import run_episode
from cabinbench.errors import LayoutError
from cabinbench.layouts.building_maps import office_floor, write_building
from cabinbench.layouts.load import available_layouts, parse_layout
from cabinbench.layouts.resolve import load_layout
from cabinbench.layouts.rosmap import occupancy_values

ROOT = Path(__file__).resolve().parents[1]
ROOM = np.full((60, 80), 254, np.uint8)  # a 4 m x 3 m room at 5 cm: walls around, a pillar
ROOM[:2], ROOM[-2:], ROOM[:, :2], ROOM[:, -2:] = 0, 0, 0, 0
ROOM[20:30, 50:60] = 0


def write_map(folder: Path, pixels: np.ndarray, name: str = "map", image: str = "map.pgm", **fields) -> Path:
    Image.fromarray(pixels).save(folder / image)
    spec = {"image": image, "resolution": 0.05, "origin": [-1.0, 2.0, 0.0], "negate": 0, **fields}
    (folder / f"{name}.yaml").write_text(yaml.safe_dump(spec))
    return folder / f"{name}.yaml"


def test_pixels_are_classified_as_map_server_does():
    pixels = np.array([0, 100, 150, 205, 230, 254, 255], dtype=np.uint8)
    # occ = 1 - p/255: 1.0, 0.61, 0.41, 0.196, 0.098, 0.004, 0.0
    assert occupancy_values(pixels, "trinary", False, 0.65, 0.196).tolist() == [100, -1, -1, -1, 0, 0, 0]
    # scale: rint((occ - free) / (occupied - free) * 100) between the thresholds
    assert occupancy_values(pixels, "scale", False, 0.65, 0.196).tolist() == [100, 91, 48, 0, 0, 0, 0]
    assert occupancy_values(pixels, "trinary", True, 0.65, 0.196).tolist() == [0, -1, -1, 100, 100, 100, 100]
    # raw: the value itself from 0 to 100, else unknown; negate does not apply
    assert occupancy_values(pixels, "raw", True, 0.65, 0.196).tolist() == [0, 100, -1, -1, -1, -1, -1]


@pytest.mark.parametrize("image", ["map.pgm", "map.png", "ascii.pgm"])
def test_a_ros_map_loads_from_pgm_and_png(tmp_path, image):
    if image == "ascii.pgm":  # plain (P2) PGM, as some tools write it
        rows = "\n".join(" ".join(str(v) for v in row) for row in ROOM)
        (tmp_path / image).write_text(f"P2\n# a room\n{ROOM.shape[1]} {ROOM.shape[0]}\n255\n{rows}\n")
        Image.fromarray(ROOM).save(tmp_path / "unused.pgm")
        spec = {"image": image, "resolution": 0.05, "origin": [-1.0, 2.0, 0.0]}
        (tmp_path / "map.yaml").write_text(yaml.safe_dump(spec))
        path = tmp_path / "map.yaml"
    else:
        path = write_map(tmp_path, ROOM, image=image)
    layout = load_layout(path)
    assert layout.kind == "occupancy" and layout.extent == (-1.0, 2.0, 3.0, 5.0)
    # the image's top row is the far edge: the pillar (rows 20-30 from the top) lies at y 3.5-4.0
    assert not layout.free_raster[60 - 25, 55] and layout.free_raster[25, 55]
    assert layout.free_area == pytest.approx((76 * 56 - 100) * 0.05**2)
    walls = layout.walls  # 4 sides of the room and 4 of the pillar, each one merged segment
    assert len(walls) == 8


def test_unknown_is_not_floor_and_speckles_go(tmp_path):
    pixels = ROOM.copy()
    pixels[40:50, 5:25] = 205  # an unknown patch: not floor
    pixels[10, 10] = 0  # a one-pixel speckle: floor
    pixels[45, 45] = 205
    layout = load_layout(write_map(tmp_path, pixels))
    assert not layout.free_raster[60 - 45, 15]
    assert layout.free_raster[60 - 11, 10] and layout.free_raster[60 - 46, 45]


def test_default_start_is_in_the_largest_region_farthest_from_walls(tmp_path):
    pixels = ROOM.copy()
    pixels[:, 20:22] = 0  # a wall cuts off a 0.9 m strip on the left: the larger part is on the right
    layout = load_layout(write_map(tmp_path, pixels))
    x, y, heading = layout.start
    assert x > -1.0 + 22 * 0.05 and heading == 0.0
    assert layout.clearance[layout.to_pixel(x, y)] == pytest.approx(layout.clearance.max())
    assert load_layout(write_map(tmp_path, pixels)).start == layout.start


def test_occupancy_kind_adds_what_a_ros_map_lacks(tmp_path):
    write_map(tmp_path, ROOM)
    spec = {
        "kind": "occupancy",
        "description": "a room",
        "start": [0.0, 3.0, 1.5],
        "robot": {"radius": 0.15},
        "max_steps": 50,
        "goals": [[1.0, 3.0]],
        "occupancy": {"image": "map.pgm", "resolution": 0.05, "origin": [-1.0, 2.0, 0.0]},
    }
    (tmp_path / "room.yaml").write_text(yaml.safe_dump(spec))
    layout = load_layout(tmp_path / "room.yaml")
    assert layout.start == (0.0, 3.0, 1.5) and layout.robot.radius == 0.15 and layout.max_steps == 50
    assert layout.goals.tolist() == [[1.0, 3.0]] and layout.description == "a room"
    Image.fromarray(np.where(ROOM == 0, 0, 254).astype(np.uint8)).save(tmp_path / "map.pgm")
    assert load_layout(tmp_path / "room.yaml").content_hash == layout.content_hash
    ROOM2 = ROOM.copy()
    ROOM2[40, 40] = 205
    Image.fromarray(ROOM2).save(tmp_path / "map.pgm")
    assert load_layout(tmp_path / "room.yaml").content_hash != layout.content_hash  # the image counts


def test_a_ros_map_works_wherever_a_layout_does(tmp_path):
    path = write_map(tmp_path, ROOM)
    env = gym.make("CabinBench/Coverage-v0", layout=str(path), max_steps=5)
    env.reset(seed=0)
    env.step(env.action_space.sample())
    team = parallel_env(layout=str(path), n_agents=2)
    team.reset(seed=0)
    aec_env(layout=str(path), n_agents=2).reset(seed=0)
    for baseline in ("random_bounce", "boustrophedon"):
        result = subprocess.run(
            [sys.executable, "-m", "cabinbench.run", "--baseline", baseline, "--layout", str(path)]
            + ["--episodes", "1", "--max-steps", "20", "--out", str(tmp_path / "runs")],
            capture_output=True,
            text=True,
            timeout=300,
        )
        assert result.returncode == 0, result.stderr
    result = subprocess.run(
        [sys.executable, "-m", "cabinbench.complexity", str(path)],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert result.returncode == 0 and "map" in result.stdout, result.stderr


def test_building_maps_are_listed_with_their_complexity(capsys):
    assert {"office_floor", "mall_corridor", "meeting_area"} <= set(available_layouts())
    assert layouts_main(["--json"]) == 0
    rows = {row["name"]: row for row in yaml.safe_load(capsys.readouterr().out)}
    for name in ("office_floor", "mall_corridor", "meeting_area"):
        assert rows[name]["kind"] == "occupancy" and rows[name]["complexity_total"] > 0


def test_building_maps_are_drawn_by_the_committed_script(tmp_path):
    subprocess.run([sys.executable, "-m", "cabinbench.building_maps", str(tmp_path)], check=True, timeout=120)
    for name in ("office_floor", "mall_corridor", "meeting_area"):
        for suffix in (".yaml", ".pgm"):
            assert (tmp_path / f"{name}{suffix}").read_bytes() == (
                ROOT / "layouts" / f"{name}{suffix}"
            ).read_bytes()


@pytest.mark.parametrize("name", sorted(available_layouts()))
def test_export_round_trips_every_builtin_layout(tmp_path, name):
    """The exported floor, loaded back, has the same coverable area within 1%. A ROS map holds no
    start or robot, so the layout's own are given to load it back with; the robot is 1 mm narrower
    in both, because the cabins draw legroom the robot fits with exactly ``CONTACT_CLEARANCE`` to
    spare, where rounding in the last bit of a float decides either way."""
    path = available_layouts()[name]
    spec = yaml.safe_load(path.read_text())
    spec["robot"] = {**spec.get("robot", {}), "radius": load_layout(name).robot.radius - 0.001}
    layout = parse_layout(yaml.safe_dump(spec), source=str(path), default_name=name)
    assert layouts_main(["export", name, str(tmp_path)]) == 0
    ros_map = yaml.safe_load((tmp_path / f"{name}.yaml").read_text())
    assert set(ros_map) == {
        "image",
        "mode",
        "resolution",
        "origin",
        "negate",
        "occupied_thresh",
        "free_thresh",
    }
    back_spec = {
        "kind": "occupancy",
        "occupancy": ros_map,
        "start": list(layout.start),
        "robot": spec["robot"],
    }
    (tmp_path / "back.yaml").write_text(yaml.safe_dump(back_spec))
    back = load_layout(tmp_path / "back.yaml")
    assert back.extent == pytest.approx(layout.extent, abs=0.01)  # whole 1 cm pixels
    assert back.free_area == pytest.approx(layout.free_area, rel=0.01)
    assert back.coverable_area == pytest.approx(layout.coverable_area, rel=0.01)


def office_with_bays(folder: Path, width: float = 20.0, **fields) -> Path:
    """The shipped office floor's drawing (``width`` m wide) as an occupancy layout with ``cells: auto``."""
    map_path = write_building(folder, "office", office_floor(width, 13.0))
    spec = {"kind": "occupancy", "occupancy": yaml.safe_load(map_path.read_text()), "cells": "auto", **fields}
    (folder / "office_bays.yaml").write_text(yaml.safe_dump(spec))
    return folder / "office_bays.yaml"


def test_cells_auto_splits_the_office_floor_into_bays_at_the_walls_between_its_offices(tmp_path):
    layout = load_layout(office_with_bays(tmp_path))
    # Four columns of 4 m offices on both sides of the corridor, then the open end: five bays, each
    # cut at a wall between two columns of offices, so no office is split.
    assert [cell.name for cell in layout.cells] == [f"bay_{index}" for index in range(5)]
    xmin, ymin, xmax, ymax = layout.extent
    edges = [cell.rect[0] for cell in layout.cells] + [layout.cells[-1].rect[2]]
    assert (
        edges[0] == xmin
        and edges[-1] == xmax
        and all(cell.rect[1::2] == (ymin, ymax) for cell in layout.cells)
    )
    walls = ~layout.free_raster.any(
        axis=0
    )  # raster columns that are wall from top to bottom but the corridor
    for cut in edges[1:-1]:
        column = round((cut - xmin) / 0.05)
        crossing = layout.free_raster[:, column - 1] | layout.free_raster[:, column]
        assert not walls[column] and crossing.sum() * 0.05 < 3.0  # only the 2 m corridor crosses it
    # the robot starts in the first bay; each bay leads into the next through the corridor, and its
    # floor is one piece
    assert layout.cell_raster[layout.to_pixel(*layout.start[:2])] == 0
    assert [len(passage.exits) for passage in layout.passages] == [1, 1, 1, 1]
    for index in range(5):
        floor = layout.coverable_raster & (layout.cell_raster == index)
        assert ndimage.label(floor)[1] == 1
    again = load_layout(office_with_bays(tmp_path))
    assert [cell.rect for cell in again.cells] == [cell.rect for cell in layout.cells]


def test_a_start_in_the_last_bay_visits_the_bays_the_other_way(tmp_path):
    first = load_layout(office_with_bays(tmp_path)).cells
    layout = load_layout(office_with_bays(tmp_path, start=[19.0, 6.5]))
    assert [cell.rect for cell in layout.cells] == [cell.rect for cell in reversed(first)]
    assert layout.cell_raster[layout.to_pixel(19.0, 6.5)] == 0


def test_the_sequential_protocol_cleans_a_building_bay_by_bay(tmp_path):
    layout = load_layout(office_with_bays(tmp_path, width=9.0, max_steps=20000))
    assert len(layout.cells) == 2
    record, _ = run_episode("boustrophedon", layout, 0, protocol="sequential")
    assert record["success"] and record["cells_cleared"] == 2 and record["bound_violations"] == 0


def test_cells_auto_refuses_what_it_cannot_split_in_one_line(tmp_path):
    middle = office_with_bays(tmp_path, start=[10.5, 6.5])  # in the third of five bays
    no_map = tmp_path / "room.yaml"
    room = {"boundary": [[0, 0], [4, 0], [4, 3], [0, 3]]}
    no_map.write_text(yaml.safe_dump({"kind": "polygons", "polygons": room, "cells": "auto"}))
    for path, field in ((middle, "start"), (no_map, "cells")):
        with pytest.raises(LayoutError) as error:
            load_layout(path)
        assert error.value.field_name == field and "\n" not in str(error.value)
