"""Layouts load by name, by path and from a user folder; broken files fail with a message that
names the file, the field and the fix."""

import textwrap
from pathlib import Path

import numpy as np
import pytest

from cabinbench.errors import LayoutError
from cabinbench.layouts.load import available_layouts, builtin_layout_dir, parse_layout
from cabinbench.layouts.resolve import load_layout

BUILTIN = [
    "a320_cell",
    "a320_tracking_cell",
    "shape_changed",
    "b777_3col",
    "full_cabin",
    "paper_matrix_a",
    "paper_matrix_b",
]

ROOM = """
kind: polygons
polygons:
  boundary: [[0, 0], [3, 0], [3, 2], [0, 2]]
  obstacles: [[[1.2, 0.8], [1.8, 0.8], [1.8, 1.2], [1.2, 1.2]]]
start: [0.5, 0.5]
"""


def test_every_builtin_layout_is_registered_and_loads():
    assert set(BUILTIN) <= set(available_layouts())
    for name in BUILTIN:
        layout = load_layout(name)
        assert layout.source, f"{name} must say where its geometry comes from"
        assert 0 < layout.coverable_area <= layout.free_area
        assert layout.centre_free[layout.to_pixel(*layout.start[:2])]


def test_cabin_geometry_is_realistic():
    a320 = load_layout("a320_cell")
    assert a320.extent[3] == pytest.approx(3.70)
    b777 = load_layout("b777_3col")
    assert b777.extent[3] == pytest.approx(5.87)
    assert [len(p.bounds) for p in b777.passages] == [2]  # two aisles: two bounds, two exits
    full = load_layout("full_cabin")
    assert len(full.cells) == 10 and len(full.passages) == 9
    assert len(full.obstacles) == 40  # twenty seat rows, two blocks each
    # every legroom gap admits the robot: the goals in the dead ends are reachable
    assert len(full.goals) == 40


def test_load_by_path_and_from_user_folder(tmp_path, monkeypatch):
    path = tmp_path / "room.yaml"
    path.write_text(ROOM)
    layout = load_layout(path)
    assert layout.name == "room" and layout.kind == "polygons"
    monkeypatch.setenv("CABINBENCH_LAYOUT_PATH", str(tmp_path))
    assert "room" in available_layouts()
    assert load_layout("room").content_hash == layout.content_hash


def test_unknown_name_lists_the_valid_ones():
    with pytest.raises(LayoutError, match="a320_cell"):
        load_layout("no_such_layout")


BROKEN = {
    "unknown key": (ROOM + "colour: red\n", "colour", "unknown key"),
    "wrong type": (ROOM.replace("start: [0.5, 0.5]", "start: [zero, 0.5]"), "start[0]", "expected a number"),
    "negative size": (
        "kind: grid\ngrid:\n  cell_size: -0.35\n  map: |\n    S..\n",
        "grid.cell_size",
        "positive",
    ),
    "zero size": (ROOM + "robot: {radius: 0}\n", "robot.radius", "positive"),
    "empty map": ("kind: grid\ngrid:\n  cell_size: 0.35\n  map: ''\n", "grid.map", "empty map"),
    "start in obstacle": (ROOM.replace("[0.5, 0.5]", "[1.5, 1.0]"), "start", "inside an obstacle"),
    "start outside": (ROOM.replace("[0.5, 0.5]", "[5.0, 0.5]"), "start", "outside the map"),
    "robot too wide": (ROOM + "robot: {radius: 1.2}\n", "robot.radius", "wider than every gap"),
    "unreachable goal": (ROOM + "goals: [[1.5, 1.15]]\n", "goals", "out of the robot's reach"),
    "unreachable cell": (
        textwrap.dedent("""
        kind: polygons
        polygons:
          boundary: [[0, 0], [4, 0], [4, 2], [0, 2]]
          obstacles: [[[1.9, 0], [2.1, 0], [2.1, 2], [1.9, 2]]]
        cells: [{rect: [0, 0, 2, 2]}, {rect: [2, 0, 4, 2]}]
        start: [0.5, 1.0]
        """),
        "cells[1]",
        "no floor the robot can reach",
    ),
    "open polygon": (
        ROOM.replace("[[0, 0], [3, 0], [3, 2], [0, 2]]", "[[0, 0], [3, 0]]"),
        "polygons.boundary",
        "at least 3 points",
    ),
    "self-intersecting polygon": (
        ROOM.replace("[[0, 0], [3, 0], [3, 2], [0, 2]]", "[[0, 0], [3, 2], [3, 0], [0, 2]]"),
        "polygons.boundary",
        "intersects itself",
    ),
    "ragged grid": (
        "kind: grid\ngrid:\n  cell_size: 0.35\n  map: |\n    S...\n    ..\n",
        "grid.map",
        "ragged rows",
    ),
    "two start markers": (
        "kind: grid\ngrid:\n  cell_size: 0.35\n  map: |\n    S..\n    ..S\n",
        "grid.map",
        "2 start cells",
    ),
    "no cell holds the robot": (
        "kind: grid\ngrid:\n  cell_size: 0.35\n  map: |\n    .....\n",
        "grid.map",
        "no free cell holds the robot",
    ),
    "kind block missing": ("kind: grid\n", "grid", "missing"),
    "cells of a cabin": (
        Path(builtin_layout_dir() / "a320_cell.yaml").read_text() + "cells: [{rect: [0, 0, 1, 1]}]\n",
        "cells",
        "derive their cells",
    ),
    "not yaml": ("kind: [grid\n  : :", "<file>", "not valid YAML"),
    "not a mapping": ("- just\n- a list\n", "<file>", "not a mapping"),
    "unknown kind": ("kind: maze\n", "kind", "cabin, grid, polygons"),
    "cabin without legroom": (
        "kind: cabin\ncabin: {width: 3.7, seat_blocks: [3, 3], aisle_width: 0.48, rows: 2, "
        "seat_pitch: 0.8, seat_depth: 0.9}\n",
        "cabin.seat_depth",
        "no legroom",
    ),
}


