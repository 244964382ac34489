"""The learned team baseline ``ppo_gail_team``: its batched team env, its training (real rsl-rl, real team
envs: checkpoints, resume, determinism, the actor started from ``ppo_gail``), and its shipped policy driving a
plain PettingZoo episode."""

from __future__ import annotations

import os
import subprocess
import sys

os.environ.setdefault("GIT_PYTHON_REFRESH", "quiet")  # rsl-rl's logger imports GitPython

import numpy as np
import pytest
import torch
from cabinbench.baselines.ppo_gail import training
from cabinbench.baselines.ppo_gail.policy import CHECKPOINT_DIR, read_policy_file
from cabinbench.baselines.ppo_gail.team_training import TeamTrainConfig
from cabinbench.baselines.ppo_gail.training.loop import build_runner

import cabinbench
from cabinbench import training_records
from cabinbench.agents import load_baseline
from cabinbench.envs.batched_team import BatchedTeamEnv
from cabinbench.episodes import run_episode

PATCH = {"coverage_patch": 32, "coverage_patch_cell": 0.125}  # the shipped ppo_gail's observation


def tiny_config(**overrides) -> TeamTrainConfig:
    """2 team envs x 2 robots x 16 steps, 30-step episodes on one cell."""
    settings = dict(
        layouts=["a320_cell"],
        n_agents=2,
        num_envs=2,
        num_steps_per_env=16,
        num_mini_batches=1,
        iterations=3,
        max_steps=30,
        demo_episodes=1,
        save_interval=1,
        validation_episodes=1,
        validation_interval=1,
    )
    return TeamTrainConfig(**{**settings, **overrides})


def test_batched_team_env_rows_are_the_team_envs_robots():
    """Row i * K + k is robot k of env i, stepped exactly as a PettingZoo team env seeded seed + i; all
    rows of a team end together and restart from the env's own generator; the state rows carry the env's
    state() and the robot's one-hot index."""
    kwargs = {"n_agents": 2, "reward": "coverage", "random_start": True, **PATCH}
    batched = BatchedTeamEnv("a320_cell", num_envs=2, seed=5, max_steps=12, **kwargs)
    references = [cabinbench.parallel_env(layout="a320_cell", max_cycles=12, **kwargs) for _ in range(2)]
    observations = [env.reset(seed=5 + index)[0] for index, env in enumerate(references)]
    rng = np.random.default_rng(0)
    ended = 0
    for _ in range(20):  # past the 12-step limit: one reset of every env
        for index, env in enumerate(references):
            rows = slice(2 * index, 2 * index + 2)
            np.testing.assert_array_equal(
                batched.observations[rows], [observations[index][a] for a in env.agents]
            )
            np.testing.assert_array_equal(batched.states[rows, :-2], [env.state()] * 2)
            np.testing.assert_array_equal(batched.states[rows, -2:], np.eye(2))
        actions = rng.uniform(-1, 1, (4, 2))
        _, rewards, terminated, truncated, finished = batched.step(torch.as_tensor(actions))
        for index, env in enumerate(references):
            result = env.step({agent: actions[2 * index + k] for k, agent in enumerate(env.agents)})
            observations[index], reward, _, truncation = result[:4]
            assert rewards[2 * index : 2 * index + 2].tolist() == pytest.approx(list(reward.values()))
            assert truncated[2 * index : 2 * index + 2].tolist() == [truncation["robot_0"]] * 2
            if truncation["robot_0"]:
                ours = dict(finished)[index]
                assert {**ours, "wall_time": 0} == {**env.episode_record, "wall_time": 0}
                observations[index] = env.reset()[0]
                ended += 1
        assert not terminated.any()
    assert ended == 2


