"""The leaderboard's suites section on real short runs whose records carry a ``suite``: the
statistics of issue 18 §4 and the complexity correlations of §5, checked against the records."""

import json

import pandas as pd
import pytest
from PIL import Image
from scipy import stats as scipy_stats

from cabinbench.commands import leaderboard
from cabinbench.records import read_records
from cabinbench.stats import stratified_bootstrap
from tests.test_run_and_leaderboard import run_main

SUITE = "cabin-v1-test"


@pytest.fixture(scope="module")
def suite_board(tmp_path_factory):
    """``run --suite`` on the suite's first three layouts, 100 steps: random_bounce (3 episodes a
    layout), boustrophedon from each layout's fixed start (2, one episode repeated), and ppo's
    shipped policy and a second policy file (2 each, the second in --ablation-runs)."""
    from cabinbench.baselines.ppo_gail.policy import CHECKPOINT_DIR

    root = tmp_path_factory.mktemp("suite")
    other = root / "training" / "ppo" / "seed1" / "policy.pt"
    other.parent.mkdir(parents=True)
    other.write_bytes((CHECKPOINT_DIR / "ppo.pt").read_bytes())
    runs, further = root / "runs", root / "ablation_runs"
    suite = ["--suite", SUITE, "--layouts", "3", "--max-steps", "100"]
    random = ["--baseline", "random_bounce", "--episodes-per-layout", "3"]
    assert run_main([*random, *suite, "--out", str(runs)])[0] == 0
    planner = ["--baseline", "boustrophedon", "--episodes-per-layout", "2", "--start", "fixed"]
    assert run_main([*planner, *suite, "--out", str(runs)])[0] == 0
    assert run_main(["--baseline", "ppo", "--episodes-per-layout", "2", *suite, "--out", str(runs)])[0] == 0
    config = json.dumps({"checkpoint": str(other)})
    ppo = ["--baseline", "ppo", "--episodes-per-layout", "2", "--seed", "5", "--config", config]
    assert run_main([*ppo, *suite, "--out", str(further)])[0] == 0
    out = root / "out"
    assert leaderboard.main(["--runs", str(runs), "--ablation-runs", str(further), "--out", str(out)]) == 0
    records = pd.concat([read_records(runs), read_records(further)], ignore_index=True)
    assert set(records["suite"]) == {SUITE} and records["layout"].nunique() == 3
    return out, records


def suite_table_row(board: str, label: str) -> list[str]:
    start = board.index(f"#### Suite `{SUITE}`")
    line = next(
        line for line in board[start:].splitlines() if line.startswith(f"| {label} | sequential | 1 |")
    )
    return [cell.strip() for cell in line.strip("|").split("|")]


def test_suite_table_scores_the_mean_over_layouts_of_per_layout_means(suite_board):
    out, records = suite_board
    board = (out / "leaderboard.md").read_text()
    assert "### Suites" in board and board.count("#### Suite ") == 1
    # suite episodes stay out of the classic table
    assert f"| {SUITE}/" not in board.split("### Suites")[0]
    rb = records[records["baseline"] == "random_bounce"]
    expected = rb.groupby("layout")["coverage"].mean().mean()
    cells = suite_table_row(board, "random_bounce")
    assert cells[3:7] == ["1", "3", "9", "9"]  # seeds, layouts, episodes, distinct
    assert cells[7].startswith(f"{expected:.3f} ± ")
    # the interval is the stratified bootstrap's, over layouts and episodes
    summary = stratified_bootstrap(
        {("shipped", layout): group["coverage"].tolist() for layout, group in rb.groupby("layout")}
    )
    assert cells[7] == f"{summary.mean:.3f} ± {(summary.high - summary.low) / 2:.3f}"
    # boustrophedon from a fixed start repeats one episode per layout: one unit per layout, the
    # layouts make the interval
    assert suite_table_row(board, "boustrophedon")[3:7] == ["1", "3", "6", "3"]


def test_learned_baseline_is_scored_over_its_training_seeds(suite_board):
    out, records = suite_board
    board = (out / "leaderboard.md").read_text()
    ppo = records[records["baseline"] == "ppo"]
    policy = ["checkpoint" in config for config in ppo["baseline_config"]]
    per_seed = ppo.assign(policy=policy).groupby(["policy", "layout"])["coverage"].mean()
    cells = suite_table_row(board, "ppo")
    assert cells[3:6] == ["2", "3", "12"]
    assert cells[7].startswith(f"{per_seed.groupby(level=0).mean().mean():.3f}")
    # the floor cleaned: each seed's own rate, then a t interval over the two seeds
    assert cells[12].count("[") == 1 or cells[12] == "—"


def test_probability_of_improvement_and_profiles(suite_board):
    out, records = suite_board
    board = (out / "leaderboard.md").read_text()
    assert "Performance profiles" in board and "| X \\ Y | boustrophedon | ppo | random_bounce |" in board
    # P(boustrophedon > random_bounce): per layout, its one distinct episode against random's three
    planner = records[records["baseline"] == "boustrophedon"].groupby("layout")["coverage"].first()
    random = records[records["baseline"] == "random_bounce"]
    per_layout = [
        ((planner[layout] > group["coverage"]).mean() + 0.5 * (planner[layout] == group["coverage"]).mean())
        for layout, group in random.groupby("layout")
    ]
    line = next(line for line in board.splitlines() if line.startswith("| boustrophedon | — |"))
    assert line.split("|")[4].strip().startswith(f"{sum(per_layout) / 3:.2f} [")
    for name in ("profiles", "improvement", "complexity"):
        assert Image.open(out / "figures" / f"suite__{SUITE}__{name}.png").size[0] > 400


def test_complexity_is_not_tested_on_too_few_layouts(suite_board):
    out, records = suite_board
    board = (out / "leaderboard.md").read_text()
    rb = records[records["baseline"] == "random_bounce"]
    scores = rb.groupby("layout")["coverage"].mean()
    complexity = rb.groupby("layout")["layout_complexity"].first()
    rho = scipy_stats.spearmanr([complexity[layout]["total"] for layout in scores.index], scores).statistic
    assert -1 <= rho <= 1
    # three layouts are too few for a test (a partial ρ needs four): every cell says so, and the finding
    line = next(line for line in board.splitlines() if line.startswith("| random_bounce | coverage (-) |"))
    assert [cell.strip() for cell in line.split("|")[3:8]] == ["—"] * 5
    assert f"Finding ({SUITE}): too few layouts" in board


def test_no_suite_records_no_suite_section(tmp_path):
    runs = tmp_path / "runs"
    assert (
        run_main(
            [
                "--baseline",
                "random_bounce",
                "--layout",
                "paper_matrix_a",
                "--max-steps",
                "50",
                "--out",
                str(runs),
            ]
        )[0]
        == 0
    )
    assert leaderboard.main(["--runs", str(runs), "--out", str(tmp_path / "out")]) == 0
    board = (tmp_path / "out" / "leaderboard.md").read_text()
    assert "### Suites" not in board and not list((tmp_path / "out" / "figures").glob("suite__*"))
