"""The runner, the record format, the statistics and the leaderboard, on real short episodes."""

import contextlib
import io
import json
import math
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from PIL import Image

from cabinbench.commands import leaderboard, run
from cabinbench.episodes import run_jobs
from cabinbench.layouts.load import available_layouts
from cabinbench.metrics import METRICS, TEAM_METRICS
from cabinbench.records import (
    RECORD_FIELDS,
    RecordWarning,
    move_runs,
    read_records,
    read_trajectories,
    run_path,
    with_current_complexity,
)
from cabinbench.stats import iqm, mean_ci, reach_time

SHORT = ["--baseline", "random_bounce", "--layout", "a320_cell", "--max-steps", "200"]
VARYING = ("wall_time", "timestamp")  # the only fields allowed to differ between identical runs


def run_main(argv: list[str]) -> tuple[int, str, str]:
    stdout, stderr = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(stdout), contextlib.redirect_stderr(stderr):
        status = run.main(argv)
    return status, stdout.getvalue(), stderr.getvalue()


def stable(records: list[dict]) -> list[dict]:
    """Records in episode order without the fields that depend on the clock."""
    return [
        {k: v for k, v in record.items() if k not in VARYING}
        for record in sorted(records, key=lambda record: record["episode"])
    ]


def lines(path: str) -> list[dict]:
    return [json.loads(line) for line in Path(path).read_text().splitlines()]


@pytest.fixture(scope="module")
def short_run(tmp_path_factory):
    """random_bounce on a320_cell, 3 episodes of 200 steps, with --json."""
    out = tmp_path_factory.mktemp("runs")
    status, stdout, _ = run_main([*SHORT, "--episodes", "3", "--out", str(out), "--json"])
    assert status == 0
    return json.loads(stdout)


def test_records_have_every_field_and_metric(short_run):
    records = lines(short_run["records"])
    assert [record["episode"] for record in records] == [0, 1, 2]
    for record in records:
        assert list(record)[: len(RECORD_FIELDS)] == list(RECORD_FIELDS)
        assert set(METRICS) <= set(record)
        assert record["layout"] == "a320_cell" and record["baseline"] == "random_bounce"
        assert record["seed"] == 0 and record["n_agents"] == 1 and record["protocol"] == "sequential"
        assert record["steps"] == 200 and record["env_config"]["max_steps"] == 200
        assert len(record["layout_hash"]) == 16
        assert set(record["layout_complexity"]) == {"normalized", "total"}
        assert record["git_commit"] is None or len(record["git_commit"]) == 40
    stored = read_trajectories(short_run["records"])
    assert sorted(stored.episodes) == [0, 1, 2]
    episode = stored.episodes[0]
    assert episode["positions"].dtype == np.float32 and episode["positions"].shape[1:] == (1, 2)
    assert episode["steps"][0] == 0 and episode["steps"][-1] == 200
    assert episode["coverage"][-1] == pytest.approx(records[0]["coverage"], abs=1e-6)
    assert episode["pass_count"].shape == stored.floor.shape


def test_json_summary(short_run):
    assert short_run["episodes"] == 3
    assert Path(short_run["records"]).is_file() and Path(short_run["trajectories"]).is_file()
    coverage = short_run["metrics"]["coverage"]
    assert coverage["n"] == 3 and coverage["ci_low"] <= coverage["mean"] <= coverage["ci_high"]
    assert short_run["metrics"]["t90"]["reached"] == 0.0  # 200 steps of random motion never get there


def test_same_seed_same_metrics_and_workers_agree(short_run, tmp_path):
    status, stdout, _ = run_main(
        [*SHORT, "--episodes", "3", "--out", str(tmp_path), "--json", "--workers", "2"]
    )
    assert status == 0
    assert stable(lines(json.loads(stdout)["records"])) == stable(lines(short_run["records"]))


def test_interrupt_keeps_finished_episodes(monkeypatch, tmp_path):
    def interrupted_after_two(jobs, executor):
        for index, result in enumerate(run_jobs(jobs, executor)):
            if index == 2:
                raise KeyboardInterrupt
            yield result

    monkeypatch.setattr(run, "run_jobs", interrupted_after_two)
    status, _, stderr = run_main([*SHORT, "--episodes", "5", "--out", str(tmp_path)])
    assert status == 130
    [records_path] = tmp_path.glob("*.jsonl")
    assert "2 finished episode(s) kept" in stderr and str(records_path) in stderr
    assert [record["episode"] for record in lines(records_path)] == [0, 1]
    assert sorted(read_trajectories(records_path).episodes) == [0, 1]


