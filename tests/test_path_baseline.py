"""``path``: any planner's path in (CSV, nav_msgs/Path YAML, GeoJSON), driven by the path follower; its
planned footprint sweep; planners' plans out in the same formats, and back as the same episode."""

from __future__ import annotations

import math

import numpy as np
import pytest
from cabinbench.baselines.boustrophedon import plan_layout
from cabinbench.baselines.path import PathBaseline, export_plan, planned_sweep, read_paths, write_paths
from cabinbench.baselines.path.baseline import stretches_between_stops

from cabinbench.agents import baseline_class
from cabinbench.commands import run
from cabinbench.episodes import run_episode
from cabinbench.errors import EXIT_USAGE, BaselineError
from cabinbench.geometry import distances_to_segments
from cabinbench.layouts.fields import RESOLUTION
from cabinbench.layouts.load import parse_layout
from cabinbench.layouts.resolve import load_layout

ROOM = parse_layout(
    """
kind: polygons
polygons:
  boundary: [[0, 0], [3, 0], [3, 2], [0, 2]]
  obstacles: [[[1.2, 0.8], [1.8, 0.8], [1.8, 1.2], [1.2, 1.2]]]
start: [0.5, 0.5]
"""
)
SUFFIXES = (".csv", ".yaml", ".geojson")

# What `ros2 topic echo --once /plan` prints for a two-pose nav_msgs/Path.
ROS2_ECHO = """header:
  stamp:
    sec: 1733450000
    nanosec: 5000
  frame_id: map
poses:
- header:
    stamp:
      sec: 0
      nanosec: 0
    frame_id: map
  pose:
    position:
      x: 0.5
      y: 0.5
      z: 0.0
    orientation:
      x: 0.0
      y: 0.0
      z: 0.7071067811865476
      w: 0.7071067811865476
- header:
    stamp:
      sec: 0
      nanosec: 0
    frame_id: ''
  pose:
    position:
      x: 0.5
      y: 1.5
      z: 0.0
    orientation:
      x: 0.0
      y: 0.0
      z: 0.0
      w: 1.0
---
"""


# ---------------------------------------------------------------------------------------------------- formats


@pytest.mark.parametrize("suffix", SUFFIXES)
def test_a_path_written_reads_back_exactly(tmp_path, suffix):
    points = np.array([[0.25, 1.85], [0.1 + 0.2, 1 / 3], [2.0, 1 / 3], [2.0, 1 / 3], [0.7, 1.9]])
    file = write_paths(tmp_path / f"plan{suffix}", [points])
    (read,) = read_paths(file)
    assert np.array_equal(read, points)


def test_geojson_holds_one_path_per_robot(tmp_path):
    team = [np.array([[0.5, 0.5], [2.5, 0.5]]), np.array([[0.5, 1.5], [2.5, 1.5], [2.5, 1.8]])]
    paths = read_paths(write_paths(tmp_path / "team.geojson", team))
    assert [path.tolist() for path in paths] == [path.tolist() for path in team]
    multi = tmp_path / "multi.geojson"  # a bare MultiLineString, with altitudes
    multi.write_text('{"type": "MultiLineString", "coordinates": [[[0, 0, 9], [1, 0, 9]], [[0, 1], [1, 1]]]}')
    assert [path.tolist() for path in read_paths(multi)] == [[[0, 0], [1, 0]], [[0, 1], [1, 1]]]


def test_ros2_topic_echo_output_and_a_headerless_csv_read(tmp_path):
    echo = tmp_path / "plan.yaml"
    echo.write_text(ROS2_ECHO)
    assert read_paths(echo)[0].tolist() == [[0.5, 0.5], [0.5, 1.5]]
    csv = tmp_path / "plan.csv"
    csv.write_text("# from my planner\n0.5, 0.5, 1.57\n\n0.5,1.5,0\n")
    assert read_paths(csv)[0].tolist() == [[0.5, 0.5], [0.5, 1.5]]


def test_written_headings_are_the_segment_directions(tmp_path):
    points = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]])
    rows = write_paths(tmp_path / "plan.csv", [points]).read_text().splitlines()
    assert rows[0] == "x,y,yaw"
    assert [float(row.split(",")[2]) for row in rows[1:]] == [0.0, math.pi / 2, math.pi / 2]


