"""Cases of issue 45 that no other test tried as the issue gives them: a layout too large for ``train``,
the issue's own large files for ``complexity``, every output under ``/proc``, and Ctrl-C in ``train`` with
worker processes (where it once gave tracebacks, a worker's or WorkerDied's wrong advice, instead of one
line). The commands run as real subprocesses."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest

from tests.test_run_and_leaderboard import alive, children, ctrl_c_as_in_a_terminal, wait_until
from tests.test_sizes import cabin

REFUSAL_S = 90  # a refusal is the interpreter's and torch's start-up; the issue's train ran 241 s first


def command(argv: list[str], cwd: Path, **environment) -> tuple[subprocess.CompletedProcess, float]:
    started = time.perf_counter()
    completed = subprocess.run(
        [sys.executable, "-m", *argv],
        cwd=cwd,
        env={**os.environ, **environment},
        capture_output=True,
        text=True,
        timeout=300,
    )
    return completed, time.perf_counter() - started


def assert_one_line(completed: subprocess.CompletedProcess, *fragments: str) -> None:
    assert completed.returncode == 2 and "Traceback" not in completed.stderr, completed.stderr
    [line] = completed.stderr.splitlines()
    for fragment in fragments:
        assert fragment in line


def test_train_refuses_a_layout_too_large_in_one_line_and_writes_nothing(tmp_path):
    (tmp_path / "endless_cabin.yaml").write_text(cabin(10_000_000))
    argv = ["cabinbench.train", "--baseline", "ppo", "--layout", "endless_cabin", "--iterations", "1"]
    completed, elapsed = command([*argv, "--run-dir", "run"], tmp_path, CABINBENCH_LAYOUT_PATH=str(tmp_path))
    assert_one_line(completed, f"{tmp_path / 'endless_cabin.yaml'}: field 'cabin.rows'", "TiB")
    assert elapsed < REFUSAL_S
    assert sorted(path.name for path in tmp_path.iterdir()) == ["endless_cabin.yaml"]


RUN = ["cabinbench.run", "--baseline", "random_bounce", "--layout", "a320_cell", "--episodes", "1"]
SUITE_RUN = [
    "cabinbench.run",
    "--baseline",
    "random_bounce",
    "--suite",
    "classic",
    "--episodes-per-layout",
    "1",
]
UNDER_PROC = [  # (the option named, the command): test_user_errors tries each in /sys/kernel, a folder
    ("--render", [*RUN, "--render", "/proc/first.png"]),  # where nobody may write; /proc has no room
    ("--submission", [*SUITE_RUN, "--submission", "/proc/s.json"]),
    ("--out", ["cabinbench.leaderboard", "--out", "/proc/results"]),
    ("--site", ["cabinbench.leaderboard", "--site", "/proc/site"]),
    ("--png", ["cabinbench.complexity", "a320_cell", "--png", "/proc/map.png"]),
    ("--png", ["cabinbench.suites", "--png", "classic", "/proc/sheet.png"]),
    ("--out", ["cabinbench.paper", "--out", "/proc/paper.md"]),
]


@pytest.mark.skipif(not Path("/proc/self").is_dir(), reason="Linux /proc")
def test_every_output_under_proc_is_refused_in_one_line_before_any_work(tmp_path):
    with ThreadPoolExecutor(max_workers=os.cpu_count() or 2) as pool:
        results = list(pool.map(lambda case: command(case[1], tmp_path)[0], UNDER_PROC))
    for (option, _), completed in zip(UNDER_PROC, results):
        assert_one_line(completed, option, "cannot write in /proc", "give a folder you can write in")
    assert not list(tmp_path.iterdir())  # no episode ran: no runs/ folder


def grid(rows: int, columns: int) -> str:
    return "kind: grid\ngrid:\n  map: |\n" + f"    {'.' * columns}\n" * rows


@pytest.mark.parametrize(
    ("text", "field"),
    [(cabin(100_000), "cabin.rows"), (grid(20_000, 2002), "<file>")],
    ids=["cabin of 100000 rows", "grid of 20000 x 2002"],
)
def test_complexity_refuses_the_issues_large_layouts_in_one_line(tmp_path, text, field):
    """The first printed nothing for 300 s at 5 GB; the second took 24 GB until the kernel killed it."""
    (tmp_path / "large.yaml").write_text(text)
    completed, elapsed = command(["cabinbench.complexity", "large.yaml"], tmp_path)
    assert_one_line(completed, f"large.yaml: field '{field}'", "Fix:")
    assert elapsed < REFUSAL_S


@pytest.mark.skipif(not Path("/proc/self/task").is_dir(), reason="reads the process tree from Linux /proc")
@pytest.mark.parametrize("moment", ["while the workers start", "while the batch steps"])
def test_ctrl_c_in_train_with_workers_is_one_line_exit_130_and_leaves_no_worker(tmp_path, moment):
    train = ["--baseline", "ppo", "--layout", "a320_cell", "--num-envs", "4", "--steps-per-env", "8"]
    train += ["--validation-episodes", "0", "--save-interval", "1", "--workers", "2", "--no-progress"]
    process = subprocess.Popen(
        [sys.executable, "-m", "cabinbench.train", *train, "--run-dir", "run", "--iterations", "1000"],
        cwd=tmp_path,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,  # its own process group, which a terminal's Ctrl-C reaches whole
        preexec_fn=ctrl_c_as_in_a_terminal,
    )
    try:
        # the multiprocessing resource tracker, then the worker of the second half of the batch
        assert wait_until(lambda: len(children(process.pid)) >= 2, 240), "no worker started"
        if moment == "while the workers start":
            time.sleep(0.5)  # the worker imports (seconds); the main process has left the spawn
        else:
            assert wait_until(lambda: list((tmp_path / "run" / "checkpoints").glob("*.pt")), 240)
        workers = children(process.pid)
        os.killpg(process.pid, signal.SIGINT)
        _, stderr = process.communicate(timeout=120)
    finally:
        process.kill()
    assert process.returncode == 130 and "Traceback" not in stderr, stderr
    assert "KeyboardInterrupt" not in stderr and "WorkerDied" not in stderr, stderr
    assert (
        stderr.splitlines()[-1] == "interrupted: finished checkpoints are kept in run; continue with --resume"
    )
    assert stderr.count("interrupted") == 1
    assert wait_until(lambda: not any(alive(worker) for worker in workers), 10), workers
