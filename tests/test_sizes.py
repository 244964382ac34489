"""A layout too large to load (memory or time) is refused in well under a second, before anything is
built, naming the file and the field that made it large; a large layout that fits still loads.
Every kind is covered (cabin, grid, polygons, occupancy, a family's cabins), and the coverage patch
of an env; the commands run as real subprocesses and answer in one line with exit status 2."""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import gymnasium as gym
import pytest

from cabinbench.errors import LayoutError
from cabinbench.layouts.family import families_dir, load_family
from cabinbench.layouts.load import MAX_LAYOUT_FILE_BYTES, read_layout
from cabinbench.layouts.sizes import MAX_LOAD_SECONDS, RASTER_BYTES_PER_PIXEL, raster_pixels
from cabinbench.memory import memory_budget
from cabinbench.sim.coverage import CoveragePatch

HANG_GUARD_S = 20  # a refusal takes well under a second in the library, a few with Python's start-up


def cabin(rows: int, width: float = 3.7) -> str:
    return (
        f"kind: cabin\ncabin: {{width: {width}, seat_blocks: [3, 3], aisle_width: 0.5, rows: {rows}, "
        "seat_pitch: 0.8, seat_depth: 0.35}\n"
    )


def square(side: float, obstacles: str = "[]") -> str:
    return (
        f"kind: polygons\npolygons:\n  boundary: [[0, 0], [{side}, 0], [{side}, {side}], [0, {side}]]\n"
        f"  obstacles: {obstacles}\nstart: [1, 1]\n"
    )


