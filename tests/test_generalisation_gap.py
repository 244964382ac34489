"""The generalisation gap where it means something: the layouts a suite training run trained on,
reconstructed from its config (checked against a real tiny run's layout builds), and the leaderboard's gap
section, whose train column is each policy's own training layouts."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from cabinbench.baselines.ppo_gail.training import suite_draws
from cabinbench.baselines.ppo_gail.training.config import TrainConfig
from cabinbench.baselines.ppo_gail.training.suite_draws import layouts_trained_on, training_sample

from cabinbench.commands import leaderboard
from cabinbench.layouts.suites import get_suite
from cabinbench.leaderboard.table import policy_of
from cabinbench.records import read_records
from cabinbench.stats import stratified_bootstrap, stratified_difference
from cabinbench.training_records import read_metrics
from tests.test_run_and_leaderboard import run_main
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


def tiny_suite_run(seed: int, disjoint_env_seeds: bool = False) -> dict:
    """The ``config.json`` of a tiny training run on cabin-v1-train (by default seeded as the committed
    runs were: env i with seed + i)."""
    config = TrainConfig(layouts=[], suite="cabin-v1-train", num_envs=3, num_steps_per_env=8, iterations=3)
    return {**config.to_dict(), "max_steps": 10, "seed": seed, "disjoint_env_seeds": disjoint_env_seeds}


def test_the_sample_is_the_layouts_every_run_trained_on_in_the_suite_order_and_the_cli_plays_it(
    tmp_path, capsys
):
    """Two seeds' runs: the sample is the layouts both began an episode on, in the suite's order (a
    run from before ``disjoint_env_seeds`` seeds env i with seed + i, so neighbouring seeds share envs;
    runs from now on share none); the command prints how many of the suite's first layouts hold it, and
    refuses a file that is no config in one line."""
    runs = [tiny_suite_run(0), tiny_suite_run(1)]
    both = set(layouts_trained_on(runs[0])) & set(layouts_trained_on(runs[1]))
    names = get_suite("cabin-v1-train").layout_names
    sample = training_sample(runs, 30)
    assert sample == [name for name in names if name in both] and len(sample) == 6  # 2 of 3 envs shared
    assert suite_draws.shared_envs(runs) == 2 and suite_draws.shared_envs([*runs, tiny_suite_run(5)]) == 0
    assert suite_draws.shared_envs([tiny_suite_run(0, True), tiny_suite_run(1, True)]) == 0
    assert training_sample(runs, 2) == sample[:2]
    paths = []
    for run in runs:
        paths.append(tmp_path / f"seed{run['seed']}.json")
        paths[-1].write_text(json.dumps(run))
    assert suite_draws.main(["--layouts", "2", *map(str, paths)]) == 0
    assert capsys.readouterr().out == f"{names.index(sample[1]) + 1}\n"
    assert suite_draws.main(["--layouts", "7", *map(str, paths)]) == 2  # they share 6
    (tmp_path / "bad.json").write_text("{")
    assert suite_draws.main([str(tmp_path / "bad.json")]) == 2
    assert capsys.readouterr().err.count("\n") == 2


def two_ppo_seeds(tmp_path, configs: list[dict]) -> tuple[Path, Path]:
    """A training folder of ``ppo``: the shipped policy and a copy kept as seed 1, each with its run's
    ``config.json`` (``configs``); the folder and seed 1's policy file."""
    from cabinbench.baselines.ppo_gail.policy import CHECKPOINT_DIR

    training = tmp_path / "training"
    other = training / "ppo" / "seed1" / "policy.pt"
    other.parent.mkdir(parents=True)
    other.write_bytes((CHECKPOINT_DIR / "ppo.pt").read_bytes())
    for folder, config in zip((training / "ppo", other.parent), configs):
        (folder / "config.json").write_text(json.dumps(config))
    return training, other


def ppo_run(runs: Path, policy_config: dict) -> list[str]:
    """``run``'s options for short ``ppo`` episodes of one policy, recorded in ``runs``."""
    return [
        "--baseline",
        "ppo",
        "--max-steps",
        "30",
        "--out",
        str(runs),
        "--config",
        json.dumps(policy_config),
    ]


def gap_table_row(runs: Path, training: Path, out: Path) -> tuple[str, list[str]]:
    """The leaderboard's generalisation-gap section built from ``runs`` and ``ppo``'s row of its table."""
    assert leaderboard.main(["--runs", str(runs), "--out", str(out), "--training", str(training)]) == 0
    section = (out / "leaderboard.md").read_text().split("#### Generalisation gap")[1]
    line = next(line for line in section.splitlines() if line.startswith("| ppo |"))
    return section, [cell.strip() for cell in line.strip("|").split("|")]


