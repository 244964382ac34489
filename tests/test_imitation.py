"""bc and dagger (``cabinbench.baselines.imitation``) on tiny settings: a320_cell, 2 episodes of 60 steps per
round, validation on 2 layouts of cabin-v1-val."""

from __future__ import annotations

import json

import numpy as np
import pytest
import torch
from cabinbench.baselines.boustrophedon import Boustrophedon
from cabinbench.baselines.imitation.config import ImitationConfig
from cabinbench.baselines.imitation.training import write_rows
from cabinbench.baselines.ppo_gail import cli
from cabinbench.baselines.ppo_gail.policy import read_policy_file
from cabinbench.baselines.ppo_gail.training.validation import VALIDATION_COLUMNS

from cabinbench.agents import EpisodeContext, load_baseline
from cabinbench.episodes import make_env
from cabinbench.layouts.resolve import load_layout
from cabinbench.training_records import best_checkpoint, read_metrics
from tests.test_run_and_leaderboard import run_main

TINY = ["--layout", "a320_cell", "--episodes-per-iteration", "2", "--max-steps", "60", "--epochs", "4"]
TINY += ["--validation-episodes", "2", "--workers", "1", "--no-progress"]


def train(baseline: str, run_dir, iterations: int, *more: str) -> int:
    return cli.main(
        ["--baseline", baseline, *TINY, "--iterations", str(iterations), "--run-dir", str(run_dir), *more]
    )


def test_bc_reduces_its_loss_resumes_as_it_would_have_gone_on_and_its_policy_plays_with_run(tmp_path):
    assert train("bc", tmp_path / "straight", 2) == 0
    metrics = read_metrics(tmp_path / "straight" / "metrics.csv")
    assert [float(row["expert_share"]) for row in metrics] == [1.0, 1.0]  # the expert drives every round
    for row in metrics:
        assert float(row["fit_loss"]) < 0.7 * float(row["fit_loss_first"])
    assert train("bc", tmp_path / "resumed", 1) == 0
    assert train("bc", tmp_path / "resumed", 2, "--resume") == 0
    resumed = read_metrics(tmp_path / "resumed" / "metrics.csv")
    assert [row["fit_loss"] for row in resumed] == [row["fit_loss"] for row in metrics]

    # a run validated before bc recorded clean_score chooses again on it when resumed, rows as a new run's
    validation_path = tmp_path / "straight" / "validation.csv"
    scored = read_metrics(validation_path)
    assert all(0.0 <= float(row["clean_score"]) <= 1.0 for row in scored)
    older = [{key: value for key, value in row.items() if key != "clean_score"} for row in scored]
    write_rows(validation_path, VALIDATION_COLUMNS, older)
    assert train("bc", tmp_path / "straight", 2, "--resume") == 0
    assert read_metrics(validation_path) == scored
    chosen = read_policy_file(tmp_path / "straight" / "policy.pt")["training"]["exported_iteration"]
    assert chosen == best_checkpoint(scored)[0]

    policy_path = tmp_path / "straight" / "policy.pt"
    policy = read_policy_file(policy_path)
    assert policy["ablation"] == "bc" and policy["actor"]["hidden_dims"] == [64, 64]
    assert policy["observation_config"]["coverage_patch"] == 32
    assert policy["observation_config"]["coverage_patch_cell"] == 0.125
    config = json.dumps({"checkpoint": str(policy_path)})
    played = ["--baseline", "bc", "--layout", "a320_cell", "--episodes", "1", "--max-steps", "30"]
    status, out, _ = run_main([*played, "--config", config, "--out", str(tmp_path / "runs"), "--json"])
    assert status == 0 and json.loads(out)["baseline"] == "bc"
    baseline = load_baseline("bc", checkpoint=str(policy_path))
    assert not baseline.stochastic  # the mean action: the same observation, the same action
    observation = np.random.default_rng(0).random(policy["observation_config"]["size"])
    assert np.array_equal(baseline.act(observation, {}), baseline.act(observation, {}))


def test_dagger_labels_the_states_its_policy_visited_with_the_expert_and_chooses_on_cabin_v1_val(tmp_path):
    assert train("dagger", tmp_path, 2) == 0
    rounds = [np.load(tmp_path / "data" / f"round_{index:06d}.npz") for index in range(2)]
    assert rounds[0]["by_expert"].all()  # round 0: the expert alone
    learner_steps = ~rounds[1]["by_expert"]
    assert 0.2 < learner_steps.mean() < 0.8  # beta = 0.5
    metrics = read_metrics(tmp_path / "metrics.csv")
    assert int(metrics[1]["timesteps"]) == sum(len(r["labels"]) for r in rounds)  # refit on both rounds

    # replay an episode of round 1: every label is what the expert says at the state the mixture reached
    data = rounds[1]
    steps = data["episode"] == 0
    config = ImitationConfig(method="dagger", layouts=["a320_cell"], max_steps=60, validation_episodes=2)
    env = make_env(load_layout(str(data["layouts"][0])), "sequential", 1, config.env_kwargs)
    observation, info = env.reset(seed=int(data["seeds"][0]))
    expert = Boustrophedon()
    context = EpisodeContext(
        env.unwrapped.layout, "sequential", int(data["seeds"][0]), env_config=config.env_kwargs,
        observation_layout=env.unwrapped.observation_layout,
    )  # fmt: skip
    expert.reset(context, observation["robot_0"], info["robot_0"])
    for visited, label, executed in zip(
        data["observations"][steps], data["labels"][steps], data["executed"][steps]
    ):
        assert np.allclose(visited, observation["robot_0"], atol=1e-2)
        assert np.allclose(label, np.clip(expert.act(observation["robot_0"], info["robot_0"]), -1, 1))
        observation, _, _, _, info = env.step({"robot_0": executed})
    assert (np.abs(data["labels"] - data["executed"])[~data["by_expert"]].max(axis=1) > 1e-3).any()

    validation = read_metrics(tmp_path / "validation.csv")
    assert {row["iteration"] for row in validation} == {"1", "2"}
    assert all(row["layout"].startswith("cabin-v1-val/") for row in validation)
    assert all(row["clean_score"] != "" for row in validation)  # chosen on the headline score
    chosen = read_policy_file(tmp_path / "policy.pt")["training"]["exported_iteration"]
    assert chosen == best_checkpoint(validation)[0]
    assert torch.equal(
        read_policy_file(tmp_path / "policy.pt")["actor"]["state_dict"]["0.weight"],
        read_policy_file(tmp_path / "validation" / f"policy_{chosen:06d}.pt")["actor"]["state_dict"][
            "0.weight"
        ],
    )


@pytest.mark.parametrize(
    "arguments, message",
    [
        (["--baseline", "bc", "--algorithm", "{}"], "--algorithm: only for"),
        (["--baseline", "dagger", "--beta-decay", "2"], "beta_decay must be in [0, 1]"),
        (["--baseline", "bc", "--validation-episodes", "500"], "validation_episodes must be at most 50"),
    ],
)
def test_a_mistaken_option_is_one_line(arguments, message, tmp_path, capsys):
    assert cli.main([*arguments, "--run-dir", str(tmp_path)]) == 2
    error = capsys.readouterr().err.strip()
    assert message in error and len(error.splitlines()) == 1
