"""Loading expert demonstrations for GAIL from ``.npz`` files.

The file schema is fixed by the demonstration recorder:

- ``observations``: float32 ``[N, D]``, the policy observation of each step;
- ``actions``: float32 ``[N, A]`` in ``[-1, 1]``, the action taken in that step;
- ``episode``: int32 ``[N]``, the index of the episode each step belongs to;
- ``observation_config``: a 0-d string array holding a JSON description of the observation layout.

GAIL only needs the (observation, action) pairs; ``episode`` is validated so that a malformed recording is
caught here rather than by whoever reads it next. Further keys are left alone: the team datasets of
``datasets.py`` add each row's robot and each episode's layout. Every error names the offending file and
what is wrong with it.
"""

from __future__ import annotations

import json
import os
from collections.abc import Sequence

import numpy as np
import torch

REQUIRED_KEYS = ("observations", "actions", "episode", "observation_config")

# Recorded actions are float32 in [-1, 1]; allow float32 rounding at the bounds.
ACTION_BOUND_TOLERANCE = 1e-5


class DemonstrationError(ValueError):
    """A demonstration file is missing, malformed, or does not match the environment."""


def load_demonstrations(
    paths: str | os.PathLike | Sequence[str | os.PathLike],
    observation_dim: int,
    action_dim: int,
    expected_observation_config: dict | str | None = None,
) -> tuple[torch.Tensor, torch.Tensor]:
    """Load and concatenate the (observation, action) pairs of one or more demonstration files.

    Args:
        paths: One ``.npz`` path or a sequence of them.
        observation_dim: Size ``D`` of the environment's policy observation; every file must match it.
        action_dim: Size ``A`` of the environment's action; every file must match it.
        expected_observation_config: The environment's observation layout, as a dict or a JSON string.
            When given, each file's ``observation_config`` must describe the same layout. When omitted, all
            files must at least agree with each other, so demonstrations of different layouts are never mixed
            silently.

    Returns:
        ``(observations [N, D], actions [N, A])``, both float32 CPU tensors.

    Raises:
        DemonstrationError: With the file name and the problem (missing file or key, wrong shape, dimension
            mismatch, non-finite values, actions out of range, observation layout mismatch).
    """
    path_list = [paths] if isinstance(paths, (str, os.PathLike)) else list(paths)
    if not path_list:
        raise DemonstrationError("No demonstration files given.")

    reference_config = (
        None if expected_observation_config is None else _parse_config(expected_observation_config)
    )
    observations, actions = [], []
    for path in path_list:
        file_observations, file_actions, file_config = _load_file(path, observation_dim, action_dim)
        if reference_config is None:
            reference_config = file_config
        elif file_config != reference_config:
            raise DemonstrationError(
                f"{path}: observation_config does not match the expected observation layout.\n"
                f"  expected: {json.dumps(reference_config, sort_keys=True)}\n"
                f"  in file:  {json.dumps(file_config, sort_keys=True)}"
            )
        observations.append(file_observations)
        actions.append(file_actions)

    return torch.from_numpy(np.concatenate(observations)), torch.from_numpy(np.concatenate(actions))


def _load_file(
    path: str | os.PathLike, observation_dim: int, action_dim: int
) -> tuple[np.ndarray, np.ndarray, object]:
    """Read one file and check it against the schema and the environment's dimensions."""
    if not os.path.isfile(path):
        raise DemonstrationError(f"{path}: demonstration file not found.")
    # allow_pickle=False: a demonstration file must never be able to execute code when loaded.
    with np.load(path, allow_pickle=False) as data:
        missing = [key for key in REQUIRED_KEYS if key not in data.files]
        if missing:
            raise DemonstrationError(f"{path}: missing key(s) {missing}; the file has {sorted(data.files)}.")
        observations = data["observations"]
        actions = data["actions"]
        episode = data["episode"]
        config_array = data["observation_config"]

    if observations.ndim != 2:
        raise DemonstrationError(f"{path}: 'observations' must have shape [N, D], got {observations.shape}.")
    if actions.ndim != 2:
        raise DemonstrationError(f"{path}: 'actions' must have shape [N, A], got {actions.shape}.")
    if episode.ndim != 1:
        raise DemonstrationError(f"{path}: 'episode' must have shape [N], got {episode.shape}.")
    num_steps = observations.shape[0]
    if num_steps == 0:
        raise DemonstrationError(f"{path}: the file holds no steps.")
    if actions.shape[0] != num_steps or episode.shape[0] != num_steps:
        raise DemonstrationError(
            f"{path}: inconsistent number of steps: observations {observations.shape[0]}, "
            f"actions {actions.shape[0]}, episode {episode.shape[0]}."
        )
    if observations.shape[1] != observation_dim:
        raise DemonstrationError(
            f"{path}: observation size {observations.shape[1]} does not match the environment's "
            f"observation size {observation_dim}."
        )
    if actions.shape[1] != action_dim:
        raise DemonstrationError(
            f"{path}: action size {actions.shape[1]} does not match the environment's "
            f"action size {action_dim}."
        )
    if not np.issubdtype(episode.dtype, np.integer):
        raise DemonstrationError(f"{path}: 'episode' must hold integers, got dtype {episode.dtype}.")
    for key, array in (("observations", observations), ("actions", actions)):
        if not np.issubdtype(array.dtype, np.floating):
            raise DemonstrationError(f"{path}: '{key}' must hold floats, got dtype {array.dtype}.")
        bad_rows = np.flatnonzero(~np.isfinite(array).all(axis=1))
        if bad_rows.size:
            raise DemonstrationError(
                f"{path}: '{key}' contains NaN or infinite values in {bad_rows.size} step(s), first at step "
                f"{bad_rows[0]}."
            )
    largest_action = float(np.abs(actions).max())
    if largest_action > 1.0 + ACTION_BOUND_TOLERANCE:
        raise DemonstrationError(
            f"{path}: actions must lie in [-1, 1], found magnitude {largest_action:.4g}."
        )

    if config_array.ndim != 0 or config_array.dtype.kind not in "US":
        raise DemonstrationError(
            f"{path}: 'observation_config' must be a 0-d string array, got dtype {config_array.dtype} "
            f"with shape {config_array.shape}."
        )
    config_text = config_array.item()
    if isinstance(config_text, bytes):
        config_text = config_text.decode("utf-8")
    config = _parse_config(config_text, source=f"{path}: 'observation_config'")
    return observations.astype(np.float32), actions.astype(np.float32), config


def _parse_config(config: dict | str, source: str = "expected_observation_config") -> object:
    """Return an observation layout as a JSON value, so layouts compare regardless of key order or
    whitespace."""
    if not isinstance(config, str):
        # Round-trip through JSON so that, e.g., tuples and lists compare equal like they do once serialised.
        return json.loads(json.dumps(config))
    try:
        return json.loads(config)
    except json.JSONDecodeError as error:
        raise DemonstrationError(f"{source} is not valid JSON: {error}") from None
