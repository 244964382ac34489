"""The committed leaderboard, figures and paper are exactly what the commands produce now from
the committed records: results are generated, never typed."""

from pathlib import Path

from cabinbench import leaderboard, paper

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
