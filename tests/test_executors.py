"""The executors behind ``run_jobs`` and ``train --seeds``: Ray tasks give the local executor's records and
run folders, a dead worker fails only its own job, and an interrupted training sweep resumes from its
checkpoints.

One real local Ray instance (2 CPUs, no dashboard) serves the whole module; the commands join it with
``--address`` as they would join a cluster, in real subprocesses.
"""

import csv
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import ray

from tests.test_run_and_leaderboard import SHORT, VARYING, ctrl_c_as_in_a_terminal, lines, stable

TIMING_COLUMNS = ("train_time", "iteration_time")  # the only metrics.csv columns that depend on the clock
TINY_TRAINING = [
    *("--baseline", "ppo", "--layout", "a320_cell", "--num-envs", "2", "--steps-per-env", "8"),
    *("--validation-episodes", "0", "--save-interval", "1"),
]

DYING_PLUGIN = '''
import os
import signal

from cabinbench.baselines.random_bounce import RandomBounce


class DiesOnSeedOne(RandomBounce):
    """random_bounce, whose worker process is killed outright in the episode seeded 1."""

    def reset(self, context, observation, info):
        if context.seed == 1:
            os.kill(os.getpid(), signal.SIGKILL)
        super().reset(context, observation, info)
'''


@pytest.fixture(scope="module")
def cluster():
    """The address of a local Ray instance with 2 CPUs."""
    ray.init(address="local", num_cpus=2, include_dashboard=False, logging_level="WARNING")
    try:
        yield ray.get_runtime_context().gcs_address
    finally:
        ray.shutdown()


def command(module: str, argv: list[str], cwd: Path, timeout: float = 600) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", module, *argv], cwd=cwd, capture_output=True, text=True, timeout=timeout
    )


def run_records(argv: list[str], cwd: Path) -> tuple[dict, list[dict], subprocess.CompletedProcess]:
    completed = command("cabinbench.run", [*argv, "--out", "out", "--json"], cwd)
    summary = json.loads(completed.stdout) if completed.stdout else {}
    return summary, lines(cwd / summary["records"]) if summary else [], completed


def test_ray_run_gives_the_local_runs_records_summary_and_file_name(cluster, tmp_path):
    argv = [*SHORT, "--episodes", "4", "--seed", "3"]
    (tmp_path / "local").mkdir(), (tmp_path / "ray").mkdir()
    local, local_records, completed = run_records(argv, tmp_path / "local")
    assert completed.returncode == 0, completed.stderr
    remote, ray_records, completed = run_records(
        [*argv, "--executor", "ray", "--address", cluster], tmp_path / "ray"
    )
    assert completed.returncode == 0, completed.stderr
    assert [record["episode"] for record in stable(ray_records)] == [0, 1, 2, 3]
    assert stable(ray_records) == stable(local_records)
    for summary in (local, remote):
        summary["metrics"].pop("wall_time")
    assert {k: v for k, v in remote.items() if k not in ("records", "trajectories")} == {
        k: v for k, v in local.items() if k not in ("records", "trajectories")
    }

    def name_without_time(path: str) -> str:  # <layout>__<baseline>__<protocol>__k<K>__seed<S>-<UTC time>
        return Path(path).name.rsplit("-", 1)[0]

    assert name_without_time(remote["records"]) == name_without_time(local["records"])
    assert {"wall_time", "timestamp"} == set(VARYING)


def test_a_plugin_resolves_on_the_workers_and_a_dead_worker_fails_only_its_episode(cluster, tmp_path):
    """A ``package.module:Class`` baseline beside the working folder reaches the workers; the worker of
    episode 1 is killed outright (SIGKILL): that episode fails in one line, the others are recorded as
    random_bounce's."""
    (tmp_path / "my_baselines").mkdir()
    (tmp_path / "my_baselines" / "__init__.py").write_text("")
    (tmp_path / "my_baselines" / "dying.py").write_text(DYING_PLUGIN)
    argv = ["--layout", "a320_cell", "--max-steps", "200", "--episodes", "3"]
    summary, records, completed = run_records(
        ["--baseline", "my_baselines.dying:DiesOnSeedOne", *argv, "--executor", "ray", "--address", cluster],
        tmp_path,
    )
    assert completed.returncode == 1
    errors = [line for line in completed.stderr.splitlines() if line.startswith("error:")]
    assert errors == [
        "error: episode 1 of a320_cell (seed 1) failed: its Ray worker died (WorkerCrashedError); "
        "play it again with --layout a320_cell --seed 1 --episodes 1"
    ]
    assert "Traceback" not in completed.stderr
    assert summary["episodes"] == 2 and [record["episode"] for record in stable(records)] == [0, 2]
    _, reference, _ = run_records(["--baseline", "random_bounce", *argv], tmp_path)
    assert [{**record, "baseline": None} for record in stable(records)] == [
        {**record, "baseline": None} for record in stable(reference) if record["episode"] != 1
    ]


