"""Does ``run`` score every shipped torch policy and its ONNX twin alike? Episode by episode, on one layout.

    python scripts/onnx_twin_scores.py [--layout a320_cell] [--seeds 0 1] [--float64]

For every shipped ``checkpoints/<name>.pt`` with its ``<name>.onnx`` (``scripts/export_onnx.py``), the torch
baseline (``<name>``, or the file's ablation with ``checkpoint=`` for the study's two networks) and the
``onnx`` baseline play the same episodes (the team policy with K = 2); per episode it prints both coverages,
how many metrics differ, and the first step at which the robots' positions
part (at all, and by more than 1 cm).

``--float64`` is the experiment behind the report on bit-equal scores: both sides compute the network in
float64 and round its output to float32 (a torch baseline of this script against a float64 ONNX twin
written to a temporary folder), which is not how the shipped baselines compute. Needs
``pip install "cabinbench[train,onnx]"``; about 1 s an episode on one core.
"""

from __future__ import annotations

import argparse
import copy
import tempfile
from pathlib import Path

import numpy as np
import torch
from cabinbench.baselines.onnx.export import export_onnx
from cabinbench.baselines.ppo_gail.policy import CHECKPOINT_DIR

from cabinbench.agents import Baseline, exact_action, load_baseline, registered_baselines
from cabinbench.episodes import run_episode
from cabinbench.metrics import METRICS, TEAM_METRICS

APART = 0.01  # metres: robots this far apart are on different courses


class Float64(torch.nn.Module):
    """A float32 actor computed in float64, its output rounded to float32; ELU as exp(x) - 1 below 0 (the
    CPU provider of onnxruntime has no float64 Elu)."""

    def __init__(self, actor: torch.nn.Module):
        super().__init__()
        self.actor = copy.deepcopy(actor).double().eval()
        if not all(isinstance(layer, (torch.nn.Linear, torch.nn.ELU)) for layer in self.actor.mlp):
            raise ValueError("--float64 rebuilds ELU networks only")
        # std + eps once, here: torch's exporter folds a Python float into a float64 sum as a float32
        self.register_buffer("divisor", self.actor.std + self.actor.eps)

    def forward(self, observation: torch.Tensor) -> torch.Tensor:
        values, actor = observation.double(), self.actor
        if actor.normalize:
            values = (values - actor.mean) / self.divisor
        for layer in actor.mlp:
            is_elu = isinstance(layer, torch.nn.ELU)
            values = torch.where(values > 0, values, torch.exp(values) - 1) if is_elu else layer(values)
        return values.float()


class Float64Torch(Baseline):
    """The torch baseline ``ablation`` of ``checkpoint`` with its network computed by :class:`Float64`."""

    def __init__(self, ablation: str, checkpoint: str):
        super().__init__(ablation=ablation, checkpoint=checkpoint)
        self.policy = load_baseline(ablation, checkpoint=checkpoint)
        self.policy.policy = {**self.policy.policy, "network": Float64(self.policy.policy["network"])}

    @property
    def env_options(self) -> dict:
        return self.policy.env_options

    def reset(self, context, observation, info) -> None:
        self.policy.reset(context, observation, info)

    def act(self, observation, info):
        return exact_action(self.policy, observation, info)


def float64_twin(checkpoint: Path, folder: Path) -> Path:
    """The ONNX twin of ``checkpoint`` computed as :class:`Float64` computes."""
    import onnx
    from cabinbench.baselines.ppo_gail.policy import read_policy_file

    twin = folder / checkpoint.with_suffix(".onnx").name
    export_onnx(checkpoint, twin)
    policy = read_policy_file(checkpoint)
    example = torch.zeros(1, policy["actor"]["observation_size"])
    program = torch.onnx.export(
        Float64(policy["network"]).eval(),
        (example,),
        input_names=["observation"],
        output_names=["action_mean"],
        dynamo=True,
        verbose=False,
    )
    model = program.model_proto
    model.metadata_props.extend(onnx.load(twin).metadata_props)
    onnx.save(model, twin)
    return twin


def compare(torch_run: tuple[dict, dict], onnx_run: tuple[dict, dict], n_agents: int) -> dict:
    """What differs between the two episodes' records and trajectories."""
    (torch_record, torch_path), (onnx_record, onnx_path) = torch_run, onnx_run
    names = [name for name in (*METRICS, *(TEAM_METRICS if n_agents > 1 else ())) if name != "wall_time"]
    differing = [name for name in names if torch_record[name] != onnx_record[name]]
    steps = min(len(torch_path["positions"]), len(onnx_path["positions"]))
    apart = np.abs(torch_path["positions"][:steps] - onnx_path["positions"][:steps]).max(axis=(1, 2))
    return {
        "coverage": (torch_record["coverage"], onnx_record["coverage"]),
        "differing": differing,
        "parted": next((int(step) for step in np.flatnonzero(apart > 0)), None),
        "apart": next((int(step) for step in np.flatnonzero(apart > APART)), None),
        "steps": (len(torch_path["positions"]) - 1, len(onnx_path["positions"]) - 1),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--layout", default="a320_cell")
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1])
    parser.add_argument("--float64", action="store_true", help="both sides in float64 (an experiment)")
    args = parser.parse_args()
    folder = Path(tempfile.mkdtemp())
    print("policy                   seed  coverage torch / onnx  metrics differing  parted at step")
    for checkpoint in sorted(CHECKPOINT_DIR.glob("*.pt")):
        name = checkpoint.stem
        if not checkpoint.with_suffix(".onnx").exists():
            print(f"{name:<24} no twin: python scripts/export_onnx.py {checkpoint}", flush=True)
            continue
        ablation = load_baseline("onnx", file=str(checkpoint.with_suffix(".onnx"))).model.metadata["ablation"]
        spec, config = (
            (name, {}) if name in registered_baselines() else (ablation, {"checkpoint": str(checkpoint)})
        )
        twin = checkpoint.with_suffix(".onnx")
        if args.float64:
            spec, config = "__main__:Float64Torch", {"ablation": ablation, "checkpoint": str(checkpoint)}
            twin = float64_twin(checkpoint, folder)
        n_agents = 2 if ablation == "ppo_gail_team" else 1
        for seed in args.seeds:
            torch_run = run_episode(spec, args.layout, seed, n_agents=n_agents, config=config)
            onnx_run = run_episode("onnx", args.layout, seed, n_agents=n_agents, config={"file": str(twin)})
            found = compare(torch_run, onnx_run, n_agents)
            coverage = "{:.4f} / {:.4f}".format(*found["coverage"])
            differing = f"{len(found['differing'])}"
            parted = f"{found['parted']} (> 1 cm: {found['apart']}) of {found['steps']}"
            print(f"{name:<24} {seed:>4}  {coverage:<21}  {differing:<17}  {parted}", flush=True)


if __name__ == "__main__":
    main()