def test_team_training_checkpoints_resumes_and_exports_a_team_policy(tmp_path):
    run_dir = tmp_path / "run"
    first = training.train(tiny_config(iterations=2), run_dir, progress=False)
    assert sorted(path.name for path in (run_dir / "checkpoints").iterdir()) == [
        "model_000001.pt",
        "model_000002.pt",
    ]
    demos = np.load(run_dir / "demos" / "a320_cell.npz")
    assert set(np.unique(demos["episode"])) == {0} and len(demos["actions"]) == 2 * 30  # both robots' pairs
    with pytest.raises(ValueError, match="n_agents"):
        training.train(tiny_config(n_agents=3), run_dir, resume=True, progress=False)

    result = training.train(tiny_config(), run_dir, resume=True, progress=False)
    assert first.iterations == 2 and result.iterations == 3 and not result.interrupted
    rows = training_records.read_metrics(run_dir / "metrics.csv")
    assert [row["iteration"] for row in rows] == ["1", "2", "3"]
    assert int(rows[-1]["timesteps"]) == 3 * (2 * 2) * 16  # robot steps: envs x robots x steps
    assert any(row["episodes"] != "0" for row in rows)
    validation = training_records.read_metrics(run_dir / "validation.csv")
    assert [row["iteration"] for row in validation] == ["1", "2", "3"]  # team episodes of every checkpoint
    assert all(row["layout"].startswith("cabin-v1-val/") for row in validation)  # as a single robot's

    policy = read_policy_file(result.policy_path)
    assert policy["ablation"] == "ppo_gail_team" and policy["training"]["iterations"] == 3
    assert policy["env_config"]["n_agents"] == 2
    record, _ = run_episode(
        "ppo_gail_team",
        "a320_cell",
        seed=0,
        n_agents=2,
        env_kwargs={"max_steps": 40},
        config={"checkpoint": str(result.policy_path)},
    )
    assert record["n_agents"] == 2 and record["steps"] == 40 and min(record["path_lengths"]) > 0


def test_team_training_is_deterministic_and_the_critic_switch_changes_its_input(tmp_path):
    """Same seed, same weights; the actor starts as the shipped ppo_gail's; the centralised critic sees
    the team state besides the robot's observation, the local one only the observation."""

    def weights(name: str, **overrides) -> dict:
        training.train(
            tiny_config(iterations=2, validation_episodes=0, **overrides), tmp_path / name, progress=False
        )
        return torch.load(tmp_path / name / "checkpoints" / "model_000002.pt", weights_only=True)

    first, again, other_seed = weights("a"), weights("b"), weights("c", seed=1)
    for key in ("actor_state_dict", "critic_state_dict", "discriminator_state_dict", "curiosity_state_dict"):
        for name, tensor in first[key].items():
            assert torch.equal(tensor, again[key][name]), (key, name)
    assert not torch.equal(
        first["actor_state_dict"]["mlp.0.weight"], other_seed["actor_state_dict"]["mlp.0.weight"]
    )

    config = tiny_config(validation_episodes=0)
    runner, _ = build_runner(config, tmp_path / "a")
    shipped = read_policy_file(CHECKPOINT_DIR / "ppo_gail.pt")
    observations = runner.env.get_observations()
    with torch.no_grad():
        torch.testing.assert_close(
            runner.get_inference_policy()(observations), shipped["network"](observations["policy"])
        )
    size, state_size = observations["policy"].shape[1], observations["state"].shape[1]
    assert runner.alg.critic.obs_dim == size + state_size
    local, _ = build_runner(tiny_config(centralised_critic=False), tmp_path / "a")
    assert local.alg.critic.obs_dim == size


def test_train_cli_team_options():
    """The team options belong to ppo_gail_team: elsewhere they are a usage error (exit 2, one line)."""
    completed = subprocess.run(
        [sys.executable, "-m", "cabinbench.train", "--baseline", "ppo_gail", "--agents", "2"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert completed.returncode == 2 and "ppo_gail_team" in completed.stderr
    assert "Traceback" not in completed.stderr


def test_shipped_team_policy_drives_a_plain_pettingzoo_episode():
    """The README's example: load the shipped policy, step cabinbench.parallel_env with its actions."""
    path = CHECKPOINT_DIR / "ppo_gail_team.pt"
    assert path.is_file(), f"{path} is missing: python -m cabinbench.train --baseline ppo_gail_team --ship"
    assert path.stat().st_size < 1_000_000
    team = load_baseline("ppo_gail_team", stochastic=False)
    assert team.policy["training"]["iterations"] > 0
    env = cabinbench.parallel_env(layout="full_cabin", n_agents=2, max_cycles=60, **team.env_options)
    observations, infos = env.reset(seed=0)
    start = infos["robot_0"]["coverage"]
    while env.agents:
        with torch.no_grad():
            actions = {
                agent: team.policy["network"](torch.as_tensor(observation)[None])[0].clamp(-1, 1).numpy()
                for agent, observation in observations.items()
            }
        observations, rewards, terminations, truncations, infos = env.step(actions)
    record = env.episode_record
    assert record["steps"] == 60 and record["coverage"] > start and min(record["path_lengths"]) > 0
