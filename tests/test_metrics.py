"""Metrics on hand-made cases with known answers, through real pymunk physics."""

import math

import numpy as np
import pytest

from cabinbench.envs.coverage_env import CoverageEnv
from cabinbench.layouts.load import parse_layout
from cabinbench.metrics import METRICS, overlap, uncovered_by_clearance

from .driving import drive


def room(width, height, start):
    return parse_layout(
        f"kind: polygons\npolygons:\n  boundary: [[0, 0], [{width}, 0], [{width}, {height}], [0, {height}]]\n"
        f"start: [{start[0]}, {start[1]}]\nsuccess_coverage: 1.0\nmax_steps: 5000\n"
    )


def finish(env):
    return env.tracker.record()


def test_straight_drive_down_an_empty_corridor():
    # Drive along a row of pixel centres (y = 0.225): the disc then covers exactly 7 rows of
    # 0.05 m, its 0.35 m width. Off-centre lines cover 6 to 8 rows; the raster is unbiased on average.
    layout = room(5.0, 0.45, (0.25, 0.225))
    env = CoverageEnv(layout, protocol="open")
    env.reset(seed=0)
    for _ in range(80):  # 80 steps at 0.5 m/s: 4 m
        env.step([1.0, 0.0])
    record = finish(env)
    assert record["path_length"] == pytest.approx(4.0, abs=0.02)  # the first substep accelerates from rest
    assert record["path_efficiency"] == pytest.approx(1.0, abs=0.02)
    assert record["overlap"] == pytest.approx(0.0, abs=1e-9)
    assert record["rotation"] == pytest.approx(0.0, abs=1e-6)
    assert record["collisions"] == 0 and record["time"] == pytest.approx(8.0)
    swept_area = 4.0 * 0.35 + math.pi * 0.175**2
    assert record["coverage_free"] == pytest.approx(swept_area / (5.0 * 0.45), abs=0.02)
    assert record["t90"] is None


def test_lawnmower_of_an_empty_room_covers_everything_once():
    width, height, radius = 2.0, 1.4, 0.175
    layout = room(width, height, (radius + 0.015, radius + 0.015))
    env = CoverageEnv(layout, protocol="open", max_steps=5000)
    env.reset(seed=0)
    margin = radius + 0.015  # drive 1.5 cm clear of the walls: touching them counts as contact
    lanes = np.linspace(margin, height - margin, 4)  # four lanes just under a tool width apart
    waypoints = []
    for k, y in enumerate(lanes):
        ends = [(margin, y), (width - margin, y)]
        waypoints += ends if k % 2 == 0 else ends[::-1]
    info, terminated = drive(env, waypoints)
    record = env.tracker.record()
    # all but the scallops a round tool leaves between lane ends at the side walls (~1.5 %)
    assert record["coverage"] >= 0.98
    assert record["overlap"] < 0.25  # only the turns at the lane ends are passed twice
    driven = 4 * (width - 2 * margin) + 3 * (lanes[1] - lanes[0])  # four lanes and three shifts
    assert record["path_length"] == pytest.approx(driven, abs=0.1)  # plus the driver's corner approaches
    assert record["path_efficiency"] > 0.85
    assert record["t90"] is not None and record["t90"] < record["t95"] <= record["time"]
    # six quarter turns, plus the driver's small heading corrections (which can only add)
    assert 6 * math.pi / 2 - 0.05 <= record["rotation"] <= 6 * math.pi / 2 + 1.0
    assert record["collisions"] == 0


def test_record_has_every_metric_and_collisions_count_contacts():
    layout = room(2.0, 2.0, (1.0, 1.0))
    env = CoverageEnv(layout, protocol="open", max_steps=60)
    env.reset(seed=0)
    for _ in range(60):  # straight into the wall: one contact event, then pressing
        *_, truncated, info = env.step([1.0, 0.0])
    record = env.episode_record
    assert set(METRICS) <= set(record)
    assert record["collisions"] == 1
    # 0.825 m to the wall, plus the ~1 cm a first contact sinks in and is pushed back out
    assert record["path_length"] == pytest.approx(1.0 - 0.175, abs=0.04)


def test_overlap_counts_passes_not_steps():
    assert overlap(np.array([[0, 1], [1, 1]], dtype=np.uint16)) == 0
    assert overlap(np.array([[3, 1], [0, 0]], dtype=np.uint16)) == pytest.approx(1.0)


def test_uncovered_floor_is_split_by_distance_from_the_walls():
    clearance = np.array([[0.02, 0.07, 0.15, 0.30, 0.50, 0.0]])  # the last pixel is not coverable
    coverable = np.array([[True, True, True, True, True, False]])
    covered_inner_two = np.array([[0, 0, 0, 1, 2, 0]], dtype=np.uint16)
    assert uncovered_by_clearance(covered_inner_two, coverable, clearance) == pytest.approx(
        [0.2, 0.2, 0.2, 0, 0]
    )
    assert uncovered_by_clearance(np.zeros_like(covered_inner_two), coverable, clearance) == pytest.approx(
        [0.2] * 5
    )
    # a real episode: the robot drives down the middle of a corridor 0.65 m wide, its disc 15 cm
    # from either side wall, so it leaves uncovered only floor within 15 cm of them; the bands sum
    # to 1 - coverage
    layout = room(1.2, 0.65, (0.25, 0.325))
    env = CoverageEnv(layout, protocol="open")
    env.reset(seed=0)
    for _ in range(30):  # into the far wall
        env.step([1.0, 0.0])
    uncovered = uncovered_by_clearance(env.world.pass_count, layout.coverable_raster, layout.clearance)
    assert uncovered.sum() == pytest.approx(1.0 - env.world.coverage, abs=1e-12)
    assert uncovered[1] > 0 and uncovered[2] > 0 and uncovered[3:].sum() == 0  # 5-10 and 10-20 cm