def test_interrupt_before_the_first_episode_leaves_no_file(monkeypatch, tmp_path):
    def interrupted_at_once(jobs, executor):
        raise KeyboardInterrupt
        yield

    monkeypatch.setattr(run, "run_jobs", interrupted_at_once)
    status, _, stderr = run_main([*SHORT, "--episodes", "2", "--out", str(tmp_path)])
    assert status == 130 and "nothing was written" in stderr
    assert list(tmp_path.iterdir()) == []


def test_runs_started_together_each_get_their_own_file(tmp_path):
    """Runs of one setting started in the same second into one folder (in parallel) must not share a file: the
    name is claimed when it is chosen, not when the first episode is written."""
    header = {"layout": "a320_cell", "baseline": "ppo", "protocol": "sequential", "n_agents": 1, "seed": 0}
    paths = [run_path(tmp_path, header) for _ in range(3)]
    assert len(set(paths)) == 3 and all(path.is_file() for path in paths)
    assert read_records(tmp_path).empty  # a claimed file with no episode yet holds no record


def test_runs_played_apart_and_moved_together_keep_every_record(short_run, tmp_path):
    """make_results plays each run into a folder of its own and moves its records on: two runs started in the
    same second have the same file name there, and moving both into one folder keeps both, each records file
    with its own trajectory."""
    records = Path(short_run["records"])
    staged = []
    for index in range(2):
        folder = tmp_path / f"staged{index}"
        folder.mkdir()
        shutil.copy(records, folder / records.name)
        shutil.copy(Path(short_run["trajectories"]), folder / records.with_suffix(".npz").name)
        staged.append(folder)
    out = tmp_path / "runs"
    moved = [path for folder in staged for path in move_runs(folder, out)]
    assert len(set(moved)) == 2 and sorted(out.iterdir()) == sorted(
        [*moved, *(p.with_suffix(".npz") for p in moved)]
    )
    assert all(not any(folder.iterdir()) for folder in staged)
    both = read_records(out)
    assert len(both) == 2 * len(read_records(records)) and set(both["source"]) == set(map(str, moved))
    trajectory = Path(short_run["trajectories"]).read_bytes()
    assert all(path.with_suffix(".npz").read_bytes() == trajectory for path in moved)


def test_truncated_last_line_is_skipped(short_run, tmp_path):
    text = Path(short_run["records"]).read_text()
    broken = tmp_path / "broken.jsonl"
    broken.write_text(text + text.splitlines()[0][:40])
    shutil.copy(Path(short_run["trajectories"]), broken.with_suffix(".npz"))
    with pytest.warns(UserWarning, match="truncated last line"):
        frame = read_records(tmp_path)
    assert len(frame) == 3 and set(frame["source"]) == {str(broken)}
    broken.write_text(text.splitlines()[0][:40] + "\n" + text)
    with pytest.warns(RecordWarning, match="broken.jsonl:1: not a JSON record"):
        assert len(read_records(broken)) == 3


def test_unknown_names_exit_2_listing_valid_ones(tmp_path):
    status, _, stderr = run_main(
        ["--baseline", "no_such_planner", "--layout", "a320_cell", "--out", str(tmp_path)]
    )
    assert status == 2 and "random_bounce" in stderr and "boustrophedon" in stderr
    result = subprocess.run(
        [
            sys.executable,
            "-m",
            "cabinbench.run",
            "--baseline",
            "random_bounce",
            "--layout",
            "no_such_cabin",
            "--out",
            str(tmp_path),
        ],
        capture_output=True,
        text=True,
    )
    assert result.returncode == 2 and "Traceback" not in result.stderr
    assert all(name in result.stderr for name in available_layouts())
    assert not list(tmp_path.iterdir())  # nothing written


