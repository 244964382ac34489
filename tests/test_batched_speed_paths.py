"""The fast paths of the env step give the results of the plain ones: shard workers on shared
memory as one process alone, observations written in place as fresh ones, the compact trajectory
as the poses stepped through."""

import numpy as np
import torch

from cabinbench.envs.batched import BatchedCoverageEnv
from cabinbench.envs.coverage_env import CoverageEnv
from cabinbench.envs.team_env import TeamCoverageEnv


def _batched_run(num_workers: int, actions: torch.Tensor) -> list:
    with BatchedCoverageEnv(
        ["a320_cell", "a320_tracking_cell"],
        num_envs=5,
        seed=2,
        num_workers=num_workers,
        max_steps=30,
        lidar_noise=0.02,
    ) as env:
        steps = [env.step(action) for action in actions]
    return [
        (
            *tensors,
            [(index, {k: v for k, v in record.items() if k != "wall_time"}) for index, record in finished],
        )
        for *tensors, finished in steps
    ]


def test_shard_workers_give_every_result_of_one_process():
    actions = torch.from_numpy(np.random.default_rng(1).uniform(-1.2, 1.2, (70, 5, 2)))
    alone, sharded = _batched_run(1, actions), _batched_run(3, actions)
    for step_alone, step_sharded in zip(alone, sharded):
        assert all(torch.equal(a, b) for a, b in zip(step_alone[:4], step_sharded[:4]))
        assert step_alone[4] == step_sharded[4]
    assert sum(len(step[4]) for step in alone) == 10  # every env truncates at 30 steps, twice in 70


def test_batched_step_returns_tensors_later_steps_leave_alone():
    with BatchedCoverageEnv("a320_cell", num_envs=2, seed=0) as env:
        first = env.step(torch.zeros(2, 2))[:4]
        kept = [tensor.clone() for tensor in first]
        env.step(torch.ones(2, 2))
    assert all(torch.equal(a, b) for a, b in zip(first, kept))


def test_observation_written_in_place_equals_a_fresh_one():
    env = TeamCoverageEnv("a320_tracking_cell", n_agents=1)  # the env core the batches step
    env.reset(seed=0)
    out = np.full(env.world.observation_size, np.nan, dtype=np.float32)
    for _ in range(20):
        env.advance(np.array([[0.8, 0.3]]))
        assert env.world.observe(0, out=out) is out
        np.testing.assert_array_equal(out, env.world.observe(0))


def test_trajectory_is_every_position_stepped_through():
    env = CoverageEnv("a320_cell")
    env.reset(seed=0)
    positions = [env.world.poses[:, :2].copy()]
    for _ in range(25):
        env.step([0.6, -0.4])
        positions.append(env.world.poses[:, :2].copy())
    np.testing.assert_array_equal(env.tracker.trajectory(), np.array(positions))
