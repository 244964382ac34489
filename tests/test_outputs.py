"""What a command writes survives what a user gives it (issue 45): one bad record does not stop the
leaderboard, the site builds outside the repository's folder, a run's summary gives a timing that
represents its episodes, and a layout whose name no report can write is refused before it runs."""

import csv
import json
import os
import shutil
import statistics
import subprocess
import sys
from pathlib import Path

import pytest

from cabinbench.commands import run

ROOT = Path(__file__).resolve().parents[1]
SHORT = ["--baseline", "random_bounce", "--layout", "a320_cell", "--max-steps", "20"]


@pytest.fixture(scope="module")
def good_run(tmp_path_factory) -> Path:
    """A folder with one run of 2 episodes (records and trajectories)."""
    folder = tmp_path_factory.mktemp("outputs") / "good"
    assert run.main([*SHORT, "--episodes", "2", "--out", str(folder)]) == 0
    return folder


def copy_run(source: Path, folder: Path, name: str, change_lines=None) -> Path:
    """The run in ``source`` copied to ``folder/name.jsonl`` (and its .npz), its lines changed."""
    [records] = source.glob("*.jsonl")
    lines = records.read_text(encoding="utf-8").splitlines()
    target = folder / f"{name}.jsonl"
    target.write_text("\n".join(change_lines(lines) if change_lines else lines) + "\n", encoding="utf-8")
    shutil.copy(records.with_suffix(".npz"), target.with_suffix(".npz"))
    return target


def with_field(line: str, name: str, value) -> str:
    return json.dumps({**json.loads(line), name: value})  # a lone surrogate is written as \udce9


def leaderboard_process(arguments: list[str], cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "cabinbench.leaderboard", *arguments],
        cwd=cwd,
        capture_output=True,
        text=True,
        timeout=300,
    )


def test_bad_records_are_named_and_skipped_and_the_rest_is_built(good_run, tmp_path):
    runs = tmp_path / "runs"
    runs.mkdir()
    copy_run(good_run, runs, "good")
    bad = {
        "latin": copy_run(
            good_run, runs, "latin", lambda lines: [with_field(lines[0], "layout", "caf\udce9")]
        ),
        "text": copy_run(
            good_run, runs, "text", lambda lines: [lines[0], with_field(lines[1], "coverage", "abc")]
        ),
        "hello": copy_run(good_run, runs, "hello", lambda lines: ['{"hello": 1}']),
    }
    truncated = copy_run(good_run, runs, "truncated")
    npz = truncated.with_suffix(".npz")
    npz.write_bytes(npz.read_bytes()[: npz.stat().st_size // 2])
    result = leaderboard_process(["--runs", str(runs), "--out", str(tmp_path / "out")], tmp_path)
    assert result.returncode == 0, result.stderr
    assert "Traceback" not in result.stderr
    warnings = [line for line in result.stderr.splitlines() if line.startswith("warning: ")]
    for expected in (
        f"{bad['latin']}:1: text that is not Unicode ('\\udce9'",
        f'{bad["text"]}:2: coverage "abc" is not a number >= 0; skipping it',
        f"{bad['hello']}:1: field 'benchmark_version' missing; skipping it",
        f"{npz}: cannot read it (",
    ):
        assert sum(expected in line for line in warnings) == 1, (expected, result.stderr)
    # the good run's 2 episodes and the first of "text" (the same 2 again): one row of 3 episodes
    [row] = list(csv.DictReader((tmp_path / "out" / "leaderboard.csv").open()))
    assert (row["layout"], row["baseline"], row["episodes"]) == ("a320_cell", "random_bounce", "3")


def test_the_site_builds_outside_the_repository(good_run, tmp_path):
    """A user's own folder holds no CITATION.cff: the site cites the checkout's."""
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    runs, out, site = str(good_run), str(tmp_path / "results"), str(tmp_path / "site")
    assert leaderboard_process(["--runs", runs, "--out", out], elsewhere).returncode == 0
    result = leaderboard_process(["--runs", runs, "--out", out, "--site", site], elsewhere)
    assert result.returncode == 0, result.stderr
    assert (Path(site) / "CITATION.cff").read_bytes() == (ROOT / "CITATION.cff").read_bytes()
    assert (Path(site) / "index.html").is_file()


def test_the_summary_gives_the_median_wall_time_of_every_episode(tmp_path, capsys):
    """A deterministic baseline repeats one outcome; its first episode's time includes compilation."""
    arguments = [
        "--baseline",
        "boustrophedon",
        "--layout",
        "a320_cell",
        "--max-steps",
        "30",
        "--episodes",
        "3",
    ]
    assert run.main([*arguments, "--out", str(tmp_path), "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    times = [json.loads(line)["wall_time"] for line in Path(summary["records"]).read_text().splitlines()]
    assert summary["metrics"]["coverage"]["n"] == 1  # one distinct outcome
    assert summary["metrics"]["wall_time"] == {"median": statistics.median(times), "n": 3}
    assert run.main([*arguments, "--out", str(tmp_path)]) == 0
    [line] = [line for line in capsys.readouterr().out.splitlines() if line.startswith("wall_time")]
    assert "median of 3 episodes" in line


@pytest.mark.skipif(sys.platform == "darwin", reason="macOS file names are always UTF-8")
def test_a_layout_named_in_another_encoding_is_refused_before_it_runs(tmp_path):
    name = os.fsdecode(b"caf\xe9.yaml")
    (tmp_path / name).write_bytes((ROOT / "layouts" / "paper_matrix_a.yaml").read_bytes())
    result = subprocess.run(
        [sys.executable, "-m", "cabinbench.run", *SHORT[:2], "--layout", name, "--out", "runs"],
        cwd=tmp_path,
        capture_output=True,
        timeout=300,
    )
    stderr = result.stderr.decode("utf-8", "replace")
    assert result.returncode == 2 and stderr.count("\n") == 1, stderr
    assert "is not UTF-8 text; rename the file" in stderr
    assert not (tmp_path / "runs").exists()
