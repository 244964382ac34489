"""The baselines in teams (K robots on one layout): the team planner splits the work so that it
finishes sooner than one robot, its shares partition the layout, the random walk runs in a
team, and a team too large for the layout is refused with a clear message."""

import numpy as np
import pytest
from cabinbench.baselines.boustrophedon import cell_region, reachable, team_plans, team_split

import cabinbench
from cabinbench.commands.run import main as run_main
from cabinbench.episodes import run_episode
from cabinbench.layouts.resolve import load_layout
from cabinbench.sim.world import random_start_poses, start_cell_spots, start_poses


@pytest.mark.parametrize("protocol", ["sequential", "open"])
def test_two_planners_cover_the_cabin_sooner_than_one(protocol):
    single, _ = run_episode("boustrophedon", "shape_changed", 0, protocol, 1)
    team, trajectory = run_episode("boustrophedon", "shape_changed", 0, protocol, 2)
    assert team["success"] and team["coverage"] >= 0.98
    assert team["makespan"] < 0.8 * single["time"]
    assert team["bound_violations"] == 0 and team["robot_collisions"] <= 2
    assert trajectory["positions"].shape[1] == 2 and len(team["path_lengths"]) == 2


@pytest.mark.parametrize(
    ("layout_name", "n_agents", "protocol"),
    [
        ("full_cabin", 4, "sequential"),
        ("full_cabin", 3, "open"),
        ("b777_3col", 2, "sequential"),
    ],
)
def test_team_shares_partition_each_stage(layout_name, n_agents, protocol):
    layout = load_layout(layout_name)
    split = team_split(layout, protocol, n_agents)
    assert sorted(split.ranks) == list(range(n_agents))  # every robot has its place in the convoy
    for stage in split.stages:
        region = reachable(layout) if stage.cell < 0 else cell_region(layout, stage.cell) & reachable(layout)
        counts = np.sum(stage.shares, axis=0)
        assert counts.max() == 1 and np.array_equal(counts > 0, region)  # disjoint and complete
        goals = layout.goals if stage.cell < 0 else layout.cells[stage.cell].goals
        assert sum(len(g) for g in stage.goals) == len(goals)  # every goal marker has one owner
        assert all(share.any() for share in stage.shares[: min(n_agents, 2)])
        for sweep, share in zip(stage.sweeps, stage.shares):
            assert not (sweep & ~share).any()  # a robot sweeps only its own share


def test_team_plans_leave_in_convoy_order():
    """After a cell clears, the robots drive on one after the other, the leader first."""
    layout = load_layout("full_cabin")
    split = team_split(layout, "sequential", 4)
    plans = team_plans(layout, "sequential", 4)
    gates = {
        int(split.ranks[agent]): [leg.delay for leg in legs if leg.gate and leg.after_cell == 3]
        for agent, legs in enumerate(plans)
    }
    delays = [gates[rank][0] for rank in range(4)]
    assert all(later > earlier for earlier, later in zip(delays, delays[1:]))


def test_team_plans_start_where_each_robot_stands():
    """From random starts every robot's plan begins at its own pose (no robot drives to the team's
    start poses first), and the team's start poses give the plans of the default team."""
    layout = load_layout("full_cabin")
    starts = random_start_poses(layout, start_cell_spots(layout), 4, np.random.default_rng(7))
    plans = team_plans(layout, "sequential", 4, starts)
    for start, legs in zip(starts, plans):
        assert np.allclose(legs[0].waypoints[0], start[:2])
    assert sorted(team_split(layout, "sequential", 4, starts).ranks) == list(range(4))
    home, default = (
        team_plans(layout, "sequential", 4, start_poses(layout, 4)),
        team_plans(layout, "sequential", 4),
    )
    assert all(
        np.array_equal(a.waypoints, b.waypoints)
        for legs, others in zip(home, default)
        for a, b in zip(legs, others)
    )


def test_a_team_from_random_starts_covers_the_cabin():
    """Four planners from random spots of the start cell (cabin-v1-test/0000, seed 0) cover the
    cabin without bumping into each other; planned from the team's start poses instead, they drove
    there first, blocked each other in the start cell and covered 0.27."""
    record, _ = run_episode(
        "boustrophedon", "cabin-v1-test/0000", 0, "sequential", 4, env_kwargs={"random_start": True}
    )
    assert record["success"] and record["coverage"] >= 0.97
    assert record["robot_collisions"] <= 2 and record["bound_violations"] == 0


def test_random_bounce_runs_as_a_team_and_records_team_metrics():
    alone, _ = run_episode("random_bounce", "a320_cell", 3, "sequential", 1, env_kwargs={"max_steps": 300})
    record, trajectory = run_episode(
        "random_bounce", "a320_cell", 3, "sequential", 2, env_kwargs={"max_steps": 300}
    )
    assert record["n_agents"] == 2 and trajectory["positions"].shape == (record["steps"] + 1, 2, 2)
    assert 0 < record["makespan"] <= record["time"]
    assert len(record["path_lengths"]) == 2 and min(record["path_lengths"]) > 5.0  # both robots drive
    # Two walkers cover more of the cell than one in the same 300 steps (0.31 against 0.23); blind
    # to each other, they bump into each other (9 times), and the team's record counts it.
    assert record["coverage"] > alone["coverage"] + 0.05
    assert record["robot_collisions"] > 0


def test_too_many_robots_for_the_layout_are_refused():
    with pytest.raises(ValueError, match="room for only"):
        cabinbench.parallel_env(layout="a320_cell", n_agents=100)


def test_run_cli_refuses_too_many_robots_with_a_message(tmp_path, capsys):
    status = run_main(
        [
            "--baseline",
            "random_bounce",
            "--layout",
            "a320_cell",
            "--agents",
            "100",
            "--episodes",
            "1",
            "--out",
            str(tmp_path),
        ]
    )
    assert status == 2 and "room for only" in capsys.readouterr().err
    assert not list(tmp_path.iterdir())