@pytest.mark.parametrize("suffix", ["png", "gif"])
def test_render(tmp_path, suffix):
    picture = tmp_path / f"x.{suffix}"
    status, stdout, _ = run_main(
        [*SHORT, "--episodes", "1", "--out", str(tmp_path), "--render", str(picture)]
    )
    assert status == 0 and str(picture) in stdout
    with Image.open(picture) as image:
        assert image.width > 100 and image.height > 100
        frames = getattr(image, "n_frames", 1)
        assert frames == 1 if suffix == "png" else frames > 10


def test_team_run_goes_through_the_parallel_env(tmp_path):
    pytest.importorskip("cabinbench.envs.team_env", reason="the PettingZoo team env is not in this checkout")
    status, stdout, _ = run_main(
        [*SHORT, "--agents", "2", "--episodes", "1", "--out", str(tmp_path), "--json"]
    )
    assert status == 0
    [record] = lines(json.loads(stdout)["records"])
    assert record["n_agents"] == 2 and set(TEAM_METRICS) <= set(record) and len(record["path_lengths"]) == 2
    assert read_trajectories(json.loads(stdout)["records"]).episodes[0]["positions"].shape[1:] == (2, 2)


def test_teams_section_sets_each_team_beside_its_single_robot(short_run, tmp_path):
    """A baseline run with K = 1 and 2 gets a teams row per K: the team's makespan, load balance and
    robot contacts from its records, the single robot's makespan its episode time."""
    runs = tmp_path / "runs"
    shutil.copytree(Path(short_run["records"]).parent, runs)
    status, _, _ = run_main([*SHORT, "--agents", "2", "--episodes", "2", "--out", str(runs)])
    assert status == 0
    assert leaderboard.main(["--runs", str(runs), "--out", str(tmp_path / "out")]) == 0
    teams = pd.read_csv(tmp_path / "out" / "teams.csv").set_index("n_agents")
    records = read_records(runs)
    alone, team = records[records["n_agents"] == 1], records[records["n_agents"] == 2]
    assert list(teams.index) == [1, 2] and set(teams["baseline"]) == {"random_bounce"}
    assert teams.loc[1, "makespan_mean"] == pytest.approx(alone["time"].mean(), rel=1e-5)  # %.6g
    assert math.isnan(teams.loc[1, "load_balance_mean"]) and math.isnan(teams.loc[1, "robot_collisions_mean"])
    for metric in ("makespan", "load_balance", "robot_collisions", "coverage"):
        assert teams.loc[2, f"{metric}_mean"] == pytest.approx(team[metric].mean(), rel=1e-5)
    table = (tmp_path / "out" / "leaderboard.md").read_text()
    assert "### Teams" in table and "| a320_cell | sequential | random_bounce |  | 2 | 2 |" in table


def test_leaderboard_is_reproducible(short_run, tmp_path):
    runs = Path(short_run["records"]).parent
    outputs = []
    for _ in range(2):
        assert leaderboard.main(["--runs", str(runs), "--out", str(tmp_path)]) == 0
        outputs.append(
            {path.relative_to(tmp_path): path.read_bytes() for path in sorted(tmp_path.rglob("*.*"))}
        )
    assert outputs[0] == outputs[1]
    names = {str(path) for path in outputs[0]}
    assert {
        "leaderboard.md",
        "leaderboard.csv",
        "uncovered.md",
        "uncovered.csv",
        "figures/bars_coverage__a320_cell.png",
        "figures/bars_time__a320_cell.png",
        "figures/coverage_time__a320_cell.png",
        "figures/trajectory__a320_cell__random_bounce__sequential__k1.png",
    } <= names
    table = (tmp_path / "leaderboard.md").read_text()
    assert "CITATION.cff" in table and f"python -m cabinbench.leaderboard --runs {runs}" in table
    assert "| a320_cell | 0.4174 / 32.14 | random_bounce |  | sequential | 1 | 3 | 3 |" in table
    # where the uncovered floor lies: the bands of a row add up to what its episodes left uncovered
    [uncovered] = pd.read_csv(tmp_path / "uncovered.csv").to_dict("records")
    bands = [value for name, value in uncovered.items() if name.startswith("uncovered ")]
    shares = [value for name, value in uncovered.items() if name.startswith("share ")]
    assert len(bands) == 5 and sum(bands) == pytest.approx(1 - uncovered["coverage"], abs=1e-5)
    assert sum(shares) == pytest.approx(1.0, abs=1e-5) and all(0 <= b <= s for b, s in zip(bands, shares))


