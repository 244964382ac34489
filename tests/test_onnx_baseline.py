"""``onnx``: the shipped policies' ONNX twins run with onnxruntime (no torch) and act as the torch policies
do; any ONNX model runs; the observation settings travel in the model's metadata."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import onnx
import pytest
import torch
from cabinbench.baselines.onnx import OnnxPolicy
from cabinbench.baselines.onnx.policy import FORMAT
from cabinbench.baselines.ppo_gail.policy import CHECKPOINT_DIR

from cabinbench.agents import EpisodeContext, load_baseline
from cabinbench.envs.coverage_env import CoverageEnv
from cabinbench.episodes import run_episode
from cabinbench.errors import BaselineError

CHECKPOINTS = sorted(CHECKPOINT_DIR.glob("*.pt"))
PARITY_STEPS = 200


@pytest.mark.parametrize("checkpoint", CHECKPOINTS, ids=lambda path: path.stem)
def test_every_shipped_policy_has_an_onnx_twin_that_acts_alike(checkpoint):
    """Every shipped policy acts in float64 (its ``inference`` entry), as its twin does: on the observations
    of the torch policy's own episode, the twin's actions (sampled with the same seeded noise) are the
    torch policy's to the bit."""
    assert torch.load(checkpoint, weights_only=True)["inference"] == "float64"
    gaps = twin_action_gaps(checkpoint, checkpoint.with_suffix(".onnx"))
    assert len(gaps) > 100 and max(gaps) == 0


def twin_action_gaps(checkpoint: Path, twin_file: Path) -> list[float]:
    """The largest difference, step by step, between the actions of the torch policy of ``checkpoint`` and
    of the onnx baseline of its twin, on the torch policy's own episode of ``PARITY_STEPS`` on a320_cell;
    both act as their baselines do by default (sampled alike, or both the mean action)."""
    twin = OnnxPolicy(file=str(twin_file))
    metadata = twin.model.metadata
    torch_policy = load_baseline(metadata["ablation"], checkpoint=str(checkpoint))
    # the twin of this very policy (its source is the file it was exported from: a run's policy.pt if shipped)
    assert metadata["format"] == FORMAT and metadata["training"] == torch_policy.policy["training"]
    assert twin.env_options == torch_policy.env_options and twin.stochastic == torch_policy.stochastic
    env = CoverageEnv("a320_cell", max_steps=PARITY_STEPS, **twin.env_options)
    observation, info = env.reset(seed=0)
    for policy in (torch_policy, twin):
        context = EpisodeContext(env.layout, "sequential", 0, env_config=twin.env_options)
        policy.reset(context, observation, info)
    gaps = []
    for _ in range(PARITY_STEPS):
        action = torch_policy.act(observation, info)
        gaps.append(np.abs(twin.act(observation, info) - action).max())
        observation, _, terminated, truncated, info = env.step(action)
        if terminated or truncated:
            break
    return gaps


@pytest.mark.parametrize(("baseline", "n_agents"), [("ppo_gail", 1), ("ppo_gail_team", 2)])
def test_run_scores_a_shipped_policy_and_its_twin_alike(baseline, n_agents):
    """A whole episode on a320_cell, through every contact: the same record and the same trajectory."""
    onnx_config = {"file": str(CHECKPOINT_DIR / f"{baseline}.onnx")}
    torch_record, torch_path = run_episode(baseline, "a320_cell", 0, n_agents=n_agents)
    onnx_record, onnx_path = run_episode("onnx", "a320_cell", 0, n_agents=n_agents, config=onnx_config)
    assert {**onnx_record, "wall_time": 0} == {**torch_record, "wall_time": 0}
    assert all(np.array_equal(onnx_path[key], torch_path[key]) for key in torch_path)


