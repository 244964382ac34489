"""ppo_lstm (``RecurrentTrainConfig``, ``baselines.ppo_gail.recurrent``): a tiny training of 2 iterations
(a320_cell, 4 envs x 16 steps, episodes of 40 steps) exports a policy file that ``run`` plays, and whose
plain-torch memory acts as rsl-rl's recurrent actor does."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest
import torch
from cabinbench.baselines.ppo_gail import cli
from cabinbench.baselines.ppo_gail.policy import read_policy_file
from cabinbench.baselines.ppo_gail.training.checkpoints import checkpoint_path, load_checkpoint
from cabinbench.baselines.ppo_gail.training.config import RecurrentTrainConfig
from cabinbench.baselines.ppo_gail.training.loop import build_runner
from tensordict import TensorDict

from cabinbench.agents import EpisodeContext, load_baseline
from cabinbench.episodes import make_env
from cabinbench.layouts.resolve import load_layout
from tests.test_run_and_leaderboard import run_main

TINY = ["--layout", "a320_cell", "--iterations", "2", "--num-envs", "4", "--steps-per-env", "16"]
TINY += [
    "--max-steps",
    "40",
    "--validation-episodes",
    "1",
    "--save-interval",
    "1",
    "--workers",
    "1",
    "--no-progress",
]


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory):
    folder = tmp_path_factory.mktemp("ppo_lstm")
    assert cli.main(["--baseline", "ppo_lstm", *TINY, "--run-dir", str(folder)]) == 0
    return folder


def observations(policy_path, steps: int = 12) -> tuple[list[np.ndarray], EpisodeContext, dict]:
    """Observations of an episode on a320_cell with the policy's observation settings, driven in a circle."""
    baseline = load_baseline("ppo_lstm", checkpoint=str(policy_path))
    env = make_env(load_layout("a320_cell"), "sequential", 1, baseline.env_options)
    observation, info = env.reset(seed=3)
    context = EpisodeContext(env.unwrapped.layout, "sequential", 3, env_config=baseline.env_options)
    seen = [observation["robot_0"]]
    for _ in range(steps - 1):
        observation, _, _, _, info = env.step({"robot_0": np.array([0.6, 0.4], dtype=np.float32)})
        seen.append(observation["robot_0"])
    return seen, context, info["robot_0"]


def test_a_recurrent_training_exports_a_policy_of_lidar_and_velocity_that_run_plays(run_dir, tmp_path):
    policy = read_policy_file(run_dir / "policy.pt")
    memory = policy["memory"]
    assert policy["ablation"] == "ppo_lstm" and memory["rnn_type"] == "lstm"
    assert policy["observation_config"]["coverage_patch"] == 0  # no map: the memory has to remember
    assert memory["input_size"] == policy["observation_config"]["size"]
    assert policy["actor"]["observation_size"] == memory["hidden_size"] == 64
    config = json.dumps({"checkpoint": str(run_dir / "policy.pt")})
    played = ["--baseline", "ppo_lstm", "--layout", "a320_cell", "--episodes", "1", "--max-steps", "30"]
    assert run_main([*played, "--config", config, "--out", str(tmp_path / "runs")])[0] == 0


def test_the_action_depends_on_the_history_and_reset_forgets_it(run_dir):
    seen, context, info = observations(run_dir / "policy.pt")
    policy = load_baseline("ppo_lstm", checkpoint=str(run_dir / "policy.pt"), stochastic=False)
    policy.reset(context, seen[-1], info)
    fresh = policy.act(seen[-1], info)
    policy.reset(context, seen[0], info)
    for observation in seen[:-1]:
        policy.act(observation, info)
    remembered = policy.act(seen[-1], info)
    assert np.abs(remembered - fresh).max() > 1e-4  # the same observation, another hidden state
    policy.reset(context, seen[-1], info)
    assert np.array_equal(policy.act(seen[-1], info), fresh)


def test_the_exported_memory_acts_as_rsl_rls_recurrent_actor(run_dir):
    config = RecurrentTrainConfig.from_dict(json.loads((run_dir / "config.json").read_text()))
    runner, _ = build_runner(dataclasses.replace(config, workers=1), run_dir)
    load_checkpoint(runner, checkpoint_path(run_dir, 2))
    runner.env.close()
    actor = runner.alg.get_policy()
    actor.eval()
    actor.reset()
    seen, context, info = observations(run_dir / "policy.pt")
    policy = load_baseline("ppo_lstm", checkpoint=str(run_dir / "policy.pt"), stochastic=False)
    policy.reset(context, seen[0], info)
    for observation in seen:
        with torch.no_grad():
            batch = TensorDict({"policy": torch.as_tensor(observation).reshape(1, -1)}, batch_size=[1])
            expected = actor(batch)[0].clamp(-1, 1).numpy()
        assert np.allclose(policy.act(observation, info), expected, atol=1e-6)
