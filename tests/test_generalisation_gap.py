"""The generalisation gap where it means something: the layouts a suite training run trained on,
reconstructed from its config (checked against a real tiny run's layout builds), and the leaderboard's gap
section, whose train column is each policy's own training layouts."""

from __future__ import annotations

import json

from cabinbench.baselines.ppo_gail.training.suite_draws import layouts_trained_on

from cabinbench.layouts.suites import get_suite
from cabinbench.training_records import read_metrics
from tests.test_validation_protocol import layouts_built


def test_the_reconstruction_names_the_layouts_a_real_suite_run_built_and_counts_its_episodes(tmp_path):
    """A tiny ``ppo`` run on cabin-v1-train whose episodes all end at their step limit (too short to
    succeed): its processes built exactly the reconstructed layouts (and the suite's first, which the
    env reads for its spaces), and it began exactly as many episodes as the reconstruction counts."""
    run_dir = tmp_path / "run"
    options = ["--suite", "cabin-v1-train", "--num-envs", "3", "--steps-per-env", "8", "--iterations", "3"]
    built = layouts_built(
        tmp_path, "ppo", run_dir, *options, "--max-steps", "10", "--validation-episodes", "0"
    )

    config = json.loads((run_dir / "config.json").read_text())
    trained = layouts_trained_on(config)
    suite = get_suite("cabin-v1-train").layout_names
    assert set(built) - {suite[0]} == set(trained) - {suite[0]}
    ended = sum(int(row["episodes"]) for row in read_metrics(run_dir / "metrics.csv"))
    assert sum(trained.values()) == ended + config["num_envs"] == 3 * 3  # 24 steps: begun at 0, 10, 20
