"""Submissions of a path or an ONNX policy carry the plans or the model (each with its sha256), are filed
and verified by replay where those files are not, and a plan or a model changed after the run fails
verification."""

from __future__ import annotations

import base64
import hashlib
import json
import shutil
from pathlib import Path

import numpy as np
import onnx
import pytest
from cabinbench.baselines.onnx.export import export_onnx
from cabinbench.baselines.path import PathBaseline, planned_paths, write_paths
from cabinbench.baselines.ppo_gail.policy import CHECKPOINT_DIR

from cabinbench.commands import leaderboard, run
from cabinbench.errors import BaselineError
from cabinbench.layouts.resolve import load_layout
from cabinbench.layouts.suites import get_suite
from cabinbench.leaderboard.submissions import checksum

CLASSIC = get_suite("classic")
WAYPOINTS = 6  # a short plan: the first waypoints of the boustrophedon's on each layout


def submitted(folder: Path, baseline: str, config: dict, monkeypatch) -> Path:
    """``run --suite classic --submission`` in ``folder``, where ``config`` names its files."""
    monkeypatch.chdir(folder)
    arguments = ["--baseline", baseline, "--config", json.dumps(config), "--suite", "classic"]
    assert run.main([*arguments, "--out", "runs", "--submission", "submission.json"]) == 0
    return folder / "submission.json"


def leaderboard_main(folder: Path, *arguments: str) -> int:
    return leaderboard.main(
        ["--runs", str(folder / "runs"), "--submissions", str(folder / "filed"), *arguments]
    )


def resealed(submission: Path, name: str, content: bytes, target: Path, file_hash: bool = True) -> Path:
    """The submission with the file ``name`` it carries replaced by ``content``, its checksum (and, with
    ``file_hash``, the file's sha256) recomputed, as anyone can: written to ``target``."""
    body = json.loads(submission.read_text())
    entry = body["files"][name]
    entry["base64"] = base64.b64encode(content).decode("ascii")
    if file_hash:
        entry["sha256"] = hashlib.sha256(content).hexdigest()
    body["checksum"] = checksum(body)
    target.write_text(json.dumps(body))
    return target


@pytest.fixture(scope="module")
def path_submission(tmp_path_factory) -> tuple[Path, dict[str, bytes]]:
    """A path submission on the classic suite, a short CSV plan per layout, and the plans' contents (their
    files removed after the run)."""
    work = tmp_path_factory.mktemp("submitter")
    (work / "plans").mkdir()
    plans = {}
    for layout in CLASSIC.layout_names:
        [points] = planned_paths("boustrophedon", layout)
        plans[layout] = f"plans/{layout}.csv"
        write_paths(work / plans[layout], [points[:WAYPOINTS]], f"first waypoints of the plan of {layout}")
    with pytest.MonkeyPatch.context() as monkeypatch:
        submission = submitted(work, "path", {"file": plans}, monkeypatch)
    contents = {name: (work / name).read_bytes() for name in plans.values()}
    shutil.rmtree(work / "plans")
    return submission, contents


def test_a_path_submission_carries_its_plans_and_verifies_without_them(
    path_submission, tmp_path, monkeypatch, capsys
):
    submission, contents = path_submission
    monkeypatch.chdir(tmp_path)
    carried = json.loads(submission.read_text())["files"]
    assert {name: entry["sha256"] for name, entry in carried.items()} == {
        name: hashlib.sha256(content).hexdigest() for name, content in contents.items()
    }
    assert leaderboard_main(tmp_path, "--add", str(submission)) == 0
    [filed] = (tmp_path / "filed").glob("*.json")
    assert leaderboard_main(tmp_path, "--verify", str(filed)) == 0
    assert "verified: all 7 episodes replayed and matched" in capsys.readouterr().out


