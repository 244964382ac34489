"""The multi-robot PettingZoo env: PettingZoo's own test suite, a many-step determinism test of
ours (``parallel_seed_test`` stops after one step), team physics and sensing, the global state
and SuperSuit's vector wrappers."""

import math

import numpy as np
import pytest
import supersuit
from gymnasium.utils.env_checker import data_equivalence
from pettingzoo.test import (
    api_test,
    max_cycles_test,
    parallel_api_test,
    parallel_seed_test,
    render_test,
    seed_test,
    state_test,
)

import cabinbench
from cabinbench.envs.team_env import TeamCoverageEnv
from cabinbench.layouts.load import parse_layout
from cabinbench.sim.render import ROBOT_COLOURS

SMALL = {"layout": "a320_cell", "n_agents": 2}
ROBOT_TAG = 5  # offset of the ``robot`` one-hot entry inside a ray's block of 6


def corridor(success_coverage: float):
    """A 1.2 m × 0.5 m room: two robots side by side, heading along it."""
    return parse_layout(
        "kind: polygons\npolygons:\n  boundary: [[0, 0], [1.2, 0], [1.2, 0.5], [0, 0.5]]\n"
        f"start: [0.3, 0.25, 0]\nsuccess_coverage: {success_coverage}\n",
        default_name="corridor",
    )


def steer_to(pose, target, speed=1.0):
    """(linear, angular) that turns a robot towards ``target`` and drives once it faces it."""
    error = math.atan2(target[1] - pose[1], target[0] - pose[0]) - pose[2]
    error = (error + math.pi) % (2 * math.pi) - math.pi
    return np.array([speed if abs(error) < 0.2 else 0.0, np.clip(2.0 * error, -1.0, 1.0)])


# ------------------------------------------------------------------------- PettingZoo's suite
def test_parallel_api():
    parallel_api_test(cabinbench.parallel_env(**SMALL), num_cycles=300)


def test_parallel_api_with_team_success():
    env = cabinbench.parallel_env(layout=corridor(0.35), n_agents=2, protocol="open")
    for index, agent in enumerate(env.possible_agents):
        env.action_space(agent).seed(index)  # the test samples from the spaces: make it repeatable
    parallel_api_test(env, num_cycles=300)
    assert env.tracker.record()["success"]  # the last episode ended on termination, not truncation


def test_aec_api():
    api_test(cabinbench.env(**SMALL), num_cycles=100)


def test_render_modes():
    render_test(lambda render_mode=None: cabinbench.env(**SMALL, render_mode=render_mode))


def test_max_cycles():
    max_cycles_test(cabinbench)


def test_pettingzoo_seed_tests():
    parallel_seed_test(lambda: cabinbench.parallel_env(**SMALL, lidar_noise=0.02))
    seed_test(lambda: cabinbench.env(**SMALL, lidar_noise=0.02), num_cycles=50)


def test_state_suite():
    state_test(cabinbench.env(**SMALL), cabinbench.parallel_env(**SMALL))


def test_aec_form_wraps_the_same_env():
    assert isinstance(cabinbench.env(**SMALL).unwrapped, TeamCoverageEnv)


# ------------------------------------------------------------------------- determinism
def rollout(seed: int, actions: np.ndarray):
    env = cabinbench.parallel_env(**SMALL, lidar_noise=0.02, max_steps=len(actions), record_in_info=True)
    observations, infos = env.reset(seed=seed)
    trace = [(observations, infos)]
    for step_actions in actions:
        observations, rewards, terminations, truncations, infos = env.step(
            dict(zip(env.agents, step_actions))
        )
        for info in infos.values():
            info.get("episode_record", {}).pop("wall_time", None)  # real seconds: never reproducible
        trace.append((observations, rewards, terminations, truncations, infos, env.state()))
    assert not env.agents  # the run went to the end of the episode
    return trace