def test_run_makes_the_env_from_the_metadata_without_torch(tmp_path):
    """The study's cleaning network sees lidar and velocity only (386 numbers): ``run`` makes that env
    from the metadata alone, in a process that never imports torch."""
    twin = CHECKPOINT_DIR / "ppo_gail_study_cleaning.onnx"
    arguments = ["--baseline", "onnx", "--config", json.dumps({"file": str(twin)}), "--layout", "a320_cell"]
    arguments += ["--episodes", "1", "--max-steps", "50", "--json", "--out", str(tmp_path)]
    script = (
        "import sys\n"
        "from cabinbench.commands import run\n"
        f"assert run.main({arguments!r}) == 0\n"
        "assert 'torch' not in sys.modules, sorted(name for name in sys.modules if 'torch' in name)[:3]\n"
    )
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    summary = json.loads(done.stdout)
    header = json.loads(Path(summary["records"]).read_text().splitlines()[0])
    assert header["env_config"]["coverage_patch"] == 0 and header["env_config"]["n_rays"] == 64
    assert summary["episodes"] == 1


def test_a_twin_refuses_an_env_with_other_observation_settings():
    twin = OnnxPolicy(file=str(CHECKPOINT_DIR / "ppo_gail.onnx"))  # trained with a 32-cell coverage patch
    env = CoverageEnv("a320_cell", coverage_patch=16)
    observation, info = env.reset(seed=0)
    context = EpisodeContext(env.layout, "sequential", 0, env_config={"coverage_patch": 16})
    with pytest.raises(BaselineError, match=r"ppo_gail.onnx: the policy was trained on another observation"):
        twin.reset(context, observation, info)


def forward_model(path: Path, width: int) -> Path:
    """An ONNX model from elsewhere (no cabinbench metadata): always full speed ahead, whatever it sees."""
    weights = onnx.numpy_helper.from_array(np.zeros((width, 2), dtype=np.float32), "weights")
    bias = onnx.numpy_helper.from_array(np.array([1.0, 0.0], dtype=np.float32), "bias")
    graph = onnx.helper.make_graph(
        [onnx.helper.make_node("Gemm", ["obs", "weights", "bias"], ["act"])],
        "forward",
        [onnx.helper.make_tensor_value_info("obs", onnx.TensorProto.FLOAT, ["batch", width])],
        [onnx.helper.make_tensor_value_info("act", onnx.TensorProto.FLOAT, ["batch", 2])],
        [weights, bias],
    )
    onnx.save(onnx.helper.make_model(graph), path)
    return path


def test_any_onnx_policy_runs_in_the_env_it_is_given(tmp_path):
    width = CoverageEnv("a320_cell").observation_space.shape[0]
    model = str(forward_model(tmp_path / "forward.onnx", width))
    record, trajectory = run_episode(
        "onnx", "a320_cell", 0, env_kwargs={"max_steps": 20}, config={"file": model}
    )
    assert record["steps"] == 20 and record["path_length"] > 0
    with pytest.raises(
        BaselineError, match="no action_std in its metadata to sample with; use stochastic false"
    ):
        OnnxPolicy(file=model, stochastic=True)
    wrong = str(forward_model(tmp_path / "narrow.onnx", width - 1))
    with pytest.raises(BaselineError, match=rf"size: model input {width - 1}, env {width}"):
        run_episode("onnx", "a320_cell", 0, env_kwargs={"max_steps": 20}, config={"file": wrong})


@pytest.mark.parametrize(
    ("contents", "problem"),
    [(b"not a model", "not a readable ONNX model"), (None, "ONNX policy file not found")],
)
def test_a_bad_onnx_file_is_one_line_naming_it(tmp_path, contents, problem):
    path = tmp_path / "policy.onnx"
    if contents is not None:
        path.write_bytes(contents)
    with pytest.raises(BaselineError) as raised:
        OnnxPolicy(file=str(path))
    assert str(raised.value).startswith(f"{path}: {problem}") and "\n" not in str(raised.value)


def test_a_model_with_state_inputs_must_give_the_next_state(tmp_path):
    """A recurrent model's state goes in and comes out again; one that only takes it is refused in a line."""
    path = forward_model(tmp_path / "forward.onnx", 8)
    model = onnx.load(path)
    model.graph.input.append(onnx.helper.make_tensor_value_info("hidden", onnx.TensorProto.FLOAT, [1, 1, 4]))
    onnx.save(model, path)
    with pytest.raises(BaselineError) as raised:
        OnnxPolicy(file=str(path))
    assert str(raised.value) == (
        f"{path}: 1 input(s) after the observation, 0 output(s) after the action; a recurrent policy takes "
        "float state inputs and gives the next state as outputs, one for each, in their order"
    )