def test_a_changed_plan_fails_verification_and_a_plan_unlike_its_hash_is_refused(
    path_submission, tmp_path, monkeypatch, capsys
):
    submission, contents = path_submission
    monkeypatch.chdir(tmp_path)
    name = "plans/a320_cell.csv"
    rows = contents[name].decode().splitlines()
    x, y, yaw = rows[3].split(",")
    rows[3] = f"{float(x) + 0.1},{y},{yaw}"  # one waypoint 10 cm to the side
    changed = "\n".join(rows).encode() + b"\n"
    assert (
        leaderboard_main(tmp_path, "--verify", str(resealed(submission, name, changed, tmp_path / "a.json")))
        == 1
    )
    said = capsys.readouterr().out
    assert (
        "differs: a320_cell seed 0: coverage submitted" in said and "unverified: the replay differs" in said
    )
    unsealed = resealed(submission, name, changed, tmp_path / "b.json", file_hash=False)
    assert leaderboard_main(tmp_path, "--add", str(unsealed)) == 2
    problem = f"file {name}: its content does not match its sha256: it was changed after the run"
    assert capsys.readouterr().err == f"error: {unsealed}: {problem}\n"


def test_an_onnx_submission_carries_its_model_and_a_changed_weight_fails_verification(
    tmp_path, monkeypatch, capsys
):
    work = tmp_path / "submitter"
    work.mkdir()
    model = export_onnx(CHECKPOINT_DIR / "ppo.pt", work / "model.onnx")
    submission = submitted(work, "onnx", {"file": "model.onnx"}, monkeypatch)
    proto = onnx.load(model)
    model.unlink()
    monkeypatch.chdir(tmp_path)
    assert leaderboard_main(tmp_path, "--verify", str(submission)) == 0
    assert "verified: all 7 episodes replayed and matched" in capsys.readouterr().out

    weights = proto.graph.initializer[-1]  # a tensor of the network (weights, a bias, the normaliser) nudged
    weights.CopyFrom(onnx.numpy_helper.from_array(onnx.numpy_helper.to_array(weights) + 0.01, weights.name))
    changed = resealed(submission, "model.onnx", proto.SerializeToString(), tmp_path / "changed.json")
    assert leaderboard_main(tmp_path, "--verify", str(changed), "--episodes", "2") == 1
    assert "unverified: the replay differs" in capsys.readouterr().out

    body = json.loads(submission.read_text())
    del body["files"]
    body["checksum"] = checksum(body)
    (tmp_path / "bare.json").write_text(json.dumps(body))
    assert leaderboard_main(tmp_path, "--add", str(tmp_path / "bare.json")) == 2
    assert "baseline onnx reads model.onnx, which the submission does not carry" in capsys.readouterr().err


def test_a_plan_per_layout_names_a_missing_layout_in_one_line(tmp_path):
    [points] = planned_paths("boustrophedon", "a320_cell")
    plan = str(write_paths(tmp_path / "a320_cell.csv", [points[:WAYPOINTS]], "a320_cell"))
    baseline = PathBaseline(file={"a320_cell": plan})
    assert np.array_equal(baseline.checked_paths(load_layout("a320_cell"), 1)[0], points[:WAYPOINTS])
    with pytest.raises(
        BaselineError, match=r"^--config file: no path for layout full_cabin \(paths for a320"
    ):
        baseline.checked_paths(load_layout("full_cabin"), 1)


def test_a_learned_policy_submission_carries_its_checkpoint(tmp_path, monkeypatch, capsys):
    work = tmp_path / "submitter"
    work.mkdir()
    shutil.copy(CHECKPOINT_DIR / "ppo.pt", work / "mine.pt")
    submission = submitted(work, "ppo", {"checkpoint": "mine.pt"}, monkeypatch)
    assert set(json.loads(submission.read_text())["files"]) == {"mine.pt"}
    (work / "mine.pt").unlink()
    monkeypatch.chdir(tmp_path)
    assert leaderboard_main(tmp_path, "--verify", str(submission), "--episodes", "1") == 0
    assert "1 of 7" in capsys.readouterr().out