def test_uncovered_table_leaves_out_runs_whose_layout_changed(short_run, tmp_path):
    source = Path(short_run["records"])
    runs = tmp_path / "runs"
    runs.mkdir()
    records = [json.loads(line) for line in source.read_text().splitlines()]
    (runs / source.name).write_text(
        "".join(json.dumps({**r, "layout_hash": "0" * 16}) + "\n" for r in records)
    )
    shutil.copy(source.with_suffix(".npz"), runs / source.with_suffix(".npz").name)
    assert leaderboard.main(["--runs", str(runs), "--out", str(tmp_path / "out")]) == 0
    table = (tmp_path / "out" / "uncovered.md").read_text()
    assert "a320_cell / random_bounce / sequential / K=1: left out of the uncovered table" in table
    assert "| a320_cell | random_bounce |" not in table


def test_leaderboard_reads_the_complexity_of_the_layout_as_it_is_now(short_run, tmp_path):
    # a record made before the complexity measure changed: same layout file, older number
    source = Path(short_run["records"])
    record = json.loads(source.read_text().splitlines()[0])
    stale = {"normalized": 0.3011, "total": 23.19}
    runs = tmp_path / "runs"
    runs.mkdir()
    for name, layout_hash in (("same", record["layout_hash"]), ("edited", "0" * 16)):
        (runs / f"{name}.jsonl").write_text(
            json.dumps({**record, "layout_hash": layout_hash, "layout_complexity": stale}) + "\n"
        )
        shutil.copy(source.with_suffix(".npz"), runs / f"{name}.npz")
    table = with_current_complexity(read_records(runs)).set_index("layout_hash")
    assert table.loc[record["layout_hash"], "layout_complexity"] == {
        "normalized": 0.417446,
        "total": 32.143343,
    }
    assert table.loc["0" * 16, "layout_complexity"] == stale  # another version of the layout keeps its own


def test_leaderboard_without_records_fails(tmp_path, capsys):
    (tmp_path / "empty").mkdir()
    assert leaderboard.main(["--runs", str(tmp_path / "empty"), "--out", str(tmp_path)]) == 2
    assert "no records" in capsys.readouterr().err


def test_statistics_edge_cases():
    lone = mean_ci([0.7])
    assert lone.mean == 0.7 and lone.n == 1 and math.isnan(lone.low) and math.isnan(lone.high)
    constant = mean_ci([True, True, True])
    assert (constant.mean, constant.low, constant.high) == (1.0, 1.0, 1.0)
    spread = mean_ci([0.1, 0.4, 0.5, 0.9])
    assert spread.low < spread.mean < spread.high and spread == mean_ci([0.1, 0.4, 0.5, 0.9])  # fixed seed
    assert iqm([0.0, 1.0, 1.0, 100.0]) == 1.0
    times = reach_time([10.0, None, 30.0, None])
    assert times.mean == 20.0 and times.reached == 0.5 and times.n == 2
    never = reach_time([None, None])
    assert math.isnan(never.mean) and never.reached == 0.0
    assert never.as_dict()["mean"] is None