def test_the_train_column_is_the_layouts_the_policy_trained_on(tmp_path):
    """A learner trained on a320_cell (two seeds, each with its config.json) with records on cabin-v1-train,
    -test, -ood and on the classic suite from random starts: its train column is its a320_cell episodes from
    random starts (not the cabin-v1-train ones), the section says so, and test − train pairs the seeds."""
    cells = TrainConfig(layouts=["a320_cell"]).to_dict()
    training, other = two_ppo_seeds(tmp_path, [cells, cells])
    runs = tmp_path / "runs"
    for config in ({}, {"checkpoint": str(other)}):
        common = ppo_run(runs, config)
        for suite in ("cabin-v1-train", "cabin-v1-test", "cabin-v1-ood"):
            assert run_main([*common, "--suite", suite, "--layouts", "2"])[0] == 0
        classic = ["--suite", "classic", "--layouts", "2", "--start", "random", "--episodes-per-layout", "2"]
        assert run_main([*common, *classic])[0] == 0
    section, row = gap_table_row(runs, training, tmp_path / "out")
    records = read_records(runs)

    def cells_of(chosen):
        policies = [policy_of(config) for config in chosen["baseline_config"]]
        return {
            (policy, layout): group["coverage"].tolist()
            for (policy, layout), group in chosen.assign(policy=policies).groupby(["policy", "layout"])
        }

    trained = cells_of(records[(records["suite"] == "classic") & (records["layout"] == "a320_cell")])
    test = cells_of(records[records["suite"] == "cabin-v1-test"])
    train_score, test_score = stratified_bootstrap(trained), stratified_bootstrap(test)
    assert len(trained) == 2 and all(len(episodes) == 2 for episodes in trained.values())
    assert row[1] == "2"  # training seeds
    assert row[2] == f"{train_score.mean:.3f} ± {(train_score.high - train_score.low) / 2:.3f} (1)"
    assert row[3] == f"{test_score.mean:.3f} ± {(test_score.high - test_score.low) / 2:.3f} (2)"
    gap = stratified_difference(trained, test)
    assert gap.mean == pytest.approx(test_score.mean - train_score.mean)
    assert row[5] == f"{gap.mean:+.3f} [{gap.low:+.3f}, {gap.high:+.3f}]"
    assert "The train column is ppo: its training cells, a320_cell." in section
    assert f"Finding: ppo covers {train_score.mean:.3f} of the layouts it trained on" in section


def test_a_suite_learners_seeds_with_layouts_of_their_own_are_scored_each_on_its_own(tmp_path, monkeypatch):
    """Two seeds' suite runs that seeded their envs apart trained on other layouts: each seed's train
    column is its own first layouts (here 1, the sample size set low), drawn apart in the bootstrap
    (layouts nested in the seeds), and the section says so; test − train still pairs the seeds."""
    from cabinbench.leaderboard import gap

    monkeypatch.setattr(gap, "TRAIN_SAMPLE", 1)
    runs_config = [tiny_suite_run(0, True), tiny_suite_run(1, True)]
    samples = [training_sample([config], 1) for config in runs_config]
    assert samples[0] != samples[1]
    training, other = two_ppo_seeds(tmp_path, runs_config)
    names = get_suite("cabin-v1-train").layout_names
    first = [names.index(sample[0]) + 1 for sample in samples]
    runs = tmp_path / "runs"
    for config, layouts in zip(({}, {"checkpoint": str(other)}), first):
        common = ppo_run(runs, config)
        assert run_main([*common, "--suite", "cabin-v1-train", "--layouts", str(layouts)])[0] == 0
        assert run_main([*common, "--suite", "cabin-v1-test", "--layouts", "2"])[0] == 0
    section, row = gap_table_row(runs, training, tmp_path / "out")
    records = read_records(runs)
    policies = records["baseline_config"].map(policy_of)
    train = records[records["suite"] == "cabin-v1-train"]
    own = {
        (policy, sample[0]): train.loc[
            (policies[train.index] == policy) & (train["layout"] == sample[0]), "coverage"
        ].tolist()
        for policy, sample in zip(("shipped", str(other)), samples)
    }
    test = records[records["suite"] == "cabin-v1-test"]
    held_out = {
        (policy, layout): group["coverage"].tolist()
        for (policy, layout), group in test.assign(policy=policies[test.index]).groupby(["policy", "layout"])
    }
    train_score = stratified_bootstrap(own, own_layouts=True)
    assert all(len(episodes) == 1 for episodes in own.values())
    assert row[2] == f"{train_score.mean:.3f} ± {(train_score.high - train_score.low) / 2:.3f} (2)"
    gap_score = stratified_difference(own, held_out, x_own_layouts=True)
    assert row[5] == f"{gap_score.mean:+.3f} [{gap_score.low:+.3f}, {gap_score.high:+.3f}]"
    assert (
        f"ppo: for each of its 2 training seeds, the first 1 layouts of cabin-v1-train (of the suite's first "
        f"{min(first)}-{max(first)})" in section
    )
