"""The ``coverage_path_planner`` baseline: the PyPI package coverage-path-planner's plan of a layout,
driven by the path follower, with the plan's sweep reported beside the executed episode."""

from __future__ import annotations

import json

import numpy as np
import pytest

pytest.importorskip(
    "coverage_path_planner",
    reason="coverage-path-planner not installed (pip install 'cabinbench[thirdparty]')",
)

from cabinbench.baselines.third_party.coverage_path_planner import third_party_plan  # noqa: E402

from cabinbench.agents import baseline_class  # noqa: E402
from cabinbench.commands import run  # noqa: E402
from cabinbench.errors import BaselineError  # noqa: E402
from cabinbench.layouts.resolve import load_layout  # noqa: E402


def test_the_plan_keeps_the_robot_centre_where_its_disc_fits():
    layout = load_layout("a320_cell")
    points = third_party_plan(layout, layout.start[:2], 0.0, "lines")
    rows, cols = zip(*(layout.to_pixel(x, y) for x, y in points[1:]))  # the first is the start pose
    assert layout.free_raster[rows, cols].all()
    margin = layout.robot.radius
    xmin, ymin, xmax, ymax = layout.extent
    assert (points[1:, 0] >= xmin + margin).all() and (points[1:, 0] <= xmax - margin).all()
    assert (points[1:, 1] >= ymin + margin).all() and (points[1:, 1] <= ymax - margin).all()


def test_a320_cell_reports_planned_and_executed_coverage(tmp_path):
    arguments = "--baseline coverage_path_planner --layout a320_cell --episodes 1 --start fixed --out"
    status = run.main([*arguments.split(), str(tmp_path)])
    assert status == 0
    (records,) = tmp_path.glob("*.jsonl")
    record = json.loads(records.read_text().splitlines()[0])
    assert record["baseline"] == "coverage_path_planner"
    assert record["planned_off_floor_length"] == 0.0  # its lanes are joined inside the free area
    assert 0.3 < record["planned_coverage"] <= 1.0
    assert 0.3 < record["coverage"] <= record["planned_coverage"] + 0.02
    assert np.isclose(sum(record["planned_path_lengths"]), record["planned_length"])


def test_a_team_is_refused_in_one_line(capsys):
    status = run.main(["--baseline", "coverage_path_planner", "--layout", "a320_cell", "--agents", "2"])
    assert status == 2
    assert "plans for one robot" in capsys.readouterr().err
    with pytest.raises(BaselineError, match="pattern"):
        baseline_class("coverage_path_planner")(pattern="spiral")
