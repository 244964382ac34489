"""The one interface every baseline implements, and the registry of names.

A baseline drives one robot through the env's actions, never by moving it directly:

    baseline.reset(context, observation, info)   # start of an episode
    action = baseline.act(observation, info)     # every step, in [-1, 1]^2

Controllers (``random_bounce``, learned policies) act from the observation. Planners
(``boustrophedon``) plan from ``context.layout`` in ``reset`` and then follow their plan using
``info["pose"]``. In a team each robot gets its own instance with ``context.agent`` set, so a
planner can split the work deterministically (every instance computes the same split).

Users plug in their own with ``--baseline package.module:ClassName``; the class is constructed
with no arguments (or ``**config`` from ``--config``) and needs only ``reset`` and ``act``.
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass, field

import numpy as np

from cabinbench.layout import Layout

BASELINES = {
    "random_bounce": "baselines.random_bounce:RandomBounce",
    "boustrophedon": "baselines.boustrophedon:Boustrophedon",
    "ppo_gail": "baselines.ppo_gail.policy:PPOGail",
    "ppo": "baselines.ppo_gail.policy:PPO",
    "ppo_icm": "baselines.ppo_gail.policy:PPOCuriosity",
    "ppo_gail_only": "baselines.ppo_gail.policy:PPOGailOnly",
}


@dataclass(frozen=True)
class EpisodeContext:
    """What a baseline may know before an episode: the layout, the protocol and its seat in the team."""

    layout: Layout
    protocol: str
    seed: int
    agent: int = 0
    n_agents: int = 1
    env_config: dict = field(default_factory=dict)  # lidar and reward settings the env was made with


class Baseline:
    """Base class; subclasses set ``name`` and override ``reset`` and ``act``."""

    name = "baseline"

    def __init__(self, **config):
        self.config = config

    @property
    def env_options(self) -> dict:
        """Env keyword arguments this baseline needs (a learned policy: the observation settings it was trained
        with). The runner makes the env with them, under any the caller set explicitly."""
        return {}

    def reset(self, context: EpisodeContext, observation: np.ndarray, info: dict) -> None:
        self.context = context

    def act(self, observation: np.ndarray, info: dict) -> np.ndarray:
        raise NotImplementedError


def load_baseline(spec: str, **config) -> Baseline:
    """A baseline by registered name or as ``package.module:ClassName``."""
    target = BASELINES.get(spec, spec)
    if ":" not in target:
        raise ValueError(f"unknown baseline {spec!r}; choose one of {', '.join(BASELINES)} or give package.module:ClassName")
    module_name, class_name = target.split(":", 1)
    try:
        cls = getattr(importlib.import_module(module_name), class_name)
    except (ImportError, AttributeError) as error:
        raise ValueError(f"cannot load baseline {spec!r} ({error}); choose one of {', '.join(BASELINES)} or give package.module:ClassName") from None
    return cls(**config)
