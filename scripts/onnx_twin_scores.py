"""Does ``run`` score every shipped torch policy and its ONNX twin alike? Episode by episode, on one layout.

    python scripts/onnx_twin_scores.py [--layout a320_cell] [--seeds 0 1] [--float32]

For every shipped ``checkpoints/<name>.pt`` with its ``<name>.onnx`` (``scripts/export_onnx.py``), the torch
baseline (``<name>``, or the file's ablation with ``checkpoint=`` for the study's two networks) and the
``onnx`` baseline play the same episodes (the team policy with K = 2); per episode it prints both coverages,
how many metrics differ, and the first step at which the robots' positions
part (at all, and by more than 1 cm).

The shipped files act in float64 (their ``inference`` entry) and round the mean action to float32, as their
twins do, so the two play the same episodes. ``--float32`` plays copies written as files were before that
entry, acting in float32, and their twins, written to a temporary folder: torch and onnxruntime sum a layer's
products in different orders, and how soon the episodes part is the paper's float-precision limitation.
Needs ``pip install "cabinbench[train,onnx]"``; about 1 s an episode on one core.
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import numpy as np
import torch
from cabinbench.baselines.onnx.export import export_onnx
from cabinbench.baselines.ppo_gail.policy import CHECKPOINT_DIR

from cabinbench.agents import load_baseline, registered_baselines
from cabinbench.episodes import run_episode
from cabinbench.metrics import METRICS, TEAM_METRICS

APART = 0.01  # metres: robots this far apart are on different courses


def float32_copy(checkpoint: Path, folder: Path) -> Path:
    """A copy of ``checkpoint`` in ``folder`` without its ``inference`` entry (so acting in float32), with its
    ONNX twin beside it."""
    policy = torch.load(checkpoint, weights_only=True)
    policy.pop("inference", None)
    copy = folder / checkpoint.name
    torch.save(policy, copy)
    export_onnx(copy, copy.with_suffix(".onnx"))
    return copy


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
    parser.add_argument("--float32", action="store_true", help="copies that act in float32, and their twins")
    args = parser.parse_args()
    folder = Path(tempfile.mkdtemp())
    print("policy                   seed  coverage torch / onnx  metrics differing  parted at step")
    for checkpoint in sorted(CHECKPOINT_DIR.glob("*.pt")):
        name = checkpoint.stem
        if not checkpoint.with_suffix(".onnx").exists():
            print(f"{name:<24} no twin: python scripts/export_onnx.py {checkpoint}", flush=True)
            continue
        ablation = load_baseline("onnx", file=str(checkpoint.with_suffix(".onnx"))).model.metadata["ablation"]
        spec = name if name in registered_baselines() else ablation
        played = float32_copy(checkpoint, folder) if args.float32 else checkpoint
        config, twin = {"checkpoint": str(played)}, played.with_suffix(".onnx")
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
