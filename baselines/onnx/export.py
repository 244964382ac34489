"""A torch policy file's ONNX twin (needs torch and onnx: ``pip install "cabinbench[train,onnx]"``).

    export_onnx("runs/train/ppo_gail__seed0/policy.pt", "policy.onnx")

The actor of a ``cabinbench-policy/1`` file (:mod:`cabinbench.baselines.ppo_gail.policy`: observation
normaliser + MLP) is exported with ``torch.onnx.export`` as ``observation [batch, D] float32 ->
action_mean [batch, A]``, and the file's observation settings, action std, ablation, env config and
training summary go into the model's ``metadata_props`` (see :mod:`.policy`), so that the ``onnx``
baseline runs it as the torch policy runs, without torch.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

from cabinbench.baselines.onnx.policy import FORMAT

INPUT, OUTPUT = "observation", "action_mean"


def policy_metadata(policy: dict, source: str) -> dict[str, str]:
    """The ``metadata_props`` of a read policy file (``read_policy_file``): strings, JSON for the rest."""
    return {
        "format": FORMAT,
        "ablation": policy["ablation"],
        "source": source,
        "observation_config": json.dumps(policy["observation_config"]),
        "action_std": json.dumps(policy["action_std"].tolist()),
        "env_config": json.dumps(policy.get("env_config", {})),
        "training": json.dumps(policy.get("training", {})),
    }


def export_onnx(policy_file: str | os.PathLike, onnx_file: str | os.PathLike) -> Path:
    """Write the ONNX twin of ``policy_file`` to ``onnx_file``; returns its path. The batch axis is
    dynamic."""
    import onnx
    import torch
    from cabinbench.baselines.ppo_gail.policy import read_policy_file

    policy = read_policy_file(policy_file)
    network = policy["network"]
    example = torch.zeros(1, policy["actor"]["observation_size"])
    program = torch.onnx.export(
        network,
        (example,),
        input_names=[INPUT],
        output_names=[OUTPUT],
        dynamic_shapes=({0: torch.export.Dim("batch")},),
        dynamo=True,
        verbose=False,
    )
    model = program.model_proto
    onnx.helper.set_model_props(model, policy_metadata(policy, Path(policy_file).name))
    onnx.checker.check_model(model)
    onnx.save(model, onnx_file)
    return Path(onnx_file)
