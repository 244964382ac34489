"""``train`` writes the ONNX twin of every policy it exports (``policy.pt`` -> ``policy.onnx``) for the
``onnx`` baseline, ``--ship`` and ``--keep`` copy it with the policy, and the twin acts as the torch policy
does, a recurrent policy's too (its memory's state an input and an output of the model): to the bit, as the
policy files written now act in float64 and round their mean actions to float32 (issue 44), so that ``run``
scores the twin as it scores the torch policy."""

from __future__ import annotations

import numpy as np
from cabinbench.baselines.onnx import OnnxPolicy
from cabinbench.baselines.ppo_gail import cli

from cabinbench.commands.train import main as train_main
from cabinbench.episodes import run_episode
from tests import test_imitation, test_recurrent
from tests.test_onnx_baseline import PARITY_STEPS, twin_action_gaps

PPO_TINY = ["--layout", "a320_cell", "--iterations", "1", "--num-envs", "4", "--steps-per-env", "8"]
PPO_TINY += ["--max-steps", "20", "--validation-episodes", "0", "--no-progress"]
EPISODE_STEPS = 500  # long enough for float32 twins to part (scripts/onnx_twin_scores.py --float32)


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
    assert len(gaps) == PARITY_STEPS and max(gaps) == 0
    assert_run_scores_the_twin_as_the_policy(tmp_path / "run" / "policy.pt", twin)


def test_an_imitation_policy_has_a_twin_that_takes_its_mean_action_as_it_does(tmp_path):
    run_dir = tmp_path / "bc"
    assert test_imitation.train("bc", run_dir, 1) == 0
    gaps = twin_action_gaps(run_dir / "policy.pt", run_dir / "policy.onnx")  # both stochastic False
    assert len(gaps) == PARITY_STEPS and max(gaps) == 0


def test_a_recurrent_policys_twin_carries_its_memory_from_step_to_step(tmp_path):
    run_dir = tmp_path / "lstm"
    assert cli.main(["--baseline", "ppo_lstm", *test_recurrent.TINY, "--run-dir", str(run_dir)]) == 0
    twin = OnnxPolicy(file=str(run_dir / "policy.onnx"))
    inputs = [(given.name, given.type, given.shape) for given in twin.model.session.get_inputs()]
    assert inputs == [
        ("observation", "tensor(double)", ["batch", 386]),
        ("hidden", "tensor(double)", [1, "batch", 64]),
        ("cell", "tensor(double)", [1, "batch", 64]),
    ]
    gaps = twin_action_gaps(run_dir / "policy.pt", run_dir / "policy.onnx")  # both sampled, from zero state
    assert len(gaps) == PARITY_STEPS and max(gaps) == 0
    assert_run_scores_the_twin_as_the_policy(run_dir / "policy.pt", run_dir / "policy.onnx")


def assert_run_scores_the_twin_as_the_policy(policy_file, twin_file) -> None:
    """The records and trajectories of an episode of the twin are the torch policy's, sampled and mean
    actions."""
    ablation = OnnxPolicy(file=str(twin_file)).model.metadata["ablation"]
    for stochastic in (True, False):
        episode = {"env_kwargs": {"max_steps": EPISODE_STEPS}}
        torch_config = {"checkpoint": str(policy_file), "stochastic": stochastic}
        torch_record, torch_path = run_episode(ablation, "a320_cell", 0, config=torch_config, **episode)
        onnx_config = {"file": str(twin_file), "stochastic": stochastic}
        onnx_record, onnx_path = run_episode("onnx", "a320_cell", 0, config=onnx_config, **episode)
        assert {**onnx_record, "wall_time": 0} == {**torch_record, "wall_time": 0}
        assert onnx_path.keys() == torch_path.keys()
        assert all(np.array_equal(onnx_path[key], torch_path[key]) for key in torch_path), stochastic