def test_same_seed_same_multi_step_trajectory():
    actions = np.random.default_rng(0).uniform(-1, 1, (250, 2, 2))
    first, second = rollout(7, actions), rollout(7, actions)
    assert len(first) == 251
    for step, (a, b) in enumerate(zip(first, second)):
        assert data_equivalence(a, b), f"runs differ at step {step}"
    assert "episode_record" in first[-1][4]["robot_0"]
    other = rollout(8, actions)  # the seed drives the lidar noise
    assert not data_equivalence(first[1][0], other[1][0])


# ------------------------------------------------------------------------- team physics
@pytest.mark.parametrize("layout", ["full_cabin", "b777_3col"])
@pytest.mark.parametrize("n_agents", [1, 2, 4])
def test_robots_start_at_distinct_valid_poses(layout, n_agents):
    env = cabinbench.parallel_env(layout=layout, n_agents=n_agents)
    _, infos = env.reset(seed=0)
    assert env.agents == [f"robot_{index}" for index in range(n_agents)]
    poses = np.array([infos[agent]["pose"] for agent in env.agents])
    np.testing.assert_allclose(poses[0], env.layout.start)
    tool_width = env.layout.robot.tool_width
    for index, (x, y, _) in enumerate(poses):
        assert env.layout.centre_free[env.layout.to_pixel(x, y)]
        for other in poses[index + 1 :]:
            assert math.dist((x, y), other[:2]) >= tool_width
    _, _, _, _, infos = env.step({})  # standing still: nobody touches anything
    assert all(info["collisions"] == info["robot_collisions"] == 0 for info in infos.values())


def test_too_many_robots_is_a_clear_error():
    with pytest.raises(ValueError, match=r"room for only \d+ robots"):
        cabinbench.parallel_env(layout="paper_matrix_a", n_agents=12)
    with pytest.raises(ValueError, match="n_agents"):
        cabinbench.parallel_env(layout="a320_cell", n_agents=0)


def test_robots_see_and_bump_into_each_other():
    env = cabinbench.parallel_env(**SMALL)
    observations, infos = env.reset(seed=0)
    mine, theirs = infos["robot_0"]["pose"], infos["robot_1"]["pose"]
    rays = observations["robot_0"][:-2].reshape(-1, 6)
    seen = rays[rays[:, ROBOT_TAG] == 1, 0] * 3.5
    gap = math.dist(mine[:2], theirs[:2]) - env.layout.robot.radius
    assert len(seen) and abs(seen.min() - gap) < 0.02  # the nearest robot ray hits the other disc

    for _ in range(100):
        poses = {agent: info["pose"] for agent, info in infos.items()}
        actions = {
            "robot_0": steer_to(poses["robot_0"], poses["robot_1"]),
            "robot_1": steer_to(poses["robot_1"], poses["robot_0"]),
        }
        *_, infos = env.step(actions)
        if infos["robot_0"]["robot_collisions"]:
            break
    assert infos["robot_0"]["robot_collisions"] > 0 and infos["robot_1"]["robot_collisions"] > 0
    assert env.tracker.record()["robot_collisions"] > 0


def test_collisions_are_counted_per_robot():
    env = cabinbench.parallel_env(layout=corridor(0.99), n_agents=2, protocol="open")
    env.reset(seed=0)
    for _ in range(20):  # robot_1 drives into the far wall; robot_0 waits
        *_, infos = env.step({"robot_1": [1.0, 0.0]})
    assert infos["robot_1"]["collisions"] > 0 and infos["robot_0"]["collisions"] == 0
    assert env.tracker.collisions == infos["robot_1"]["collisions"]


def test_shared_coverage_grows_from_both_robots():
    one, both = (
        cabinbench.parallel_env(layout=corridor(0.99), n_agents=2, protocol="open") for _ in range(2)
    )
    _, start = one.reset(seed=0)
    both.reset(seed=0)
    for _ in range(6):  # robot_1 drives east; in `both` robot_0 also backs up west
        *_, alone = one.step({"robot_1": [1.0, 0.0]})  # robot_0 has no action: it stands still
        *_, together = both.step({"robot_0": [-1.0, 0.0], "robot_1": [1.0, 0.0]})
    np.testing.assert_array_equal(alone["robot_0"]["pose"], start["robot_0"]["pose"])
    assert alone["robot_0"]["path_length"] == 0 < alone["robot_1"]["path_length"]
    assert start["robot_0"]["coverage"] < alone["robot_0"]["coverage"] < together["robot_0"]["coverage"]
    assert together["robot_0"]["coverage"] == together["robot_1"]["coverage"]  # one raster


