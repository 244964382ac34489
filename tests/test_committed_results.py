"""The committed leaderboard, figures and paper are exactly what the commands produce now from
the committed records: results are generated, never typed."""

from pathlib import Path

import pandas as pd

from cabinbench.commands import leaderboard, paper

ROOT = Path(__file__).resolve().parents[1]


def test_committed_leaderboard_and_paper_match_the_records(tmp_path, monkeypatch):
    monkeypatch.chdir(ROOT)  # the leaderboard names its inputs relative to the repository
    out = tmp_path / "results"
    assert leaderboard.main(["--runs", "results/runs", "--out", str(out)]) == 0
    for name in (
        "leaderboard.md",
        "leaderboard.csv",
        "uncovered.md",
        "uncovered.csv",
        "ablation.md",
        "ablation.csv",
        "teams.csv",
    ):
        regenerated = (out / name).read_text(encoding="utf-8").replace(str(out), "results")
        assert regenerated == (ROOT / "results" / name).read_text(encoding="utf-8"), (
            f"results/{name} is stale: run python -m cabinbench.leaderboard"
        )
    committed_figures = sorted(path.name for path in (ROOT / "results" / "figures").glob("*.png"))
    assert committed_figures == sorted(path.name for path in (out / "figures").glob("*.png"))
    for name in committed_figures:
        assert (out / "figures" / name).read_bytes() == (ROOT / "results" / "figures" / name).read_bytes(), (
            f"figure {name} is stale"
        )
    # the paper is built from the committed results
    built = paper.build(ROOT / "paper" / "template.md", ROOT / "results", ROOT / "paper" / "paper.md")
    assert built == (ROOT / "paper" / "paper.md").read_text(encoding="utf-8"), (
        "paper/paper.md is stale: run python -m cabinbench.paper"
    )


def test_readme_states_the_spread_of_the_main_commands_training_seeds():
    """The README's main command runs the shipped ppo_gail policy on full_cabin; the coverage it
    quotes for each training seed, and over all seeds, is the committed leaderboard's."""
    board = pd.read_csv(ROOT / "results" / "leaderboard.csv")
    main_command = (
        (board["layout"] == "full_cabin") & (board["baseline"] == "ppo_gail") & (board["n_agents"] == 1)
    )
    rows = board[main_command].set_index("policy")
    assert len(rows) == 4  # three training seeds and the row over all of them
    coverage = rows["coverage_mean"]
    assert coverage["seed0 (shipped)"] == coverage.max()  # "the best of three training seeds"
    readme = " ".join((ROOT / "README.md").read_text(encoding="utf-8").split())
    assert (
        f"coverage is {coverage['seed0 (shipped)']:.3f} (seed 0, shipped), against {coverage['seed1']:.3f} "
        f"(seed 1) and {coverage['seed2']:.3f} (seed 2); over the three seeds {coverage['all seeds']:.3f}, "
        f"95% interval [{rows.loc['all seeds', 'coverage_ci_low']:.3f}, "
        f"{rows.loc['all seeds', 'coverage_ci_high']:.3f}]"
    ) in readme


def test_no_committed_row_has_an_interval_over_identical_episodes_and_every_seed_is_shown():
    board = pd.read_csv(ROOT / "results" / "leaderboard.csv")
    bounds = [name for name in board.columns if name.endswith(("_ci_low", "_ci_high"))]
    one_unit = board[board["distinct_episodes"] == 1]
    assert len(one_unit) > 0 and one_unit[bounds].isna().all().all()  # boustrophedon from a fixed start
    assert (board.loc[board["distinct_episodes"] > 1, "coverage_ci_low"].notna()).all()
    table = (ROOT / "results" / "leaderboard.md").read_text(encoding="utf-8")
    assert "deterministic: 20 identical episodes" in table and "1.00 ± 0.00" not in table
    learned = board[board["policy"].notna()]
    for (layout, baseline, agents), rows in learned.groupby(["layout", "baseline", "n_agents"]):
        kept = sorted(path.name for path in (ROOT / "results" / "training" / baseline).glob("seed*"))
        every_seed = {"seed0 (shipped)", *kept} | ({"all seeds"} if kept else set())
        assert set(rows["policy"]) == every_seed, (layout, baseline, agents)


def test_every_committed_figure_is_readable_at_its_natural_size():
    from PIL import Image

    for path in sorted((ROOT / "results" / "figures").glob("*.png")):
        with Image.open(path) as image:
            assert image.width <= 3000, f"{path.name} is {image.width} px wide: split it"
