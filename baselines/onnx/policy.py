"""``OnnxPolicy`` (``--baseline onnx``): any ONNX policy, run with onnxruntime; no torch.

    python -m cabinbench.run --baseline onnx --config '{"file": "policy.onnx"}' --layout a320_cell

The model maps observations ``[batch, D]`` (float32, or float64 if its input says so, as the twin of
a float64 policy file's does) to mean actions ``[batch, 2]`` in [-1, 1] (linear, angular): its first
input and first output. A recurrent
model (an LSTM's, a GRU's) takes its memory's state as further inputs and gives the next state as the
further outputs, in the same order; the state starts at zero at each episode (``export`` writes a
``ppo_lstm`` policy so: ``observation, hidden, cell -> action_mean, hidden_out, cell_out``).
What the model's ``metadata_props`` hold (``cabinbench.baselines.onnx.export`` writes them from
a torch policy file) is used as the torch policy uses it:

    format              "cabinbench-onnx-policy/1"
    observation_config  JSON: the observation settings it was trained with (``n_rays``, ...,
                        ``size``); ``run`` makes the env with them (``env_options``) and every
                        episode checks that the env's observation has them
    action_std          JSON list: the Gaussian policy's std; with ``stochastic`` the action is
                        mean + std * noise from a generator seeded by the episode seed and the
                        robot's index, then clipped, as ``ppo_gail``'s torch policies act
    stochastic          JSON true or false: whether its torch baseline samples by default (``bc``
                        and ``dagger`` take the mean action); the default of ``stochastic`` here
    ablation, source, env_config, training   where it came from (informational)

A model from elsewhere without them runs in the env it is given, on observations as wide as its
input, taking its output as the action (clipped).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from cabinbench.agents import Baseline, EpisodeContext
from cabinbench.errors import BaselineError

FORMAT = "cabinbench-onnx-policy/1"
INPUT_TYPES = {"tensor(float)": np.float32, "tensor(double)": np.float64}


class OnnxModel:
    """An ONNX policy file loaded for inference: ``session`` (onnxruntime), ``metadata`` (the
    ``metadata_props``, JSON values decoded), ``input_name``, ``input_width`` (D, or None when the
    model leaves it open) and ``dtype`` of the input."""

    def __init__(self, path: Path):
        try:
            import onnxruntime
        except ModuleNotFoundError:
            raise BaselineError('baseline onnx needs onnxruntime: pip install "cabinbench[onnx]"') from None
        if not path.is_file():
            raise BaselineError(
                f'{path}: ONNX policy file not found; give --config \'{{"file": "policy.onnx"}}\''
            )
        options = onnxruntime.SessionOptions()
        # One observation at a time: more threads only add overhead (and contention on a busy machine).
        options.intra_op_num_threads = options.inter_op_num_threads = 1
        try:
            self.session = onnxruntime.InferenceSession(
                str(path), options, providers=["CPUExecutionProvider"]
            )
        except Exception as error:  # onnxruntime raises its own types for foreign or broken files
            reason = next(iter(str(error).splitlines()), "")
            raise BaselineError(
                f"{path}: not a readable ONNX model ({reason}); export one with torch.onnx.export"
            ) from None
        model_input = self.session.get_inputs()[0]
        if len(model_input.shape) != 2 or model_input.type not in INPUT_TYPES:
            raise BaselineError(
                f"{path}: input {model_input.name!r} is {model_input.type} {model_input.shape}; a policy "
                "takes float observations [batch, D]"
            )
        self.input_name, self.dtype = model_input.name, INPUT_TYPES[model_input.type]
        self.state_inputs = self.session.get_inputs()[1:]  # a recurrent model's memory, fed back each step
        state_outputs = len(self.session.get_outputs()) - 1
        if state_outputs < len(self.state_inputs) or any(
            i.type not in INPUT_TYPES for i in self.state_inputs
        ):
            raise BaselineError(
                f"{path}: {len(self.state_inputs)} input(s) after the observation, {state_outputs} output(s) "
                "after the action; a recurrent policy takes float state inputs and gives the next state as "
                "outputs, one for each, in their order"
            )
        width = model_input.shape[1]
        self.input_width = width if isinstance(width, int) else None
        self.metadata = {}
        for key, value in self.session.get_modelmeta().custom_metadata_map.items():
            try:
                self.metadata[key] = (
                    json.loads(value) if key not in ("format", "ablation", "source") else value
                )
            except json.JSONDecodeError:
                raise BaselineError(
                    f"{path}: metadata {key!r} is not JSON; export the policy again"
                ) from None
        if "format" in self.metadata and self.metadata["format"] != FORMAT:
            raise BaselineError(f"{path}: metadata format {self.metadata['format']!r} is not {FORMAT!r}")

    def initial_state(self) -> list[np.ndarray]:
        """The zero state of an episode's start, for one robot (none for a memoryless model)."""
        return [
            np.zeros([size if isinstance(size, int) else 1 for size in given.shape], INPUT_TYPES[given.type])
            for given in self.state_inputs
        ]

    def step(self, observation: np.ndarray, state: list[np.ndarray]) -> tuple[np.ndarray, list[np.ndarray]]:
        """The model's output for one observation and the state before it, as float64 (A,), and the state
        after it."""
        batch = np.asarray(observation, dtype=self.dtype).reshape(1, -1)
        feed = {
            self.input_name: batch,
            **{given.name: value for given, value in zip(self.state_inputs, state)},
        }
        outputs = self.session.run(None, feed)
        return np.asarray(outputs[0], dtype=np.float64).reshape(-1), outputs[1 : 1 + len(state)]


