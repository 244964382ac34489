"""Every registered Gymnasium id, in the MiniGrid pattern: the checker (with renders), many-step
determinism, rendering, pickling and make_vec. A new built-in layout is tested for free."""

import pickle

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import cabinbench  # noqa: F401  (registers the ids)
from cabinbench.metrics import METRICS

ENV_IDS = [env_id for env_id in gym.registry if env_id.startswith("CabinBench/")]


def rollout(env, seed: int, steps: int):
    observation, _ = env.reset(seed=seed)
    actions = np.random.default_rng(seed).uniform(-1, 1, (steps, 2))
    trace = [observation]
    for action in actions:
        observation, reward, terminated, truncated, info = env.step(action)
        trace.append(np.append(observation, [reward, *info["pose"]]))
        if terminated or truncated:
            break
    return np.concatenate(trace)


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_env_passes_gymnasium_checker(env_id):
    env = gym.make(env_id, render_mode="rgb_array")
    check_env(env.unwrapped, skip_render_check=False)
    env.close()


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_same_seed_same_trajectory(env_id):
    first = rollout(gym.make(env_id, lidar_noise=0.02), seed=7, steps=300)
    second = rollout(gym.make(env_id, lidar_noise=0.02), seed=7, steps=300)
    np.testing.assert_array_equal(first, second)
    other = rollout(gym.make(env_id, lidar_noise=0.02), seed=8, steps=300)
    assert first.shape != other.shape or not np.array_equal(first, other)


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_render_and_pickle(env_id):
    env = gym.make(env_id, render_mode="rgb_array")
    env.reset(seed=0)
    env.step(env.action_space.sample())
    frame = env.render()
    assert frame.dtype == np.uint8 and frame.ndim == 3 and frame.shape[2] == 3 and min(frame.shape[:2]) >= 60
    clone = pickle.loads(pickle.dumps(env.unwrapped))
    action = np.array([0.7, 0.2])
    np.testing.assert_array_equal(clone.step(action)[0], env.unwrapped.step(action)[0])


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
    assert observations.shape == (3, 386)
    observations, rewards, *_ = envs.step(np.zeros((3, 2)))
    assert rewards.shape == (3,)
    envs.close()


def test_random_full_cabin_episode_has_every_metric():
    env = gym.make("CabinBench/FullCabin-v0", max_steps=3000)
    env.reset(seed=0)
    rng = np.random.default_rng(0)
    for step in range(3000):
        *_, terminated, truncated, info = env.step(rng.uniform(-1, 1, 2))
        if terminated or truncated:
            break
    assert step == 2999 and truncated
    record = info["episode_record"]
    assert set(METRICS) <= set(record)
    assert record["steps"] == 3000 and record["time"] == pytest.approx(300.0)
    assert 0 < record["coverage"] < 0.5 and record["collisions"] > 0


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
