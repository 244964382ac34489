"""``train`` writes the ONNX twin of every policy it exports (``policy.pt`` -> ``policy.onnx``) for the
``onnx`` baseline, ``--ship`` and ``--keep`` copy it with the policy, and the twin acts as the torch policy
does; a recurrent policy, whose memory a twin cannot carry, says so and leaves none."""

from __future__ import annotations

import pytest
from cabinbench.baselines.onnx.export import NoOnnxTwin, export_onnx
from cabinbench.baselines.ppo_gail import cli
from cabinbench.baselines.ppo_gail.policy import read_policy_file

from cabinbench.commands.train import main as train_main
from tests import test_imitation, test_recurrent
from tests.test_onnx_baseline import ACTION_GAP, PARITY_STEPS, twin_action_gaps

PPO_TINY = ["--layout", "a320_cell", "--iterations", "1", "--num-envs", "4", "--steps-per-env", "8"]
PPO_TINY += ["--max-steps", "20", "--validation-episodes", "0", "--no-progress"]


def test_train_writes_the_twin_and_ship_and_keep_copy_it(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "checkpoints").mkdir()
    shipping = ["--ship", "--ship-dir", "checkpoints", "--keep"]
    assert train_main(["--baseline", "ppo", *PPO_TINY, "--run-dir", "run", *shipping]) == 0
    assert "onnx twin: run/policy.onnx (run it with --baseline onnx)" in capsys.readouterr().out
    twin = tmp_path / "run" / "policy.onnx"
    for copy in (tmp_path / "checkpoints" / "ppo.onnx", tmp_path / "results/training/ppo/seed0/policy.onnx"):
        assert copy.read_bytes() == twin.read_bytes()
    gaps = twin_action_gaps(tmp_path / "run" / "policy.pt", twin)
    assert len(gaps) == PARITY_STEPS and max(gaps) < ACTION_GAP


def test_an_imitation_policy_has_a_twin_that_takes_its_mean_action_as_it_does(tmp_path):
    run_dir = tmp_path / "bc"
    assert test_imitation.train("bc", run_dir, 1) == 0
    gaps = twin_action_gaps(run_dir / "policy.pt", run_dir / "policy.onnx")  # both stochastic False
    assert len(gaps) == PARITY_STEPS and max(gaps) < ACTION_GAP


def test_a_recurrent_policy_has_no_twin_and_training_says_why(tmp_path, capsys):
    run_dir = tmp_path / "lstm"
    (run_dir / "policy.onnx").parent.mkdir()
    (run_dir / "policy.onnx").write_bytes(b"a twin of an earlier policy")
    assert cli.main(["--baseline", "ppo_lstm", *test_recurrent.TINY, "--run-dir", str(run_dir)]) == 0
    said = capsys.readouterr().out
    assert (
        f"onnx twin: none: {run_dir / 'policy.pt'}: a recurrent policy (ppo_lstm) carries its memory" in said
    )
    assert not (run_dir / "policy.onnx").exists()
    assert read_policy_file(run_dir / "policy.pt")["memory"]
    with pytest.raises(NoOnnxTwin, match="the onnx baseline runs memoryless policies"):
        export_onnx(run_dir / "policy.pt", tmp_path / "twin.onnx")
