"""Every registered Gymnasium id and the team env, in the MiniGrid pattern: the checker (with
renders), the observation layout, many-step determinism, rendering, copies. A new built-in layout
is tested for free."""

import copy
import pickle
from dataclasses import replace

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env
from pettingzoo.test import parallel_api_test

import cabinbench
from cabinbench.envs.settings import EnvSettings
from cabinbench.errors import LayoutError
from cabinbench.metrics import METRICS
from cabinbench.sim.observation import LIDAR_CHANNELS

ENV_IDS = [env_id for env_id in gym.registry if env_id.startswith("CabinBench/")]
TEAM = "team env (a320_cell, 2 robots)"


def make(name: str, **kwargs):
    if name == TEAM:
        return cabinbench.parallel_env(layout="a320_cell", n_agents=2, **kwargs)
    return gym.make(name, **kwargs).unwrapped


def spaces_of(env) -> list:
    if isinstance(env, gym.Env):
        return [env.observation_space]
    return [env.observation_space(agent) for agent in env.possible_agents]


def step(env, action: np.ndarray) -> tuple[np.ndarray, bool]:
    """One step with every robot on ``action``: (observations, rewards and poses flat; episode over)."""
    if isinstance(env, gym.Env):
        observation, reward, terminated, truncated, info = env.step(action)
        return np.append(observation, [reward, *info["pose"]]), terminated or truncated
    observations, rewards, _, _, infos = env.step(dict.fromkeys(env.agents, action))
    flat = [np.append(observations[a], [rewards[a], *infos[a]["pose"]]) for a in env.possible_agents]
    return np.concatenate(flat), not env.agents


def rollout(env, seed: int, steps: int) -> np.ndarray:
    env.reset(seed=seed)
    trace = []
    for action in np.random.default_rng(seed).uniform(-1, 1, (steps, 2)):
        values, over = step(env, action)
        trace.append(values)
        if over:
            break
    return np.concatenate(trace)


def assert_layout_tiles(observation_layout: dict, size: int, n_rays: int) -> None:
    parts = sorted(observation_layout.values(), key=lambda part: part.start)
    assert parts[0].start == 0 and parts[-1].stop == size
    assert all(left.stop == right.start for left, right in zip(parts, parts[1:]))
    lidar = observation_layout["lidar"]
    assert lidar.stop - lidar.start == n_rays * len(LIDAR_CHANNELS)


@pytest.mark.parametrize("name", [*ENV_IDS, TEAM])
def test_every_env(name):
    env = make(name, render_mode="rgb_array")
    if isinstance(env, gym.Env):
        check_env(gym.make(name, render_mode="rgb_array").unwrapped, skip_render_check=False)
    else:
        parallel_api_test(make(name), num_cycles=200)

    for kwargs in ({}, {"n_rays": 16, "coverage_patch": 8}):
        made = make(name, **kwargs)
        for space in spaces_of(made):
            assert_layout_tiles(made.observation_layout, space.shape[0], kwargs.get("n_rays", 64))
        assert ("coverage_patch" in made.observation_layout) == bool(kwargs)

    first = rollout(make(name, lidar_noise=0.02), seed=7, steps=200)
    np.testing.assert_array_equal(first, rollout(make(name, lidar_noise=0.02), seed=7, steps=200))
    other = rollout(make(name, lidar_noise=0.02), seed=8, steps=200)
    assert first.shape != other.shape or not np.array_equal(first, other)

    env.reset(seed=0)
    for action in np.random.default_rng(0).uniform(-1, 1, (30, 2)):
        step(env, action)
    frame = env.render()
    assert frame.dtype == np.uint8 and frame.ndim == 3 and frame.shape[2] == 3 and min(frame.shape[:2]) >= 60
    copies = [copy.deepcopy(env), pickle.loads(pickle.dumps(env))]
    for action in np.random.default_rng(1).uniform(-1, 1, (20, 2)):
        values = step(env, action)[0]
        for clone in copies:
            np.testing.assert_array_equal(step(clone, action)[0], values)


