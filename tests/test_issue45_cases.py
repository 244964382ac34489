"""Cases of issue 45 that no other test tried as the issue gives them: a layout too large for ``train``,
the issue's own large files for ``complexity``, every output under ``/proc``, and Ctrl-C in ``train`` with
worker processes (where it once gave tracebacks, a worker's or WorkerDied's wrong advice, instead of one
line). The commands run as real subprocesses."""

from __future__ import annotations

import contextlib
import os
import shutil
import signal
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest

from tests.test_run_and_leaderboard import children, ctrl_c_as_in_a_terminal, wait_until
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


def train_with_workers(tmp_path: Path, layout: str) -> subprocess.Popen:
    """``train`` with two workers (the main process steps half the batch, a worker process the other half)
    in a process group of its own, which a terminal's Ctrl-C reaches whole."""
    train = ["--baseline", "ppo", "--layout", layout, "--num-envs", "4", "--steps-per-env", "8"]
    train += ["--validation-episodes", "0", "--save-interval", "1", "--workers", "2", "--no-progress"]
    return subprocess.Popen(
        [sys.executable, "-m", "cabinbench.train", *train, "--run-dir", "run", "--iterations", "1000"],
        cwd=tmp_path,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
        preexec_fn=ctrl_c_as_in_a_terminal,
    )


def spawning(pid: int) -> bool:
    """Whether the main thread of ``pid`` blocks or ignores SIGINT (Linux /proc) while its multiprocessing
    resource tracker runs: the main process of a batched env starts the tracker, then holds SIGINT while
    it spawns its workers (a Ctrl-C then waits; it was ignored, and lost). The other moments that block
    it, every subprocess's ``vfork``, come before. Fails once a worker runs and SIGINT is not held: the
    moment (milliseconds) passed between two looks."""
    fields = dict(line.split(":\t", 1) for line in Path(f"/proc/{pid}/status").read_text().splitlines())
    holds = any(int(fields[name], 16) >> (signal.SIGINT - 1) & 1 for name in ("SigBlk", "SigIgn"))
    commands = [cmdline(child) for child in children(pid)]
    if not holds and any(b"spawn_main" in command for command in commands):
        raise MomentMissed("the spawn passed unseen")
    return holds and any(b"multiprocessing.resource_tracker" in command for command in commands)


def cmdline(pid: int) -> bytes:
    """The command line of ``pid`` (Linux /proc); empty once it has ended."""
    try:
        return Path(f"/proc/{pid}/cmdline").read_bytes()
    except OSError:
        return b""


def worker_running_for(seconds: float):
    """The moment the worker of a train (its second child) has run for ``seconds``."""
    first_seen = []

    def moment(pid: int) -> bool:
        if not first_seen and len(children(pid)) >= 2:
            first_seen.append(time.monotonic())
        return bool(first_seen) and time.monotonic() - first_seen[0] >= seconds

    return moment


def group_alive(group: int) -> list[int]:
    """The processes of process group ``group`` that still run (Linux /proc)."""
    members = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        with contextlib.suppress(OSError):  # a process that ended meanwhile
            state, _, group_of = stat.read_text().rsplit(")", 1)[1].split()[:3]
            if int(group_of) == group and state != "Z":
                members.append(int(stat.parent.name))
    return members


class MomentMissed(Exception):
    """A moment of milliseconds passed between two looks of the poll (a loaded machine): a harness miss, not
    the behaviour under test, so ``ctrl_c`` starts a fresh train and looks again."""


def ctrl_c(tmp_path: Path, layout: str, moment, tries: int = 5) -> tuple[subprocess.Popen, str]:
    """Ctrl-C to a ``train`` with workers as soon as ``moment(pid)`` is true (polled every millisecond):
    the process, and what it printed. A missed moment (``MomentMissed``) kills that train and starts
    another, up to ``tries`` trains."""
    for _ in range(tries):
        shutil.rmtree(tmp_path / "run", ignore_errors=True)
        process = train_with_workers(tmp_path, layout)
        try:
            deadline = time.monotonic() + 240
            while not moment(process.pid):
                assert process.poll() is None and time.monotonic() < deadline, "the moment never came"
                time.sleep(0.001)
        except MomentMissed:
            os.killpg(process.pid, signal.SIGKILL)
            process.communicate()
            assert wait_until(lambda group=process.pid: not group_alive(group), 10), "a missed try left some"
            continue
        try:
            os.killpg(process.pid, signal.SIGINT)
            _, stderr = process.communicate(timeout=60)  # a lost Ctrl-C: training goes on (TimeoutExpired)
        finally:
            process.kill()
        return process, stderr
    pytest.fail(f"the moment passed unseen in each of {tries} trains")


def assert_interrupted_in_one_line(process: subprocess.Popen, stderr: str, moment: str) -> None:
    """Exit 130 with the line of an interrupted run (after train's heading, if it came that far), and no
    process of its group left."""
    assert process.returncode == 130 and "Traceback" not in stderr, f"{moment}: {stderr}"
    assert "KeyboardInterrupt" not in stderr and "WorkerDied" not in stderr, f"{moment}: {stderr}"
    *heading, last = stderr.splitlines()
    assert last == "interrupted: finished checkpoints are kept in run; continue with --resume", moment
    assert all(line.startswith("training ppo on ") for line in heading), f"{moment}: {stderr}"
    assert wait_until(lambda: not group_alive(process.pid), 10), f"{moment}: {group_alive(process.pid)} left"


@pytest.mark.skipif(not Path("/proc/self/task").is_dir(), reason="reads the process tree from Linux /proc")
def test_ctrl_c_while_train_starts_its_workers_is_never_lost_and_is_one_line(tmp_path):
    """Each moment in a train of its own, at once. On full_cabin the layouts a worker is given are larger
    than a pipe holds: a spawn that sends them lasts until the worker has imported them (seconds), and a
    Ctrl-C that the main process ignored all that time was lost (training went on). Every try must end
    in the one line, exit 130, with no process of its group left."""
    starting = {
        "as the worker is spawned": spawning,  # milliseconds
        "as the worker appears": worker_running_for(0.0),  # the main process sends it its layouts
        "while the worker imports": worker_running_for(1.0),
    }
    folders = {moment: tmp_path / str(number) for number, moment in enumerate(starting)}
    for folder in folders.values():
        folder.mkdir()
    with ThreadPoolExecutor(max_workers=len(starting)) as pool:
        tries = {
            moment: pool.submit(ctrl_c, folders[moment], "full_cabin", starting[moment])
            for moment in starting
        }
    for moment, attempt in tries.items():
        assert_interrupted_in_one_line(*attempt.result(), moment)


@pytest.mark.skipif(not Path("/proc/self/task").is_dir(), reason="reads the process tree from Linux /proc")
def test_ctrl_c_while_train_steps_its_workers_is_one_line_exit_130_and_leaves_no_worker(tmp_path):
    """Where it once gave two tracebacks and WorkerDied's wrong advice."""
    process, stderr = ctrl_c(
        tmp_path, "a320_cell", lambda pid: list((tmp_path / "run" / "checkpoints").glob("*.pt"))
    )
    assert_interrupted_in_one_line(process, stderr, "while the batch steps")
