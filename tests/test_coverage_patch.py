"""The observation's coverage patch: an egocentric window on the uncleaned floor (``coverage_patch``)."""

import math

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env
from pettingzoo.test import parallel_api_test

from cabinbench import parallel_env
from cabinbench.envs.coverage_env import CoverageEnv
from cabinbench.layouts.fields import RESOLUTION
from cabinbench.sim.coverage import PATCH_SAMPLES, CoveragePatch, write_coverage_patch

from .driving import drive

CELLS, CELL_SIZE = 16, 0.25


def reference_patch(world, x, y, heading, cells=CELLS, cell_size=CELL_SIZE):
    """The patch computed point by point in numpy from its definition, to check the compiled kernel."""
    offsets = (np.arange(cells * PATCH_SAMPLES) + 0.5) * cell_size / PATCH_SAMPLES - cells * cell_size / 2
    ahead, left = np.meshgrid(offsets, offsets, indexing="ij")
    world_x = x + ahead * math.cos(heading) - left * math.sin(heading)
    world_y = y + ahead * math.sin(heading) + left * math.cos(heading)
    origin_x, origin_y = world.layout.origin
    cols = np.floor((world_x - origin_x) / RESOLUTION).astype(int)
    rows = np.floor((world_y - origin_y) / RESOLUTION).astype(int)
    height, width = world.pass_count.shape
    inside = (rows >= 0) & (rows < height) & (cols >= 0) & (cols < width)
    rows, cols = np.where(inside, rows, 0), np.where(inside, cols, 0)
    cell = world.cell_of[rows, cols]
    visible = np.where(cell >= 0, world.cell_visible[np.maximum(cell, 0)], world.protocol == "open")
    uncleaned = inside & world.coverable_mask[rows, cols] & (world.pass_count[rows, cols] == 0) & visible
    return uncleaned.reshape(cells, PATCH_SAMPLES, cells, PATCH_SAMPLES).mean(axis=(1, 3))


def observed_patch(env, observation):
    return observation[env.unwrapped.observation_layout["coverage_patch"]].reshape(CELLS, CELLS)


def test_patch_sits_between_the_rays_and_the_velocities_and_leaves_them_alone():
    plain, patched = CoverageEnv("a320_cell"), CoverageEnv("a320_cell", coverage_patch=CELLS)
    parts = patched.observation_layout
    assert patched.observation_space.shape == (parts["velocity"].stop,)
    assert parts["coverage_patch"] == slice(parts["lidar"].stop, parts["lidar"].stop + CELLS * CELLS)
    assert plain.observation_layout["lidar"] == parts["lidar"]
    assert (
        patched.observation_config["coverage_patch"] == CELLS
        and plain.observation_config["coverage_patch"] == 0
    )
    first, _ = plain.reset(seed=0)
    second, _ = patched.reset(seed=0)
    rng = np.random.default_rng(0)
    for _ in range(200):
        np.testing.assert_array_equal(first[parts["lidar"]], second[parts["lidar"]])
        np.testing.assert_array_equal(first[-2:], second[-2:])
        assert patched.observation_space.contains(second)
        action = rng.uniform(-1, 1, 2)
        first, *_ = plain.step(action)
        second, *_ = patched.step(action)


def test_patch_matches_its_definition_as_the_robot_cleans():
    env = CoverageEnv("a320_cell", coverage_patch=CELLS)
    observation, info = env.reset(seed=0)
    rng = np.random.default_rng(1)
    for step in range(300):
        if step % 25 == 0:
            np.testing.assert_allclose(
                observed_patch(env, observation), reference_patch(env.world, *info["pose"]), atol=1e-6
            )
        observation, _, terminated, truncated, info = env.step([0.8, rng.uniform(-1, 1)])
        if terminated or truncated:
            break
    patch = observed_patch(env, observation)
    assert patch.max() == 1.0 and patch.min() == 0.0  # both dirty floor and cleaned or solid ground in view
    middle = slice(CELLS // 2 - 1, CELLS // 2 + 1)
    assert patch[middle, middle].max() < 0.5  # the robot stands on floor it has just cleaned


def test_patch_turns_with_the_robot():
    env = CoverageEnv("a320_cell", coverage_patch=CELLS)
    env.reset(seed=0)
    world = env.world
    x, y = 1.3, 1.9
    patches = []
    for quarter in range(4):
        out = np.zeros(CELLS * CELLS, dtype=np.float32)
        write_coverage_patch(
            out,
            0,
            x,
            y,
            quarter * math.pi / 2,
            CELLS,
            CELL_SIZE,
            world.pass_count,
            world.coverable_mask,
            world.cell_of,
            world.cell_visible,
            False,
            0.0,
            0.0,
            RESOLUTION,
        )
        patches.append(out.reshape(CELLS, CELLS))
    # After a quarter turn to the left, what was on the left (high columns) lies ahead (high rows)...
    for quarter in range(1, 4):
        same = np.abs(np.rot90(patches[0], k=-quarter) - patches[quarter]) < 1e-6
        assert same.mean() > 0.97  # ...up to samples that land on pixel edges
    assert not np.allclose(patches[0], patches[1])  # the cabin is not symmetric under a quarter turn


def test_sequential_patch_shows_only_floor_that_may_be_cleaned_now():
    env = CoverageEnv("a320_tracking_cell", coverage_patch=CELLS)
    observation, info = env.reset(seed=0)
    world = env.world
    # Cell 0 starts cleared (it counts as clean) and its passage is open: only the next cell's floor
    # shows, so the patch points the way on.
    assert world.cell_visible.tolist() == [False, True]
    patch = observed_patch(env, observation)
    assert (
        patch[: CELLS // 2].sum() == 0 and patch[CELLS // 2 :].sum() > 0
    )  # nothing behind, the next cell ahead
    exit_point = env.layout.passages[0].exits[0]
    info, _ = drive(env, [(exit_point[0] - 0.3, exit_point[1]), tuple(exit_point)])
    assert info["current_cell"] == 1
    assert world.cell_visible.tolist() == [False, True]  # the cell behind the bound no longer counts
    observation = world.observe(0)
    np.testing.assert_allclose(
        observed_patch(env, observation), reference_patch(world, *world.poses[0]), atol=1e-6
    )

    other = CoverageEnv("b777_3col", coverage_patch=CELLS)
    other.reset(seed=0)
    assert other.world.cell_visible.tolist() == [True, False]  # the next cell waits behind its bound
    opened = CoverageEnv("b777_3col", protocol="open", coverage_patch=CELLS)
    opened.reset(seed=0)
    assert opened.world.cell_visible.all()


def test_patched_envs_pass_the_api_checkers():
    check_env(
        gym.make(
            "CabinBench/Coverage-v0", layout="b777_3col", coverage_patch=8, render_mode="rgb_array"
        ).unwrapped,
        skip_render_check=False,
    )
    parallel_api_test(parallel_env(layout="b777_3col", n_agents=2, coverage_patch=8), num_cycles=200)


@pytest.mark.parametrize(
    "cells, cell_size", [(-1, 0.25), (2.5, 0.25), (True, 0.25), (4, 0.0), (4, float("nan"))]
)
def test_bad_patch_settings_are_refused(cells, cell_size):
    with pytest.raises(ValueError, match="coverage_patch"):
        CoveragePatch(cells, cell_size)
    with pytest.raises(ValueError, match="coverage_patch"):
        CoverageEnv("a320_cell", coverage_patch=cells, coverage_patch_cell=cell_size)