def test_generic_id_takes_a_layout_name_or_file(tmp_path):
    env = gym.make("CabinBench/Coverage-v0", layout="paper_matrix_a")
    assert env.unwrapped.layout.name == "paper_matrix_a"
    path = tmp_path / "room.yaml"
    path.write_text(
        "kind: polygons\npolygons:\n  boundary: [[0, 0], [2, 0], [2, 2], [0, 2]]\nstart: [1, 1]\n"
    )
    env = gym.make("CabinBench/Coverage-v0", layout=str(path), protocol="open")
    observation, _ = env.reset(seed=0)
    assert env.observation_space.contains(observation)


def test_make_vec_steps_several_envs():
    envs = gym.make_vec("CabinBench/A320Cell-v0", num_envs=3, vectorization_mode="sync")
    observations, _ = envs.reset(seed=0)
    assert observations.shape == (3, gym.make("CabinBench/A320Cell-v0").observation_space.shape[0])
    observations, rewards, *_ = envs.step(np.zeros((3, 2)))
    assert rewards.shape == (3,)
    envs.close()


def test_random_full_cabin_episode_has_every_metric():
    env = gym.make("CabinBench/FullCabin-v0", max_steps=3000)
    env.reset(seed=0)
    rng = np.random.default_rng(0)
    for _ in range(3000):
        *_, terminated, truncated, info = env.step(rng.uniform(-1, 1, 2))
        if terminated or truncated:
            break
    assert truncated
    record = env.unwrapped.episode_record
    assert set(METRICS) <= set(record)
    assert record["steps"] == 3000 and record["time"] == pytest.approx(300.0)
    assert 0 < record["coverage"] < 0.5 and record["collisions"] > 0


BAD_SETTINGS = [
    ("n_rays", 0),
    ("n_rays", 2.5),
    ("lidar_range", -1.0),
    ("lidar_range", float("nan")),
    ("field_of_view", 0.0),
    ("field_of_view", 7.0),
    ("lidar_noise", -0.1),
    ("lidar_range", True),  # YAML's and JSON's true is a bool, which Python counts as 1
    ("coverage_patch", True),
    ("coverage_patch_cell", True),
]


@pytest.mark.parametrize("name, value", [*BAD_SETTINGS, ("max_steps", 0), ("max_steps", -5)])
def test_bad_env_settings_are_refused_naming_the_argument(name, value):
    with pytest.raises(ValueError, match=f"^{name} must be"):
        gym.make("CabinBench/Coverage-v0", **{name: value})


TEAM_BAD_SETTINGS = [
    ("max_steps", 0),
    ("n_agents", 0),
    ("n_agents", 2.0),
    ("team_weight", float("nan")),
    ("team_weight", True),
]


@pytest.mark.parametrize("name, value", [*BAD_SETTINGS, *TEAM_BAD_SETTINGS, ("team_weight", -1.0)])
def test_bad_team_env_settings_are_refused_naming_the_argument(name, value):
    with pytest.raises(ValueError, match=f"^{name} must be"):
        cabinbench.parallel_env(**{"layout": "a320_cell", "n_agents": 2, name: value})


def test_bad_actions_are_clipped_or_refused():
    env = gym.make("CabinBench/A320Cell-v0").unwrapped
    env.reset(seed=0)
    clipped = env.step([5.0, 0.0])[4]["pose"]
    env.reset(seed=0)
    unit = env.step([1.0, 0.0])[4]["pose"]
    np.testing.assert_allclose(clipped, unit)
    with pytest.raises(ValueError, match="NaN"):
        env.step([np.nan, 0.0])


def test_batched_env_matches_single_envs_and_does_not_depend_on_workers():
    import torch

    from cabinbench.envs.batched import BatchedCoverageEnv

    actions = torch.from_numpy(np.random.default_rng(0).uniform(-1, 1, (120, 4, 2)))
    runs = []
    for workers in (1, 2):
        with BatchedCoverageEnv(
            ["a320_cell", "a320_tracking_cell"], num_envs=4, seed=5, num_workers=workers, max_steps=50
        ) as env:
            steps = [env.step(action) for action in actions]
        runs.append(
            (torch.stack([s[0] for s in steps]), torch.stack([s[1] for s in steps]), [s[4] for s in steps])
        )
    assert torch.equal(runs[0][0], runs[1][0]) and torch.equal(runs[0][1], runs[1][1])
    finished = [item for step in runs[0][2] for item in step]
    assert len(finished) == 8  # every env truncates at 50 steps, twice in 120
    # env 1 of the batch behaves as a single env seeded 5 + 1 on the tracking cell
    single = gym.make("CabinBench/A320TrackingCell-v0", max_steps=50).unwrapped
    single.reset(seed=6)
    for action, batched_observation in zip(actions[:40, 1], runs[0][0][:40, 1]):
        observation = single.step(action.numpy())[0]
        np.testing.assert_array_equal(observation, batched_observation.numpy())