BAD_PATHS = [
    ("empty.csv", "x,y\n", "has no waypoints; give at least 2"),
    ("nan.csv", "0,0\nnan,1\n", "waypoint 2 is not finite"),
    ("one.csv", "0.5,0.5\n", "has 1 waypoint; a path needs at least 2"),
    ("fields.csv", "0,0\n1,1,0,4\n", "line 2: '1,1,0,4' is not x,y or x,y,yaw"),
    ("header.csv", "lat,lon\n0,0\n1,1\n", "header 'lat,lon' is not x,y or x,y,yaw"),
    (
        "odom.yaml",
        ROS2_ECHO.replace("frame_id: map", "frame_id: odom"),
        "frame 'odom' is not the layout's frame",
    ),
    ("two.yaml", ROS2_ECHO + ROS2_ECHO, "holds 2 messages"),
    ("notapath.yaml", "data: [1, 2]\n", "not a nav_msgs/Path"),
    ("point.geojson", '{"type": "Point", "coordinates": [0, 0]}', "a Point geometry; give a LineString"),
    ("broken.geojson", '{"type": "LineString", ', "not valid JSON"),
    ("plan.txt", "0,0\n1,1\n", "unknown path format '.txt'"),
    ("latin1.csv", b"# caf\xe9\n0,0\n1,1\n", "cannot read the path file"),
    ("missing.csv", None, "cannot read the path file (No such file or directory)"),
]


@pytest.mark.parametrize(("name", "contents", "problem"), BAD_PATHS)
def test_a_bad_path_is_one_line_naming_the_file_and_the_fix(tmp_path, name, contents, problem):
    file = tmp_path / name
    if isinstance(contents, bytes):
        file.write_bytes(contents)
    elif contents is not None:
        file.write_text(contents)
    with pytest.raises(BaselineError) as raised:
        PathBaseline(file=str(file))
    message = str(raised.value)
    assert message.startswith(f"{file}: ") and problem in message and "\n" not in message
    assert "; " in message  # the fix follows the problem


def test_paths_off_the_layout_or_not_one_per_robot_are_refused_before_driving(tmp_path):
    outside = tmp_path / "outside.csv"
    outside.write_text("0.5,0.5\n3.5,0.5\n")
    with pytest.raises(BaselineError, match=r"outside.csv: waypoint 2 \(3.500, 0.500\) lies outside layout"):
        PathBaseline(file=str(outside)).planned(ROOM)
    inside = tmp_path / "inside.csv"
    inside.write_text("0.5,0.5\n2.5,0.5\n")
    with pytest.raises(BaselineError, match=r"1 path\(s\) .* for 2 robot\(s\); give one path per robot"):
        PathBaseline(file=str(inside)).planned(ROOM, n_agents=2)
    assert PathBaseline(file=[str(inside), str(inside)]).planned(ROOM, n_agents=2)[
        "planned_path_lengths"
    ] == [2, 2]


def test_run_refuses_a_bad_path_in_one_line_with_exit_status_2(tmp_path, capsys):
    plan = tmp_path / "plan.csv"
    plan.write_text("0.5,0.5\n0.5,99\n")  # read fine; off the layout, found when the episode starts
    status = run.main(
        [
            "--baseline",
            "path",
            "--config",
            f'{{"file": "{plan}"}}',
            "--layout",
            "a320_cell",
            "--out",
            str(tmp_path),
        ]
    )
    error = capsys.readouterr().err.strip().splitlines()[-1]
    assert (
        status == EXIT_USAGE and error.startswith(f"error: {plan}: waypoint 2") and "layout's frame" in error
    )


# ---------------------------------------------------------------------------------------------- planned sweep


def test_the_sweep_is_every_floor_pixel_within_the_radius_of_the_path():
    path = np.array([[0.5, 0.5], [2.5, 0.5], [2.5, 1.6], [0.4, 1.6]])
    figures = planned_sweep(ROOM, [path])
    xs, ys = ROOM.pixel_centres()
    centres = np.column_stack([coordinate.ravel() for coordinate in np.meshgrid(xs, ys)])
    near = distances_to_segments(centres, path[:-1], path[1:]).min(axis=1) <= ROOM.robot.radius
    swept = near.reshape(ROOM.raster_shape) & ROOM.free_raster
    coverable = ROOM.coverable_raster
    assert figures["planned_coverage"] == (swept & coverable).sum() / coverable.sum()
    assert figures["planned_length"] == pytest.approx(2 + 1.1 + 2.1)
    assert (figures["planned_turns"], figures["planned_turning"]) == (2, pytest.approx(math.pi))
    assert figures["planned_off_floor_length"] == figures["planned_unreachable_length"] == 0.0


