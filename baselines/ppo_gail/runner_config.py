"""rsl-rl's ``train_cfg`` of a ``PPOCuriosityGail`` run (``make_train_cfg``), and the algorithm settings a
run may give it (``algorithm_settings``), checked before any work starts."""

from __future__ import annotations

import inspect
import os
from collections.abc import Sequence

from cabinbench.baselines.ppo_gail.algorithm import ABLATIONS, REWARD_SIGNALS, STUDY_PPO, PPOCuriosityGail
from cabinbench.baselines.ppo_gail.signal_values import CRITIC_CLASS_NAME, signal_names
from rsl_rl.algorithms import PPO

ALGORITHM_CLASS_NAME = "cabinbench.baselines.ppo_gail.algorithm:PPOCuriosityGail"


SET_BY_THE_TRAINER = (
    "actor",
    "critic",
    "storage",
    *REWARD_SIGNALS,
    "expert_demonstrations",
    "expected_observation_config",
    "shaping_columns",
    "shaping_update_threads",
    "num_mini_batches",
    "device",
    "multi_gpu_cfg",
)
"""``PPOCuriosityGail`` and ``PPO`` arguments that training sets itself (``TrainConfig`` and the ablation)."""


def algorithm_settings() -> list[str]:
    """The settings a run may give the algorithm (``TrainConfig.algorithm``, ``train --algorithm``): the
    arguments of ``PPOCuriosityGail`` and ``PPO`` but those of ``SET_BY_THE_TRAINER``."""
    names = {
        parameter.name
        for function in (PPOCuriosityGail.__init__, PPO.__init__)
        for parameter in inspect.signature(function).parameters.values()
        if parameter.kind is inspect.Parameter.POSITIONAL_OR_KEYWORD
        or parameter.kind is inspect.Parameter.KEYWORD_ONLY
    }
    return sorted(names - {"self", *SET_BY_THE_TRAINER})


def algorithm_defaults() -> dict:
    """What each of ``algorithm_settings()`` is in a run that does not give it: the study's PPO values
    (``STUDY_PPO``, which ``make_train_cfg`` sets) over the arguments' own defaults."""
    defaults = {
        parameter.name: parameter.default
        for function in (PPO.__init__, PPOCuriosityGail.__init__)
        for parameter in inspect.signature(function).parameters.values()
        if parameter.default is not inspect.Parameter.empty
    }
    return {name: value for name, value in {**defaults, **STUDY_PPO}.items() if name in algorithm_settings()}


def check_algorithm_settings(settings: dict) -> None:
    """Raise ``ValueError`` naming the settings that are not ``algorithm_settings()``."""
    unknown = sorted(set(settings) - set(algorithm_settings()))
    if unknown:
        raise ValueError(
            f"algorithm: unknown setting(s) {', '.join(unknown)}; known: {', '.join(algorithm_settings())}"
        )


def make_train_cfg(
    variant: str = "ppo_gail",
    *,
    expert_demonstrations: str | os.PathLike | Sequence[str | os.PathLike] = (),
    expected_observation_config: dict | str | None = None,
    num_steps_per_env: int = 64,
    num_mini_batches: int = 4,
    learning_rate: float = STUDY_PPO["learning_rate"],
    schedule: str = "fixed",
    hidden_dims: Sequence[int] = (64, 64),
    activation: str = "elu",
    init_noise_std: float = 1.0,
    obs_normalization: bool = True,
    obs_groups: dict[str, list[str]] | None = None,
    save_interval: int = 50,
    **algorithm_kwargs,
) -> dict:
    """Build the rsl-rl 5.5.1 ``train_cfg`` for ``OnPolicyRunner(env, train_cfg, log_dir, device)``.

    Args:
        variant: One of ``ABLATIONS``: "ppo", "ppo_icm", "ppo_gail_only" or "ppo_gail".
        expert_demonstrations: ``.npz`` file(s); needed by the GAIL variants.
        expected_observation_config: The environment's observation layout, checked against the demonstrations.
        num_steps_per_env: Rollout length per environment and iteration.
        num_mini_batches: Mini-batches per epoch (PPO, ICM and discriminator alike).
        learning_rate: PPO learning rate (study: 3e-4).
        schedule: "fixed" keeps ``learning_rate``; rsl-rl's "adaptive" adjusts it to a target KL.
        hidden_dims, activation: Actor and critic MLPs; small by default because training runs on a CPU.
        init_noise_std: Initial std of the Gaussian policy.
        obs_normalization: Normalise actor and critic inputs with running statistics.
        obs_groups: rsl-rl observation sets; by default actor and critic both see the "policy" group.
        save_interval: Checkpoint every this many iterations (when the runner has a log_dir).
        algorithm_kwargs: Further ``PPOCuriosityGail``/``PPO`` arguments, e.g. ``curiosity_strength=0.05``,
            ``gail_strength=0.1``, ``gamma=0.995``; they override the study defaults.

    Returns:
        A plain dict (strings, numbers, lists), so it can be logged or stored as JSON.
    """
    if variant not in ABLATIONS:
        raise ValueError(f"Unknown variant '{variant}'; choose one of {sorted(ABLATIONS)}.")
    if ABLATIONS[variant].keys() & algorithm_kwargs.keys():
        raise ValueError("Choose the reward signals with `variant`, not with use_curiosity/use_gail.")
    if isinstance(expert_demonstrations, (str, os.PathLike)):
        expert_demonstrations = [expert_demonstrations]
    algorithm = {
        "class_name": ALGORITHM_CLASS_NAME,
        **ABLATIONS[variant],
        **STUDY_PPO,
        "learning_rate": learning_rate,
        "schedule": schedule,
        "num_mini_batches": num_mini_batches,
        "expert_demonstrations": [str(path) for path in expert_demonstrations],
        "expected_observation_config": expected_observation_config,
        **algorithm_kwargs,
    }
    model = {
        "class_name": "MLPModel",
        "hidden_dims": list(hidden_dims),
        "activation": activation,
        "obs_normalization": obs_normalization,
    }
    critic = model
    if algorithm.get("value_per_signal"):  # a value per reward signal, see signal_values.py
        signals = signal_names(**ABLATIONS[variant])
        critic = {**model, "class_name": CRITIC_CLASS_NAME, "num_values": len(signals)}
    return {
        "num_steps_per_env": num_steps_per_env,
        "save_interval": save_interval,
        "obs_groups": obs_groups or {"actor": ["policy"], "critic": ["policy"]},
        "algorithm": algorithm,
        "actor": {
            **model,
            "distribution_cfg": {"class_name": "GaussianDistribution", "init_std": init_noise_std},
        },
        "critic": critic,
    }