def infos_of(env, info_or_infos) -> list[dict]:
    return [info_or_infos] if isinstance(env, gym.Env) else list(info_or_infos.values())


@pytest.mark.parametrize("name", [*ENV_IDS, TEAM])
def test_infos_keep_the_reset_keys_and_hold_numpy_values_to_the_end(name):
    """What Minari's record_infos, TorchRL's info readers and PettingZooWrapper rely on: one set of
    keys through the episode (the record only in ``episode_record``), numpy values they can stack."""
    env = make(name, max_steps=6)
    _, reset_info = env.reset(seed=0)
    keys = [set(info) for info in infos_of(env, reset_info)]
    over = False
    for step_number in range(6):
        if isinstance(env, gym.Env):
            *_, terminated, truncated, info = env.step(np.array([1.0, 0.3]))
            over = terminated or truncated
        else:
            *_, info = env.step(dict.fromkeys(env.agents, np.array([1.0, 0.3])))
            over = not env.agents
        for agent_keys, agent_info in zip(keys, infos_of(env, info), strict=True):
            assert set(agent_info) == agent_keys, f"step {step_number}"
            assert all(isinstance(value, (np.generic, np.ndarray)) for value in agent_info.values()), (
                agent_info
            )
    assert over and env.episode_record["steps"] == 6


def test_record_in_info_puts_the_record_in_the_last_infos():
    env = gym.make("CabinBench/A320Cell-v0", max_steps=3, record_in_info=True)
    env.reset(seed=0)
    infos = [env.step(np.zeros(2))[4] for _ in range(3)]
    assert ["episode_record" in info for info in infos] == [False, False, True]
    assert infos[-1]["episode_record"] is env.unwrapped.episode_record
    team = cabinbench.parallel_env(layout="a320_cell", n_agents=2, max_steps=2, record_in_info=True)
    team.reset(seed=0)
    infos = [team.step({})[4] for _ in range(2)]
    assert [
        sorted(agent for agent, info in step_infos.items() if "episode_record" in info)
        for step_infos in infos
    ] == [
        [],
        ["robot_0", "robot_1"],
    ]


def test_both_envs_take_one_settings_object_and_refuse_unknown_arguments():
    settings = EnvSettings(n_rays=16, coverage_patch=4, max_steps=9)
    single = gym.make("CabinBench/A320Cell-v0", settings=settings).unwrapped
    team = cabinbench.parallel_env(layout="a320_cell", n_agents=2, settings=settings, reward="coverage")
    assert single.settings == settings and team.settings == replace(settings, reward="coverage")
    assert single.observation_space.shape == team.observation_space("robot_1").shape == (6 * 16 + 16 + 2,)
    assert single.max_steps == team.max_steps == 9
    with pytest.raises(TypeError, match="unknown env argument 'n_ray'; the arguments are layout, protocol"):
        gym.make("CabinBench/A320Cell-v0", n_ray=16)


@pytest.mark.parametrize("layout", [123, 4.5, ["a320_cell"], None])
def test_a_layout_that_is_no_name_or_path_is_a_layout_error(layout):
    with pytest.raises(LayoutError, match=r"field 'layout': a \w+ is not a layout\. Fix: give a layout name"):
        gym.make("CabinBench/Coverage-v0", layout=layout)
    with pytest.raises(LayoutError):
        cabinbench.parallel_env(layout=layout)


def test_complex_actions_are_refused():
    import torch

    env = gym.make("CabinBench/A320Cell-v0").unwrapped
    env.reset(seed=0)
    for action in ([1 + 1j, 0.0], np.array([0.5, 0.5j]), torch.tensor([1.0, 0.0], dtype=torch.complex64)):
        with pytest.raises(ValueError, match="action must be real numbers, got complex"):
            env.step(action)
