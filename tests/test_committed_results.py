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
        "headline.csv",
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
    """The README's main command runs the shipped ppo_gail policy (seed 0) on full_cabin; it says so,
    and the coverage it quotes for each training seed, and over all seeds with the t interval and its
    n, is the committed leaderboard's."""
    board = pd.read_csv(ROOT / "results" / "leaderboard.csv")
    main_command = (
        (board["layout"] == "full_cabin") & (board["baseline"] == "ppo_gail") & (board["n_agents"] == 1)
    )
    rows = board[main_command].set_index("policy")
    assert len(rows) == 4  # three training seeds and the row over all of them
    coverage, over_seeds = rows["coverage_mean"], rows.loc["all seeds"]
    readme = " ".join((ROOT / "README.md").read_text(encoding="utf-8").split())
    assert "It runs seed 0 of `ppo_gail`'s three training seeds, the policy the package ships." in readme
    assert (
        f"on `full_cabin` its coverage is {coverage['seed0 (shipped)']:.3f} (seed 0), against "
        f"{coverage['seed1']:.3f} (seed 1) and {coverage['seed2']:.3f} (seed 2); over the three seeds "
        f"{coverage['all seeds']:.3f}, 95% t interval [{over_seeds['coverage_ci_low']:.3f}, "
        f"{over_seeds['coverage_ci_high']:.3f}] (n = {int(over_seeds['coverage_n'])} seeds)"
    ) in readme


def test_every_committed_figure_is_readable_at_its_natural_size():
    from PIL import Image

    for path in sorted((ROOT / "results" / "figures").glob("*.png")):
        with Image.open(path) as image:
            assert image.width <= 3000, f"{path.name} is {image.width} px wide: split it"


def test_the_packaged_citation_is_the_repositorys():
    """The site of an installed cabinbench cites the copy the package ships: it must not drift."""
    packaged = ROOT / "cabinbench" / "leaderboard" / "site_files" / "CITATION.cff"
    assert packaged.read_bytes() == (ROOT / "CITATION.cff").read_bytes()