def triangles(count: int) -> str:
    """``count`` small triangles, in rows of 90."""
    corners = [(1 + (i % 90), 2 + (i // 90) * 0.5) for i in range(count)]
    return "[" + ",".join(f"[[{x},{y}],[{x + 0.2:g},{y}],[{x},{y + 0.2:g}]]" for x, y in corners) + "]"


def refused(path: Path) -> LayoutError:
    """The error loading ``path`` raises, after checking that it came fast."""
    started = time.perf_counter()
    with pytest.raises(LayoutError) as caught:
        read_layout(path)
    assert time.perf_counter() - started < 10.0  # the estimate (and the YAML): a build takes minutes
    assert caught.value.source == str(path)
    return caught.value


TOO_LARGE = {  # file name → (text, field named, words of the problem)
    "long_cabin.yaml": (cabin(10_000_000), "cabin.rows", ["8,000,000.0 x 3.7 m cabin", "TiB, more than the"]),
    "wide_cabin.yaml": (
        cabin(10, width=1e6),
        "cabin.width",
        ["8.0 x 1,000,000.0 m cabin", "GiB allowed on this machine"],
    ),
    "grid.yaml": (
        "kind: grid\ngrid:\n  cell_size: 10\n  map: |\n" + "".join(f"    {'.' * 300}\n" for _ in range(300)),
        "grid.map",
        ["a 300 x 300 map of 10 m cells", "GiB allowed on this machine"],
    ),
    "polygons.yaml": (
        square(100_000),
        "polygons.boundary",
        ["100,000.0 x 100,000.0 m floor", "allowed on this machine"],
    ),
    "corners.yaml": (
        "kind: polygons\npolygons:\n  boundary: ["
        + ",".join(f"[{i},{i % 2}]" for i in range(10_000))
        + ",[0,5]]\n",
        "polygons.boundary",
        ["10001 corners, more than the 10000"],
    ),
}


@pytest.mark.parametrize("name", list(TOO_LARGE))
def test_a_layout_too_large_is_refused_fast_naming_its_field(tmp_path, name):
    text, field, words = TOO_LARGE[name]
    (tmp_path / name).write_text(text)
    error = refused(tmp_path / name)
    assert error.field_name == field
    for word in words:
        assert word in error.problem
    assert error.fix


def test_an_occupancy_map_too_large_is_refused_before_it_is_decoded(tmp_path):
    (tmp_path / "huge.pgm").write_bytes(b"P5\n12000 12000\n255\n" + bytes(10))  # a header: 600 m a side
    (tmp_path / "huge.yaml").write_text("image: huge.pgm\nresolution: 0.05\norigin: [0.0, 0.0, 0.0]\n")
    error = refused(tmp_path / "huge.yaml")
    assert error.field_name == "image"  # a plain ROS map.yaml names its fields as it writes them
    assert "(12000 x 12000 px of 0.05 m)" in error.problem
    assert "GiB allowed on this machine" in error.problem


def test_obstacles_with_too_many_walls_for_their_floor_are_refused(tmp_path):
    side = 250  # the floor alone loads in under a minute; against 6,004 walls it would not
    if raster_pixels(side, side) * RASTER_BYTES_PER_PIXEL > memory_budget():
        pytest.skip("on this machine the floor alone is too large")
    (tmp_path / "furnished.yaml").write_text(square(side, triangles(2_000)))
    error = refused(tmp_path / "furnished.yaml")
    assert error.field_name == "polygons.obstacles"
    assert "a 250.0 x 250.0 m floor, a 5 cm raster of 2.5e+07 pixels against 6004 walls" in error.problem
    assert "minutes to load" in error.problem


def test_a_floor_that_fits_in_memory_but_loads_for_minutes_is_refused(tmp_path):
    side = 350  # 49 million pixels: about 10 GB, and over a minute
    (tmp_path / "hall.yaml").write_text(square(side))
    error = refused(tmp_path / "hall.yaml")
    assert error.field_name == "polygons.boundary"
    if raster_pixels(side, side) * RASTER_BYTES_PER_PIXEL <= memory_budget():
        assert "minutes to load" in error.problem and f"at most {MAX_LOAD_SECONDS} s" in error.problem


def test_a_layout_file_too_large_to_read_is_refused_before_parsing(tmp_path):
    path = tmp_path / "big.yaml"
    path.write_text(cabin(10) + "description: " + "x" * MAX_LAYOUT_FILE_BYTES + "\n")
    error = refused(path)
    assert error.field_name == "<file>" and "MiB a layout file may be" in error.problem


def test_a_family_drawing_cabins_too_large_is_refused_when_loaded(tmp_path):
    text = (families_dir() / "cabin_v1.yaml").read_text()
    assert "\ncells: [1, 4]\n" in text
    path = tmp_path / "endless.yaml"
    path.write_text(text.replace("\ncells: [1, 4]\n", "\ncells: [1, 100000000]\n"))
    started = time.perf_counter()
    with pytest.raises(LayoutError) as caught:
        load_family(path)
    assert time.perf_counter() - started < 5.0
    assert caught.value.source == str(path) and caught.value.field_name == "cells"


def test_a_large_layout_that_fits_still_loads(tmp_path):
    (tmp_path / "long.yaml").write_text(cabin(300))  # a 240 m cabin, 355,000 pixels
    layout = read_layout(tmp_path / "long.yaml")
    assert layout.raster_shape == (74, 4800)
    assert len(layout.obstacles) == 600


def test_a_cabin_of_hundreds_of_cells_loads_with_every_cell_its_own(tmp_path):
    (tmp_path / "cells.yaml").write_text(cabin(200).replace("rows: 200,", "rows: 200, rows_per_cell: 1,"))
    layout = read_layout(tmp_path / "cells.yaml")
    assert len(layout.cells) == 200 and len(layout.passages) == 199
    assert sorted(set(layout.cell_raster.ravel().tolist())) == list(range(200))  # no index wrapped round


def test_a_coverage_patch_too_large_is_refused_before_it_is_allocated():
    started = time.perf_counter()
    with pytest.raises(ValueError, match=r"^coverage_patch 1000000: .* TiB") as caught:
        CoveragePatch(10**6)
    with pytest.raises(ValueError, match="^coverage_patch 1000000: "):
        gym.make("CabinBench/Coverage-v0", layout="a320_cell", coverage_patch=10**6)
    assert time.perf_counter() - started < 5.0
    assert "\n" not in str(caught.value)
    assert CoveragePatch(64).size == 64 * 64


@pytest.fixture(scope="module")
def large_layouts(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("large_layouts")
    (folder / "endless_cabin.yaml").write_text(cabin(10_000_000))
    return folder


def command(argv: list[str], layouts: Path) -> tuple[int, str, str, float]:
    started = time.perf_counter()
    result = subprocess.run(
        [sys.executable, "-m", *argv],
        env={**os.environ, "CABINBENCH_LAYOUT_PATH": str(layouts)},
        capture_output=True,
        text=True,
        timeout=300,
    )
    return result.returncode, result.stdout, result.stderr, time.perf_counter() - started


@pytest.mark.parametrize(
    "argv",
    [
        ["cabinbench.run", "--baseline", "random_bounce", "--layout", "endless_cabin", "--episodes", "1"],
        ["cabinbench.complexity", "endless_cabin"],
    ],
    ids=["run", "complexity"],
)
def test_commands_refuse_a_layout_too_large_in_one_line(large_layouts, argv):
    status, _, stderr, elapsed = command(argv, large_layouts)
    assert status == 2
    assert stderr.count("\n") == 1 and "Traceback" not in stderr
    assert f"{large_layouts / 'endless_cabin.yaml'}: field 'cabin.rows'" in stderr
    assert elapsed < HANG_GUARD_S


def test_the_listing_reports_a_layout_too_large_and_lists_the_rest(large_layouts):
    status, stdout, stderr, elapsed = command(["cabinbench.layouts"], large_layouts)
    assert status == 2
    assert stderr.splitlines() == [stderr.strip()] and "field 'cabin.rows'" in stderr
    assert "Traceback" not in stderr
    assert "a320_cell" in stdout and "endless_cabin" not in stdout
    assert elapsed < HANG_GUARD_S
