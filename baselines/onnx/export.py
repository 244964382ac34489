"""A torch policy file's ONNX twin (needs torch and onnx: ``pip install "cabinbench[train,onnx]"``).

    export_onnx("runs/train/ppo_gail__seed0/policy.pt", "policy.onnx")

The actor of a ``cabinbench-policy/1`` file, as its torch baseline computes it (``networks.Inference``:
observation normaliser, a recurrent actor's RNN, MLP, in the file's precision), is exported with
``torch.onnx.export`` as ``observation [batch, D] -> action_mean [batch, A] float32``, the observation float64
in a float64 file (the mean computed in float64 and rounded to float32, as torch does, so that the twin's
actions are the torch policy's to the bit), float32 in an older one. The file's observation settings, action
std (and whether its baseline samples with it by default), ablation, env config and training summary go
into the model's ``metadata_props`` (see :mod:`.policy`), so that the ``onnx`` baseline runs it as the torch
policy runs, without torch.

A recurrent actor's (``ppo_lstm``) takes its memory's state as further inputs and gives the next state as
further outputs, which the ``onnx`` baseline carries from step to step, from zero at each episode:
``observation, hidden (, cell) -> action_mean, hidden_out (, cell_out)``, the state [layers, batch, H]
(torch's exporter fixes a float32 LSTM's batch at one robot).

``train`` writes every run's twin beside its policy file (:func:`export_twin`).
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
# networks.ACTIVATIONS that onnxruntime's CPU provider runs in float64 (ELU as ``networks.Float64Elu``); it
# has no float64 kernel for the others (selu, lrelu, softplus, gelu, mish), or runs
# them in float32 (crelu)
FLOAT64_ACTIVATIONS = ("elu", "relu", "tanh", "sigmoid", "swish", "identity")


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
    dynamic. A float64 file whose activation onnxruntime cannot run in float64 (``FLOAT64_ACTIVATIONS``) is
    refused (``PolicyFileError``)."""
    import onnx
    import torch
    from cabinbench.baselines.ppo_gail.policy import PolicyFileError, read_policy_file

    policy = read_policy_file(policy_file)
    activation = policy["actor"]["activation"]
    if policy["inference"] == "float64" and activation not in FLOAT64_ACTIVATIONS:
        raise PolicyFileError(
            f"{policy_file}: onnxruntime cannot run activation {activation!r} in float64, which the "
            f"policy acts in (inference 'float64'): no ONNX twin. Train with "
            f"{', '.join(FLOAT64_ACTIVATIONS)} for one."
        )
    network = policy["inference_model"]
    states = network.state_names
    batch = torch.export.Dim("batch")
    inputs, outputs = [INPUT, *states], [OUTPUT, *(f"{name}_out" for name in states)]
    examples = (torch.zeros(1, network.observation_size, dtype=network.dtype), *network.initial_state())
    batch_axes = ({0: batch}, *({1: batch} for _ in states))
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
    from cabinbench.baselines.ppo_gail.policy import PolicyFileError

    twin = Path(policy_file).with_suffix(".onnx")
    try:
        return f"{export_onnx(policy_file, twin)} (run it with --baseline onnx)"
    except (
        ModuleNotFoundError
    ) as error:  # onnx and onnxscript come with rsl-rl; a trimmed install may lack them
        reason = f"writing it needs {error.name}: pip install onnx onnxscript"
    except PolicyFileError as error:  # an activation onnxruntime cannot run in float64
        reason = str(error)
    twin.unlink(missing_ok=True)  # a twin of an earlier export would not be this policy's
    return f"none: {reason}"