def test_ablation_table_scores_each_training_run_and_their_spread(tmp_path):
    """The shipped ppo policy's episodes (in --runs) and another policy file's (in --ablation-runs)
    are scored per policy; the table gives the mean over policies with the lowest and highest; the
    leaderboard has a row per policy and one over both."""
    from cabinbench.baselines.ppo_gail.policy import CHECKPOINT_DIR

    other = tmp_path / "training" / "ppo" / "seed7" / "policy.pt"
    other.parent.mkdir(parents=True)
    other.write_bytes((CHECKPOINT_DIR / "ppo.pt").read_bytes())
    short = ["--baseline", "ppo", "--layout", "a320_cell", "--max-steps", "150", "--episodes", "2"]
    assert run_main([*short, "--seed", "0", "--out", str(tmp_path / "runs")])[0] == 0
    config = json.dumps({"checkpoint": str(other)})
    assert (
        run_main([*short, "--seed", "10", "--config", config, "--out", str(tmp_path / "ablation_runs")])[0]
        == 0
    )

    assert leaderboard.main(["--runs", str(tmp_path / "runs"), "--out", str(tmp_path / "out")]) == 0
    shipped = read_records(tmp_path / "runs")["coverage"].mean()
    seed7 = read_records(tmp_path / "ablation_runs")["coverage"].mean()
    assert shipped != seed7  # different episode seeds: the two policies' scores differ
    table = (tmp_path / "out" / "ablation.md").read_text()
    low, high = sorted([shipped, seed7])
    assert (
        f"| a320_cell | ppo | no | no | 2 | 4 | {(shipped + seed7) / 2:.3f} [{low:.3f}, {high:.3f}] |"
        in table
    )
    assert f"shipped {shipped:.3f} / 0.00, seed7 {seed7:.3f} / 0.00 |" in table  # 150 steps clear no cell
    lines_csv = (tmp_path / "out" / "ablation.csv").read_text().splitlines()
    assert lines_csv[0] == "layout,baseline,policy,episodes,coverage,success,cells_cleared"
    assert [line.split(",")[2] for line in lines_csv[1:]] == ["shipped", str(other)]
    board = (tmp_path / "out" / "leaderboard.md").read_text()
    for policy, episodes in (("seed0 (shipped)", 2), ("seed7", 2), ("all seeds", 4)):  # every training seed
        assert (
            f"| a320_cell | 0.4174 / 32.14 | ppo | {policy} | sequential | 1 | {episodes} | {episodes} |"
            in board
        )
    assert Image.open(tmp_path / "out" / "figures" / "ablation_coverage.png").size[0] > 500


def children(pid: int) -> list[int]:
    """The live child processes of ``pid`` (Linux /proc)."""
    found = []
    for task in Path(f"/proc/{pid}/task").glob("*/children"):
        found += [int(child) for child in task.read_text().split()]
    return found


def alive(pid: int) -> bool:
    """True while ``pid`` runs (a zombie, dead but not yet reaped by its new parent, is not alive)."""
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] != "Z"
    except FileNotFoundError:
        return False


def wait_until(condition, seconds: float) -> bool:
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        if condition():
            return True
        time.sleep(0.1)
    return condition()


LONG = ["--baseline", "random_bounce", "--layout", "a320_cell", "--max-steps", "1500", "--episodes", "50"]


def ctrl_c_as_in_a_terminal() -> None:
    """``preexec_fn`` for a child that must see Ctrl-C: SIGINT back to its default, so Python installs its
    KeyboardInterrupt handler even when the tests run in a background job, which inherits SIGINT ignored."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


@pytest.mark.skipif(not Path("/proc/self/task").is_dir(), reason="reads the process tree from Linux /proc")
def test_workers_die_with_a_killed_run(tmp_path):
    """kill -9 leaves the parent no chance to stop its pool: the workers notice and end themselves."""
    command = [sys.executable, "-m", "cabinbench.run", *LONG, "--workers", "2", "--out", str(tmp_path)]
    process = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        assert wait_until(lambda: len(children(process.pid)) >= 2, 60), "the run did not start its workers"
        workers = children(process.pid)
        process.kill()
        process.wait()
        assert wait_until(lambda: not any(alive(worker) for worker in workers), 5), workers
    finally:
        process.kill()


def test_ctrl_c_keeps_what_is_on_disk_and_says_so(tmp_path):
    """SIGINT once episodes are on disk: exit 130, one message counting the records in the file, no
    traceback, no temporary file."""
    command = [sys.executable, "-m", "cabinbench.run", *LONG, "--out", str(tmp_path)]
    process = subprocess.Popen(
        command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, preexec_fn=ctrl_c_as_in_a_terminal
    )

    def records() -> list[str]:
        return [line for path in tmp_path.glob("*.jsonl") for line in path.read_text().splitlines()]

    assert wait_until(lambda: len(records()) >= 2, 120), "no episode finished"
    process.send_signal(signal.SIGINT)
    _, stderr = process.communicate(timeout=60)
    assert process.returncode == 130 and "Traceback" not in stderr
    [message] = [line for line in stderr.splitlines() if line.startswith("interrupted")]
    assert f"interrupted: {len(records())} finished episode(s) kept" in message
    assert not list(tmp_path.glob("*.tmp"))
