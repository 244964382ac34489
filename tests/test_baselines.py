"""The classic baselines in the real env: the planner covers cabins, the random walk does not."""

import numpy as np
import pytest
from cabinbench.baselines.boustrophedon import plan_layout, record_demonstrations, team_share
from cabinbench.baselines.ppo_gail.demonstrations import load_demonstrations

from cabinbench.agents import EpisodeContext, load_baseline
from cabinbench.envs.coverage_env import CoverageEnv
from cabinbench.layouts.resolve import load_layout
from cabinbench.sim.physics import TIME_STEP


def run_episode(baseline_name, layout, protocol, seed=0, **env_kwargs):
    env = CoverageEnv(layout, protocol=protocol, **env_kwargs)
    observation, info = env.reset(seed=seed)
    baseline = load_baseline(baseline_name)
    context = EpisodeContext(env.layout, protocol, seed, observation_layout=env.observation_layout)
    baseline.reset(context, observation, info)
    while True:
        observation, _, terminated, truncated, info = env.step(baseline.act(observation, info))
        if terminated or truncated:
            return env.episode_record


@pytest.mark.parametrize("protocol", ["sequential", "open"])
def test_boustrophedon_covers_the_a320_cell(protocol):
    record = run_episode("boustrophedon", "a320_cell", protocol)
    assert record["success"] and record["coverage"] >= 0.98
    assert record["bound_violations"] == 0 and record["collisions"] <= 2


def test_boustrophedon_cleans_two_cells_in_order():
    record = run_episode("boustrophedon", "shape_changed", "sequential")
    assert record["success"] and record["cells_cleared"] == 2 and record["coverage"] >= 0.98
    assert record["bound_violations"] == 0


def test_random_bounce_covers_clearly_less_in_the_same_limit():
    planner = run_episode("boustrophedon", "a320_cell", "open")
    random = [run_episode("random_bounce", "a320_cell", "open", seed=seed) for seed in range(3)]
    assert max(r["coverage"] for r in random) < planner["coverage"] - 0.15
    assert all(r["time"] > planner["time"] for r in random)


def bounce_turns(baseline_name, steps=600):
    """The angle of each turn on the spot (radians), over ``steps`` of a real a320_cell episode."""
    env = CoverageEnv("a320_cell")
    observation, info = env.reset(seed=0)
    baseline = load_baseline(baseline_name)
    context = EpisodeContext(env.layout, "sequential", 0, observation_layout=env.observation_layout)
    baseline.reset(context, observation, info)
    turns, turning = [], 0.0
    for _ in range(steps):
        action = baseline.act(observation, info)
        if action[0] == 0.0:  # on the spot: this step turns action[1] of the full turn rate
            turning += abs(action[1]) * env.layout.robot.max_turn_rate * TIME_STEP
        elif turning:
            turns.append(turning)
            turning = 0.0
        observation, *_, info = env.step(action)
    return turns


def test_the_studys_random_motion_turns_by_any_angle():
    # §2.2.1: "turns its heading with a random degree"; random_bounce keeps clear of turns under pi/4
    study, ours = bounce_turns("random_bounce_study"), bounce_turns("random_bounce")
    assert len(study) > 10 and len(ours) > 10
    assert min(study) < np.pi / 4 <= min(ours)


def test_full_cabin_plan_visits_every_cell_and_exit():
    legs = plan_layout(load_layout("full_cabin"), "sequential")
    assert [leg.cell for leg in legs if leg.purpose == "sweep"] == list(range(10))
    assert sum(leg.purpose == "exit" for leg in legs) == 9
    layout = load_layout("full_cabin")
    for leg in legs:  # every waypoint is a pose where the robot's disc touches nothing
        assert (layout.distance_to_walls(leg.waypoints) > layout.robot.radius).all()


def test_team_shares_split_the_region_evenly():
    layout = load_layout("full_cabin")
    shares = [team_share(layout, layout.centre_free, agent, 4) for agent in range(4)]
    assert np.array_equal(np.sum(shares, axis=0), layout.centre_free.astype(int))  # disjoint, complete
    sizes = [share.sum() for share in shares]
    assert max(sizes) / min(sizes) < 1.15  # strips end on whole raster columns


def test_demonstrations_are_recorded_in_the_documented_schema(tmp_path):
    path = tmp_path / "demos.npz"
    summary = record_demonstrations("a320_cell", episodes=2, path=str(path), seed=3)
    assert summary["success"] == 1.0
    data = np.load(path, allow_pickle=False)
    assert set(data.files) == {"observations", "actions", "episode", "observation_config"}
    (observation_size,) = CoverageEnv("a320_cell").observation_space.shape
    assert data["observations"].shape == (summary["steps"], observation_size)
    assert data["actions"].shape == (summary["steps"], 2)
    assert set(np.unique(data["episode"])) == {0, 1}
    observations, actions = load_demonstrations([str(path)], observation_dim=observation_size, action_dim=2)
    assert observations.shape[0] == actions.shape[0] == summary["steps"]
    assert np.abs(actions.numpy()).max() <= 1.0


def test_noisy_demonstrations_vary_per_episode_and_record_the_planners_own_actions(tmp_path):
    def record(name: str, action_noise: float) -> dict:
        record_demonstrations(
            "a320_cell",
            episodes=2,
            path=str(tmp_path / name),
            seed=3,
            action_noise=action_noise,
            max_steps=300,
        )
        return dict(np.load(tmp_path / name, allow_pickle=False))

    clean, noisy, again = record("clean.npz", 0.0), record("noisy.npz", 0.3), record("again.npz", 0.3)
    first, second = (noisy["observations"][noisy["episode"] == episode] for episode in (0, 1))
    assert not np.array_equal(first, second)  # each episode drifts its own way...
    clean_first, clean_second = (clean["observations"][clean["episode"] == episode] for episode in (0, 1))
    assert np.array_equal(clean_first, clean_second)  # ...where without noise they repeat one trajectory
    for name in noisy:
        np.testing.assert_array_equal(noisy[name], again[name])  # the noise is seeded
    # The recorded actions are the planner's: they change from step to step by about 0.18 on
    # average (0.11 without noise); the executed ones, with noise of std 0.3 on top, by about 0.36.
    jumps = np.abs(np.diff(noisy["actions"][noisy["episode"] == 0], axis=0)).mean()
    assert jumps < 2 * np.abs(np.diff(clean["actions"][clean["episode"] == 0], axis=0)).mean() + 0.02


def test_a_team_of_two_covers_faster_than_one_robot():
    from cabinbench.episodes import run_episode as run_team_episode

    alone, _ = run_team_episode("boustrophedon", "b777_3col", 0, "sequential", 1, {}, {})
    team, _ = run_team_episode("boustrophedon", "b777_3col", 0, "sequential", 2, {}, {})
    assert team["success"] and team["coverage"] >= 0.98 and team["n_agents"] == 2
    assert team["makespan"] < 0.85 * alone["time"]
    assert team["robot_collisions"] <= 4 and team["load_balance"] < 1.5