@pytest.mark.parametrize("case", sorted(BROKEN))
def test_broken_layout_names_file_field_and_fix(case, tmp_path):
    text, field, problem = BROKEN[case]
    path = tmp_path / "broken.yaml"
    path.write_text(text)
    with pytest.raises(LayoutError) as raised:
        load_layout(path)
    message = str(raised.value)
    assert str(path) in message and f"'{field}'" in message and problem in message and "Fix:" in message


def test_yaml_is_read_safely(tmp_path):
    path = tmp_path / "evil.yaml"
    path.write_text("kind: !!python/object/apply:os.system ['echo hacked']\n")
    with pytest.raises(LayoutError, match="not valid YAML"):
        load_layout(path)


def test_coverable_area_is_free_space_reachable_by_the_disc():
    layout = parse_layout(ROOM)
    coverable, free = layout.coverable_raster, layout.free_raster
    assert (coverable <= free).all()
    assert np.isclose(layout.free_area, 3 * 2 - 0.6 * 0.4, atol=0.05)
    # Poses sit on pixel centres 1 cm clear of walls, so coverage reaches to within one pixel
    # (5 cm) of a wall, less the round scallops in corners the disc cannot reach.
    away_from_walls = layout.clearance >= 0.075
    missed = away_from_walls & ~coverable
    assert missed.sum() < 0.02 * away_from_walls.sum()
    assert 0.85 * layout.free_area < layout.coverable_area < 0.95 * layout.free_area


def test_grid_without_start_marker_starts_nearest_the_centre_where_the_robot_fits():
    """The centre cell is an obstacle and its four neighbours are too narrow for the 0.35 m robot on
    0.35 m cells; of the four diagonal cells, equally near, the first in reading order wins."""
    rows = ".....", ".....", "..#..", ".....", "....."
    layout = parse_layout(
        "kind: grid\ngrid:\n  cell_size: 0.35\n  map: |\n" + "".join(f"    {row}\n" for row in rows)
    )
    assert layout.start == pytest.approx((1.5 * 0.35, 3.5 * 0.35, 0.0))  # text row 1, column 1
    with_marker = (builtin_layout_dir() / "paper_matrix_a.yaml").read_text()
    assert "..S.." in with_marker  # the study's Matrix A marks the centre
    assert parse_layout(with_marker.replace("S", ".")).start == load_layout("paper_matrix_a").start


@pytest.mark.parametrize(
    ("contents", "problem"),
    [(b"kind: grid\n# caf\xe9\n", "not UTF-8 text (line 2)"), (None, "is a folder")],
)
def test_unreadable_layout_file_is_named(tmp_path, contents, problem):
    path = tmp_path / "room.yaml"
    if contents is None:
        path.mkdir()
    else:
        path.write_bytes(contents)
    with pytest.raises(LayoutError) as raised:
        load_layout(path)
    assert str(raised.value).startswith(f"{path}: field '<file>': {problem}. Fix: ")
