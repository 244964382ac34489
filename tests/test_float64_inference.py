"""A policy file's ``inference`` entry (issue 44, ``networks.Inference``): the files written now act in
float64 and round the mean action to float32, which their ONNX twins compute to the bit
(tests/test_onnx_training.py plays a trained one of each kind against its twin); the files written before
it act in float32 as they did (tests/test_issue45_float32_actions.py replays committed records)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import onnx
import onnxruntime
import pytest
import torch
import torch.nn as nn
from cabinbench.baselines.onnx.export import FLOAT64_ACTIVATIONS, export_onnx, export_twin
from cabinbench.baselines.ppo_gail.memory import RNN_TYPES, rnn
from cabinbench.baselines.ppo_gail.networks import ACTIVATIONS
from cabinbench.baselines.ppo_gail.policy import (
    CHECKPOINT_DIR,
    PolicyFileError,
    read_policy_file,
    write_policy_file,
)

from cabinbench.agents import load_baseline

WIDTH = 12


def observations(count: int = 64, width: int = WIDTH) -> torch.Tensor:
    return torch.rand(count, width, generator=torch.Generator().manual_seed(0)) * 3 - 1


def mlp_policy(path, activation: str = "elu") -> dict:
    """A small MLP policy written by ``write_policy_file``, with an observation normaliser, read back."""
    torch.manual_seed(0)
    network = nn.Sequential(nn.Linear(WIDTH, 16), ACTIVATIONS[activation](), nn.Linear(16, 2))
    normalizer = {"mean": torch.rand(WIDTH), "std": torch.rand(WIDTH) + 0.5, "eps": 1e-8}
    write_policy_file(
        path,
        network,
        activation,
        ablation="ppo",
        obs_normalizer=normalizer,
        action_std=torch.full((2,), 0.5),
        observation_config={"size": WIDTH},
    )
    return read_policy_file(path)


def file_without_inference(path: Path) -> Path:
    """The shipped ``ppo`` with its ``inference`` entry removed: a file as written before the entry."""
    policy = torch.load(CHECKPOINT_DIR / "ppo.pt", weights_only=True)
    del policy["inference"]
    torch.save(policy, path)
    return path


@pytest.mark.parametrize("rnn_type", ["lstm", "gru"])
def test_the_written_out_rnn_computes_what_torchs_does(rnn_type):
    """Two layers, five steps, a batch of three, from a random state."""
    torch.manual_seed(1)
    reference = RNN_TYPES[rnn_type](7, 5, 2).double()
    entry = {"rnn_type": rnn_type, "input_size": 7, "hidden_size": 5, "num_layers": 2}
    written = rnn({**entry, "state_dict": reference.state_dict()}, torch.float64)
    assert not isinstance(written, (nn.LSTM, nn.GRU))
    sequence, hidden, cell = (
        torch.randn(size, 3, width, dtype=torch.float64) for size, width in ((5, 7), (2, 5), (2, 5))
    )
    state = (hidden, cell) if rnn_type == "lstm" else hidden
    with torch.no_grad():
        expected, expected_state = reference(sequence, state)
        actual, actual_state = written(sequence, state)
    assert torch.allclose(actual, expected, rtol=1e-12, atol=1e-15)
    states = [state if rnn_type == "lstm" else (state,) for state in (actual_state, expected_state)]
    assert all(
        torch.allclose(mine, theirs, rtol=1e-12, atol=1e-15) for mine, theirs in zip(*states, strict=True)
    )


def test_a_written_file_acts_in_float64_and_rounds_its_mean_action_to_float32(tmp_path):
    policy = mlp_policy(tmp_path / "policy.pt")
    assert torch.load(tmp_path / "policy.pt", weights_only=True)["inference"] == "float64"
    inference = policy["inference_model"]
    with torch.no_grad():
        (mean,) = inference(observations().double())
        expected = policy["network"].double()(observations().double()).float()
    assert inference.dtype == torch.float64 and mean.dtype == torch.float32
    assert torch.equal(mean, expected)


def test_a_file_without_inference_acts_in_float32_as_before(tmp_path):
    """A file written before the entry has no ``inference``: it acts as the float32 actor, to the bit (one
    observation a call, as ``act`` computes it: a batch's matrix product may round otherwise)."""
    baseline = load_baseline(
        "ppo", checkpoint=str(file_without_inference(tmp_path / "ppo.pt")), stochastic=False
    )
    assert baseline.inference.dtype == torch.float32
    width = baseline.policy["actor"]["observation_size"]
    for observation in observations(8, width):
        with torch.no_grad():
            expected = baseline.policy["network"](observation.reshape(1, -1)).clamp(-1, 1)[0].numpy()
        assert np.array_equal(baseline.act(observation.numpy(), {}), expected)


@pytest.mark.parametrize("value", ["float16", ["float64"]])
def test_a_bad_inference_value_is_one_line_naming_the_file_and_the_field(tmp_path, value):
    path = tmp_path / "policy.pt"
    mlp_policy(path)
    torch.save({**torch.load(path, weights_only=True), "inference": value}, path)
    with pytest.raises(PolicyFileError) as raised:
        read_policy_file(path)
    assert str(raised.value).startswith(f"{path}: inference {value!r} is not 'float32' or 'float64'; ")
    assert "\n" not in str(raised.value)


@pytest.mark.parametrize("activation", list(ACTIVATIONS))
def test_a_float64_policys_twin_computes_its_mean_action_where_onnxruntime_runs_its_activation(
    activation, tmp_path
):
    """Where onnxruntime runs the activation in float64 the twin's only Cast is the mean action's to float32,
    and its means are torch's; elsewhere the export is refused in a line, which ``train`` prints for the twin
    (removing one of an earlier export)."""
    policy = mlp_policy(tmp_path / "policy.pt", activation)
    if activation not in FLOAT64_ACTIVATIONS:
        with pytest.raises(PolicyFileError) as raised:
            export_onnx(tmp_path / "policy.pt", tmp_path / "policy.onnx")
        message = str(raised.value)
        assert message.startswith(
            f"{tmp_path / 'policy.pt'}: onnxruntime cannot run activation {activation!r}"
        )
        assert "\n" not in message and not (tmp_path / "policy.onnx").exists()
        (tmp_path / "policy.onnx").write_bytes(b"an earlier twin")
        assert export_twin(tmp_path / "policy.pt") == f"none: {message}"
        assert not (tmp_path / "policy.onnx").exists()
        return
    twin = export_onnx(tmp_path / "policy.pt", tmp_path / "policy.onnx")
    assert [node.op_type for node in onnx.load(twin).graph.node].count("Cast") == 1
    session = onnxruntime.InferenceSession(str(twin), providers=["CPUExecutionProvider"])
    (mean,) = session.run(None, {"observation": observations().double().numpy()})
    with torch.no_grad():
        (expected,) = policy["inference_model"](observations().double())
    assert mean.dtype == np.float32 and np.array_equal(mean, expected.numpy())


def test_export_onnx_float64_makes_a_shipped_float32_policy_act_alike_to_its_twin(tmp_path):
    """``scripts/export_onnx.py --float64`` on a policy written before the entry (the shipped ``ppo``
    without it): the same weights, now acting in float64, and ``run`` scores it and its new twin alike."""
    from cabinbench.episodes import run_episode

    policy = file_without_inference(tmp_path / "ppo.pt")
    script = Path(__file__).resolve().parents[1] / "scripts" / "export_onnx.py"
    subprocess.run([sys.executable, str(script), "--float64", str(policy)], check=True, capture_output=True)
    written, shipped = (torch.load(path, weights_only=True) for path in (policy, CHECKPOINT_DIR / "ppo.pt"))
    assert written["inference"] == "float64"
    weights = shipped["actor"]["state_dict"]
    assert all(torch.equal(written["actor"]["state_dict"][key], value) for key, value in weights.items())
    episodes = [
        run_episode(baseline, "a320_cell", 0, env_kwargs={"max_steps": 120}, config=config)
        for baseline, config in (
            ("ppo", {"checkpoint": str(policy)}),
            ("onnx", {"file": str(policy.with_suffix(".onnx"))}),
        )
    ]
    (torch_record, torch_trajectory), (twin_record, twin_trajectory) = episodes
    assert np.array_equal(torch_trajectory["positions"], twin_trajectory["positions"])
    assert all(torch_record[name] == twin_record[name] for name in ("coverage", "steps", "path_length"))