def test_team_success_terminates_everyone_with_a_record():
    env = cabinbench.parallel_env(layout=corridor(0.5), n_agents=2, protocol="open", reward="coverage")
    env.reset(seed=0)
    for _ in range(20):  # the robots drive apart, each cleaning its half
        _, rewards, terminations, truncations, infos = env.step(
            {"robot_0": [-1.0, 0.0], "robot_1": [1.0, 0.0]}
        )
        if not env.agents:
            break
    assert all(terminations.values()) and not any(truncations.values())
    assert (
        rewards.keys() == infos.keys() == set(env.possible_agents)
    )  # the finishing agents get their last step
    record = env.episode_record
    assert record["success"] and record["n_agents"] == 2 and len(record["path_lengths"]) == 2
    assert {"makespan", "load_balance", "robot_collisions"} <= record.keys()
    with pytest.raises(RuntimeError, match="reset"):
        env.step({})


def test_bad_actions_are_refused():
    env = cabinbench.parallel_env(**SMALL)
    env.reset(seed=0)
    with pytest.raises(ValueError, match="unknown agent"):
        env.step({"robot_7": [0.0, 0.0]})
    with pytest.raises(ValueError, match="NaN"):
        env.step({"robot_0": [math.nan, 0.0]})
    with pytest.raises(ValueError, match=r"must have shape \(2,\)"):
        env.step({"robot_0": [0.0, 0.0, 0.0]})


# ------------------------------------------------------------------------- state and render
@pytest.mark.parametrize("n_agents", [1, 4])
def test_state_has_the_declared_shape(n_agents):
    env = cabinbench.parallel_env(layout="b777_3col", n_agents=n_agents)
    _, infos = env.reset(seed=0)
    assert env.state_space.shape == (6 * n_agents + 4 + len(env.layout.goals),)
    for _ in range(5):
        state = env.state()
        assert state.shape == env.state_space.shape and state.dtype == np.float32
        assert env.state_space.contains(state)
        *_, infos = env.step({agent: env.action_space(agent).sample() for agent in env.agents})
    xmin, ymin, xmax, ymax = env.layout.extent
    x, y, heading = infos["robot_0"]["pose"]
    np.testing.assert_allclose(
        env.state()[:4],
        [(x - xmin) / (xmax - xmin), (y - ymin) / (ymax - ymin), math.cos(heading), math.sin(heading)],
        atol=1e-6,
    )


def test_rgb_frame_shows_every_robot_in_its_colour():
    env = cabinbench.parallel_env(layout="a320_cell", n_agents=3, render_mode="rgb_array")
    env.reset(seed=0)
    frame = env.render()
    assert frame.dtype == np.uint8 and frame.ndim == 3 and frame.shape[2] == 3
    for colour in ROBOT_COLOURS[:3]:
        assert (frame == colour).all(axis=2).any()


# ------------------------------------------------------------------------- vector wrappers
def test_supersuit_vector_env_steps_and_resets():
    env = supersuit.pettingzoo_env_to_vec_env_v1(cabinbench.parallel_env(**SMALL, max_steps=3))
    envs = supersuit.concat_vec_envs_v1(env, 2, num_cpus=0, base_class="gymnasium")
    observations, _ = envs.reset(seed=0)
    size = cabinbench.parallel_env(**SMALL).observation_space("robot_0").shape[0]
    assert observations.shape == (4, size)  # 2 envs × 2 robots
    for step in range(5):  # the episodes end at step 3 and reset themselves
        observations, rewards, terminations, truncations, infos = envs.step(np.full((4, 2), 0.5))
        assert observations.shape == (4, size) and rewards.shape == (4,)
        assert truncations.all() == (step == 2)
    envs.close()