def test_length_through_the_obstacle_and_too_near_it_is_measured():
    figures = planned_sweep(ROOM, [np.array([[0.5, 1.0], [2.5, 1.0]])])  # straight through the 0.6 m box
    assert figures["planned_off_floor_length"] == pytest.approx(0.6, abs=RESOLUTION / 4)
    # either side of it, the disc (radius + contact clearance) would touch the box
    assert figures["planned_unreachable_length"] == pytest.approx(2 * (0.175 + 0.01), abs=RESOLUTION)


def test_gentle_bends_add_turning_but_are_no_turns():
    bend = np.array([[0.5, 0.5], [1.5, 0.5], [2.5, 0.5 + math.tan(0.1)]])
    figures = planned_sweep(ROOM, [bend])
    assert (figures["planned_turns"], figures["planned_turning"]) == (0, pytest.approx(0.1))


def test_a_repeated_waypoint_is_a_stop_between_legs():
    points = np.array([[0, 0], [1, 0], [1, 0], [1, 1], [1, 1], [1, 1], [2, 1]], dtype=float)
    stretches = stretches_between_stops(points)
    assert [stretch.tolist() for stretch in stretches] == [
        [[0, 0], [1, 0]],
        [[1, 0], [1, 1]],
        [[1, 1]],
        [[1, 1], [2, 1]],
    ]


# ------------------------------------------------------------------------------------------------- round trip


def test_an_exported_plan_run_as_a_path_is_the_planners_episode(tmp_path):
    """Each of the three formats: the same waypoints, through the same follower, so the same record (every
    metric but the wall-clock time) and the same trajectory."""
    planner, planner_trajectory = run_episode("boustrophedon", "a320_cell", 0)
    for suffix in SUFFIXES:
        file = export_plan("boustrophedon", "a320_cell", tmp_path / f"plan{suffix}")
        record, trajectory = run_episode("path", "a320_cell", 0, config={"file": str(file)})
        assert {**record, "wall_time": 0} == {**planner, "wall_time": 0}, suffix
        assert np.array_equal(trajectory["positions"], planner_trajectory["positions"])
    executed = planner["coverage"]
    planned = PathBaseline(file=str(file)).planned(load_layout("a320_cell"))
    assert planned["planned_off_floor_length"] == planned["planned_unreachable_length"] == 0.0
    assert abs(planned["planned_coverage"] - executed) < 0.01  # the follower keeps to the plan


def test_a_teams_export_is_each_robots_waypoints_without_the_convoy_gates(tmp_path):
    """A file holds waypoints, not a leg's start condition: a team's robots get their planned waypoints but
    start at once, where the planner's wait at its departure gates; so the team's episode is not the
    planner's (tested: the same waypoints; the run covers the cell)."""
    layout = load_layout("a320_cell")
    file = export_plan("boustrophedon", layout, tmp_path / "team.geojson", n_agents=2)
    for agent, path in enumerate(read_paths(file)):
        legs = plan_layout(layout, "sequential", agent, 2)
        assert np.array_equal(path, np.vstack([leg.waypoints for leg in legs]))
    record, _ = run_episode("path", layout, 0, n_agents=2, config={"file": str(file)})
    assert record["success"] and record["robot_collisions"] == 0


def test_export_refuses_a_team_in_a_one_path_format(tmp_path):
    export = baseline_class("path").export_plan  # how run reaches it: a command may not import a baseline
    with pytest.raises(BaselineError, match="holds one robot's path; write a team's to a .geojson file"):
        export("boustrophedon", "a320_cell", tmp_path / "team.csv", n_agents=2)
    with pytest.raises(BaselineError, match="has no plan to export"):
        export_plan("random_bounce", "a320_cell", tmp_path / "plan.csv")


def test_run_exports_a_plan_and_reports_planned_beside_executed(tmp_path, capsys):
    """``run --export-path`` writes the planner's plan; ``run --baseline path`` on it prints and records
    the plan's footprint sweep beside the executed metrics."""
    import json
    from pathlib import Path

    plan = tmp_path / "plan.csv"
    out = ["--layout", "a320_cell", "--episodes", "1", "--out", str(tmp_path / "runs")]
    assert run.main(["--baseline", "boustrophedon", "--export-path", str(plan), *out]) == 0
    capsys.readouterr()
    assert run.main(["--baseline", "path", "--config", json.dumps({"file": str(plan)}), "--json", *out]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["planned"]["planned_coverage"] >= summary["metrics"]["coverage"]["mean"] > 0.95
    record = json.loads(Path(summary["records"]).read_text().splitlines()[0])
    assert record["planned_length"] == summary["planned"]["planned_length"]
    bad = ["--baseline", "boustrophedon", "--suite", "classic", "--export-path", str(tmp_path / "x.csv")]
    assert run.main([*bad, "--out", str(tmp_path / "runs")]) == 2