def test_a_cluster_that_asks_for_its_token_gets_one_line_on_how_to_give_it(cluster, tmp_path):
    """A new Ray instance uses Ray's token authentication, and Ray sends the token to an address given by
    hand only with RAY_AUTH_MODE=token: without it the cluster refuses the command, which says how to
    give the token rather than that there is no cluster."""
    assert os.environ["RAY_AUTH_MODE"] == "token"  # set by ray.init for the fixture's instance
    environment = {name: value for name, value in os.environ.items() if name != "RAY_AUTH_MODE"}
    argv = [*SHORT, "--executor", "ray", "--address", cluster, "--out", "out"]
    completed = subprocess.run(
        [sys.executable, "-m", "cabinbench.run", *argv],
        cwd=tmp_path,
        env=environment,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert completed.returncode == 2
    assert [line for line in completed.stderr.splitlines() if line.startswith("error:")] == [
        f"error: --address {cluster}: the Ray cluster there asks for its authentication token; run with "
        "RAY_AUTH_MODE=token and the cluster's token in ~/.ray/auth_token (or RAY_AUTH_TOKEN), or with "
        "--address auto on one of its nodes"
    ]
    assert "Traceback" not in completed.stderr and not (tmp_path / "out").exists()


def test_without_ray_the_ray_executor_says_how_to_install_it(tmp_path):
    hide_ray = (
        "import sys; sys.modules['ray'] = None; from cabinbench.run import main; raise SystemExit(main())"
    )
    completed = subprocess.run(
        [sys.executable, "-c", hide_ray, *SHORT, "--executor", "ray", "--out", str(tmp_path)],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert completed.returncode == 2
    assert completed.stderr.strip() == (
        'error: --executor ray needs Ray, which is not installed: pip install "cabinbench[ray]"'
    )
    assert list(tmp_path.iterdir()) == []


def metrics(run_dir: Path) -> list[dict]:
    with open(run_dir / "metrics.csv", newline="") as file:
        return [{k: v for k, v in row.items() if k not in TIMING_COLUMNS} for row in csv.DictReader(file)]


def test_a_training_sweep_on_ray_writes_each_seed_as_a_local_run_would(cluster, tmp_path):
    local, remote = tmp_path / "local", tmp_path / "ray"
    local.mkdir(), remote.mkdir()
    completed = command("cabinbench.train", [*TINY_TRAINING, "--iterations", "2", "--seed", "1"], local)
    assert completed.returncode == 0, completed.stderr
    sweep = [
        *("--baseline", "ppo", "ppo_icm"),  # one sweep of both
        *TINY_TRAINING[2:],
        "--iterations",
        "2",
        "--seeds",
        "0",
        "1",
        "--run-dir",
        "swept",
        "--executor",
        "ray",
        "--address",
        cluster,
    ]
    completed = command("cabinbench.train", sweep, remote)
    assert completed.returncode == 0, completed.stderr
    for baseline in ("ppo", "ppo_icm"):
        for seed in (0, 1):
            assert f"{baseline} seed {seed}: done (swept/{baseline}__seed{seed})" in completed.stderr
    single, swept = local / "runs/train/ppo__seed1", remote / "swept/ppo__seed1"
    assert sorted(p.relative_to(swept) for p in swept.rglob("*")) == sorted(
        p.relative_to(single) for p in single.rglob("*")
    )
    assert (swept / "config.json").read_text() == (single / "config.json").read_text()
    assert metrics(swept) == metrics(single) and len(metrics(swept)) == 2
    assert metrics(remote / "swept/ppo__seed0") != metrics(swept)  # another seed, another run
    curiosity = [
        row["curiosity_forward"]
        for run in ("ppo", "ppo_icm")
        for row in metrics(remote / f"swept/{run}__seed1")
    ]
    assert curiosity[:2] == ["", ""] and all(curiosity[2:])  # each baseline trained as itself


def test_an_interrupted_sweep_resumes_the_unfinished_seeds_from_their_checkpoints(tmp_path):
    """Ctrl-C (SIGINT to the process group) stops a local sweep of two seeds once each has a checkpoint; the
    same command with --resume continues each seed from its latest checkpoint (its earlier checkpoints are
    not written again) to the end."""
    sweep = [*TINY_TRAINING, "--seeds", "0", "1", "--executor", "local"]
    process = subprocess.Popen(
        [sys.executable, "-m", "cabinbench.train", *sweep, "--iterations", "1000"],
        cwd=tmp_path,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
        preexec_fn=ctrl_c_as_in_a_terminal,
    )
    runs = [tmp_path / f"runs/train/ppo__seed{seed}" for seed in (0, 1)]
    deadline = time.monotonic() + 300
    while not all(list((run / "checkpoints").glob("*.pt")) for run in runs):
        assert process.poll() is None and time.monotonic() < deadline
        time.sleep(0.2)
    os.killpg(process.pid, signal.SIGINT)
    _, stderr = process.communicate(timeout=120)
    assert process.returncode == 130
    assert (
        "not finished: ppo seed 0, ppo seed 1; continue them from their checkpoints with the same command "
        "and --resume" in (stderr)
    )
    before = {path: path.stat().st_mtime_ns for run in runs for path in (run / "checkpoints").glob("*.pt")}
    last = max(int(path.stem.split("_")[1]) for path in before)

    completed = command("cabinbench.train", [*sweep, "--iterations", str(last + 2), "--resume"], tmp_path)
    assert completed.returncode == 0, completed.stderr
    for run in runs:
        assert [int(row["iteration"]) for row in metrics(run)] == list(range(1, last + 3))
        assert (run / "policy.pt").is_file()
    assert all(path.stat().st_mtime_ns == written for path, written in before.items())
