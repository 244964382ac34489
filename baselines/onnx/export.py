"""A torch policy file's ONNX twin (needs torch and onnx: ``pip install "cabinbench[train,onnx]"``).

    export_onnx("runs/train/ppo_gail__seed0/policy.pt", "policy.onnx")

The actor of a ``cabinbench-policy/1`` file (:mod:`cabinbench.baselines.ppo_gail.policy`: observation
normaliser + MLP) is exported with ``torch.onnx.export`` as ``observation [batch, D] float32 -> action_mean
[batch, A]``, and the file's observation settings, action std (and whether its baseline samples with it by
default), ablation, env config and training summary go into the model's ``metadata_props`` (see
:mod:`.policy`), so that the ``onnx`` baseline runs it as the torch policy runs, without torch.

``train`` writes every run's twin beside its policy file (:func:`export_twin`). A recurrent actor's
(``ppo_lstm``) takes its memory's state as further inputs and gives the next state as further outputs
(:mod:`.recurrent`), which the ``onnx`` baseline carries from step to step.
"""

from __future__ import annotations

import contextlib
import inspect
import json
import logging
import os
import warnings
from collections.abc import Iterator
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
        "stochastic": json.dumps(sampled_by_default(policy["ablation"])),
        "env_config": json.dumps(policy.get("env_config", {})),
        "training": json.dumps(policy.get("training", {})),
    }


def sampled_by_default(ablation: str) -> bool:
    """Whether the torch baseline of ``ablation`` samples its actions unless told otherwise: ``ppo_gail``'s
    family does, ``bc`` and ``dagger`` take the mean action. Its twin does as it does."""
    from cabinbench.agents import baseline_class

    return inspect.signature(baseline_class(ablation)).parameters["stochastic"].default


def export_onnx(policy_file: str | os.PathLike, onnx_file: str | os.PathLike) -> Path:
    """Write the ONNX twin of ``policy_file`` to ``onnx_file``; returns its path. The batch axis is
    dynamic. A recurrent actor's memory state is an input and an output (:mod:`.recurrent`; torch's
    exporter fixes its batch at one robot)."""
    import onnx
    import torch
    from cabinbench.baselines.ppo_gail.policy import read_policy_file

    policy = read_policy_file(policy_file)
    batch = torch.export.Dim("batch")
    if policy.get("memory"):
        from cabinbench.baselines.onnx.recurrent import RecurrentActor

        network = RecurrentActor(policy)
        states = network.state_names
        inputs, outputs = [INPUT, *states], [OUTPUT, *(f"{name}_out" for name in states)]
        examples = (torch.zeros(1, policy["memory"]["input_size"]), *network.example_state())
        batch_axes = ({0: batch}, *({1: batch} for _ in states))
    else:
        network, inputs, outputs = policy["network"], [INPUT], [OUTPUT]
        examples, batch_axes = (torch.zeros(1, policy["actor"]["observation_size"]),), ({0: batch},)
    with quiet_exporter():
        program = torch.onnx.export(
            network,
            examples,
            input_names=inputs,
            output_names=outputs,
            dynamic_shapes=batch_axes,
            dynamo=True,
            verbose=False,
        )
    model = program.model_proto
    onnx.helper.set_model_props(model, policy_metadata(policy, Path(policy_file).name))
    onnx.checker.check_model(model)
    onnx.save(model, onnx_file)
    return Path(onnx_file)


@contextlib.contextmanager
def quiet_exporter() -> Iterator[None]:
    """torch's exporter without its notes on what does not concern a policy (torchvision's operators not
    installed, torch's own deprecations and notes on the RNN's weights), which would bury ``train``'s last
    lines; the checker and the twins' tests watch what matters."""
    exporter = logging.getLogger("torch.onnx")
    level = exporter.level
    exporter.setLevel(logging.ERROR)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", FutureWarning)
            warnings.simplefilter("ignore", UserWarning)
            yield
    finally:
        exporter.setLevel(level)


def export_twin(policy_file: str | os.PathLike) -> str:
    """Write the ONNX twin of a trained ``policy.pt`` beside it as ``policy.onnx`` (``--ship`` and ``--keep``
    copy it with the policy); what was done, in a line."""
    twin = Path(policy_file).with_suffix(".onnx")
    try:
        return f"{export_onnx(policy_file, twin)} (run it with --baseline onnx)"
    except (
        ModuleNotFoundError
    ) as error:  # onnxscript and onnx come with rsl-rl; a trimmed install may lack them
        twin.unlink(missing_ok=True)  # a twin of an earlier export would not be this policy's
        return f"none: writing it needs {error.name}: pip install onnx onnxscript"
