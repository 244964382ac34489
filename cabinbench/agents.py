"""The one interface every baseline implements, and how the core finds baselines by name.

A baseline drives one robot through the env's actions, never by moving it directly:

    baseline.reset(context, observation, info)   # start of an episode
    action = baseline.act(observation, info)     # every step, float32 in [-1, 1]^2

Controllers (``random_bounce``, learned policies) act from the observation. Planners
(``boustrophedon``) plan from ``context.layout`` in ``reset`` and then follow their plan using
``info["pose"]``. In a team each robot gets its own instance with ``context.agent`` set, so a
planner can split the work deterministically (every instance computes the same split).

Baselines are found through the entry-point group ``cabinbench.baselines``; the built-in ones are
declared in cabinbench's own ``pyproject.toml``. A third-party package adds one with

    [project.entry-points."cabinbench.baselines"]
    spinner = "theirpkg:Spinner"

after which ``python -m cabinbench.run --baseline spinner`` runs it. ``--baseline
package.module:ClassName`` loads a class that is not registered. The class is constructed with
``**config`` (``--config``) and needs only ``reset`` and ``act``; a baseline that learns names its
trainer in ``trainer`` (run by ``python -m cabinbench.train``).
"""

from __future__ import annotations

import functools
import importlib
from dataclasses import dataclass, field
from importlib.metadata import entry_points
from typing import ClassVar

import numpy as np

from cabinbench.errors import BaselineError
from cabinbench.layouts.model import Layout

ENTRY_POINT_GROUP = "cabinbench.baselines"


@dataclass(frozen=True)
class EpisodeContext:
    """What a baseline may know before an episode: the layout, the protocol, its seat in the team and
    where the team's robots stand (``team_start``: (K, 3) poses x, y, heading in seat order; None
    where the caller did not say)."""

    layout: Layout
    protocol: str
    seed: int
    agent: int = 0
    n_agents: int = 1
    env_config: dict = field(default_factory=dict)  # lidar and reward settings the env was made with
    observation_layout: dict = field(default_factory=dict)  # part name -> slice (cabinbench.sim.observation)
    team_start: np.ndarray | None = None


class Baseline:
    """Base class; subclasses set ``name`` and override ``reset`` and ``act``.

    A subclass's ``act`` returns float32, the dtype of the env's action space (a client such as Minari
    records it and checks it with ``action_space.contains``), whatever its body computes in. The
    benchmark steps the env with the action before that cast (:func:`exact_action`): every record was
    played so, and float32 rounding would change them (it moves a planner's robot by 1e-8 m within a
    few steps, a team's by a millimetre, and a stochastic policy's whole episode). A baseline that acts
    through another's ``act`` calls ``exact_action(other, ...)`` instead, to keep the exact value.
    """

    name = "baseline"
    trainer: ClassVar[str | None] = None
    """``package.module:function`` taking the ``train`` command's arguments (a list of strings) and returning
    its exit status; None for a baseline that does not learn."""
    config_files: ClassVar[tuple[str, ...]] = ()
    """The settings of its config that name files an episode reads (a plan, a policy): a submission carries
    them, and its replay reads the carried copies (:mod:`cabinbench.leaderboard.submission_files`)."""

    def __init_subclass__(cls, **kwargs):
        super().__init_subclass__(**kwargs)
        if "act" in vars(cls):
            cls.act = _float32_act(vars(cls)["act"])

    def __init__(self, **config):
        self.config = config

    @property
    def env_options(self) -> dict:
        """Env keyword arguments this baseline needs (a learned policy: the observation settings it was
        trained with). The runner makes the env with them, under any the caller set explicitly."""
        return {}

    def reset(self, context: EpisodeContext, observation: np.ndarray, info: dict) -> None:
        self.context = context

    def act(self, observation: np.ndarray, info: dict) -> np.ndarray:
        raise NotImplementedError


def _float32_act(act):
    """``act`` with its action cast to float32; ``act`` itself stays reachable as ``exact``."""

    @functools.wraps(act)
    def float32_act(self, observation: np.ndarray, info: dict) -> np.ndarray:
        return np.asarray(act(self, observation, info), dtype=np.float32)

    float32_act.exact = act
    return float32_act


def exact_action(baseline, observation: np.ndarray, info: dict) -> np.ndarray:
    """``baseline``'s action for this step before ``act`` casts it to float32 (see :class:`Baseline`); what
    ``act`` returns where no cast wraps it (a class that only has ``reset`` and ``act``)."""
    act = baseline.act
    exact = getattr(act, "exact", None)
    return exact(baseline, observation, info) if exact else act(observation, info)


def registered_baselines() -> dict[str, str]:
    """Registered name → ``package.module:ClassName``, in name order."""
    return {
        point.name: point.value
        for point in sorted(entry_points(group=ENTRY_POINT_GROUP), key=lambda p: p.name)
    }


def baseline_class(spec: str) -> type[Baseline]:
    """The class of a registered baseline name or of ``package.module:ClassName``."""
    registered = registered_baselines()
    target = registered.get(spec, spec)
    choices = f"choose one of {', '.join(registered)} or give package.module:ClassName"
    if ":" not in target:
        raise BaselineError(f"unknown baseline {spec!r}; {choices}")
    module_name, class_name = target.split(":", 1)
    try:
        cls = getattr(importlib.import_module(module_name), class_name)
    except ModuleNotFoundError as error:
        if error.name in ("torch", "rsl_rl"):
            raise BaselineError(
                f'baseline {spec!r} needs {error.name}: pip install "cabinbench[train]" '
                "(after pip install torch==2.13.0 for the CPU wheel)"
            ) from None
        raise BaselineError(f"cannot load baseline {spec!r} ({error}); {choices}") from None
    except (ImportError, AttributeError) as error:
        raise BaselineError(f"cannot load baseline {spec!r} ({error}); {choices}") from None
    if not (
        isinstance(cls, type)
        and callable(getattr(cls, "act", None))
        and callable(getattr(cls, "reset", None))
    ):
        raise BaselineError(f"baseline {spec!r} ({target}) is not a class with reset() and act(); {choices}")
    return cls


def load_baseline(spec: str, **config) -> Baseline:
    """A baseline by registered name or as ``package.module:ClassName``, constructed with ``config``."""
    cls = baseline_class(spec)
    try:
        return cls(**config)
    except TypeError as error:  # settings the class does not take
        raise BaselineError(f"baseline {spec!r}: {error}") from None