def mismatched_settings(trained: dict, env: dict) -> list[str]:
    """The observation settings in which ``env`` differs from ``trained``, as ``key: trained ..., env
    ...`` (numbers compared to 1e-9 relative)."""

    def same(a, b) -> bool:
        if isinstance(a, float) or isinstance(b, float):
            return a is not None and b is not None and math.isclose(float(a), float(b), rel_tol=1e-9)
        return a == b

    keys = sorted(set(trained) | set(env))
    return [
        f"{key}: trained {trained.get(key)!r}, env {env.get(key)!r}"
        for key in keys
        if not same(trained.get(key), env.get(key))
    ]


class OnnxPolicy(Baseline):
    """Config: ``file`` (an ONNX policy) and ``stochastic`` (sample around the mean with the file's
    ``action_std``; default: as its metadata's ``stochastic`` says, else when the file holds an
    ``action_std``; false: the mean action)."""

    name = "onnx"
    config_files = ("file",)

    def __init__(self, file: str, stochastic: bool | None = None):
        if not isinstance(stochastic, (bool, type(None))):  # bool("no") is True
            raise BaselineError(f"--config stochastic: must be true or false, got {stochastic!r}")
        super().__init__(file=str(file), **({} if stochastic is None else {"stochastic": stochastic}))
        self.path = Path(file)
        self.model = OnnxModel(self.path)  # a few milliseconds: no cache needed
        has_std = "action_std" in self.model.metadata
        if stochastic and not has_std:
            raise BaselineError(
                f"{self.path}: no action_std in its metadata to sample with; use stochastic false"
            )
        default = self.model.metadata.get("stochastic", has_std)
        self.stochastic = default if stochastic is None else stochastic
        self.rng: np.random.Generator | None = None
        self.state: list[np.ndarray] = []

    @property
    def env_options(self) -> dict:
        """The observation settings in the file's metadata (none for a model from elsewhere)."""
        return {
            key: value
            for key, value in self.model.metadata.get("observation_config", {}).items()
            if key != "size"
        }

    def reset(self, context: EpisodeContext, observation: np.ndarray, info: dict) -> None:
        from cabinbench.envs.coverage_env import observation_config

        super().reset(context, observation, info)
        size = np.asarray(observation).shape[-1]
        trained = self.model.metadata.get("observation_config")
        different = (
            mismatched_settings(trained, observation_config(context.env_config, size))
            if trained is not None
            else [f"size: model input {self.model.input_width}, env {size}"]
            if self.model.input_width not in (None, size)
            else []
        )
        if different:
            raise BaselineError(
                f"{self.path}: the policy was trained on another observation ({', '.join(different)}); "
                "run the env with the observation settings it was trained with (its env_options), or export "
                "it again"
            )
        self.state = self.model.initial_state()
        if self.stochastic:
            self.rng = np.random.default_rng([context.seed, context.agent])
            self.action_std = np.asarray(self.model.metadata["action_std"], dtype=np.float64)

    def act(self, observation: np.ndarray, info: dict) -> np.ndarray:
        action, self.state = self.model.step(observation, self.state)
        if action.shape != (2,):
            raise BaselineError(
                f"{self.path}: the model gives {action.size} numbers; a policy gives 2 (linear, angular)"
            )
        if self.stochastic:
            action = action + self.action_std * self.rng.standard_normal(action.shape)
        return np.clip(action, -1.0, 1.0)
