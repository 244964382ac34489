"""``ImitationConfig``: every setting of a ``bc`` or ``dagger`` run. Its fields marked ``option(...)`` are
options of ``python -m cabinbench.train`` (``baselines.ppo_gail.options``); those that ppo_gail's
``TrainConfig`` also has share its flag."""

from __future__ import annotations

import dataclasses
import os
from dataclasses import dataclass, field

from cabinbench.baselines.ppo_gail.options import option
from cabinbench.baselines.ppo_gail.training.config import (
    CELL_LAYOUTS,
    VALIDATION_SEED,
    VALIDATION_SUITE,
    suite_sample,
)

METHODS = ("bc", "dagger")
TRAINING_SEED = 2_000_000
"""Training episodes take seeds from here on: neither the leaderboard's (0-403) nor validation's
(``VALIDATION_SEED`` + i)."""


@dataclass
class ImitationConfig:
    """Every setting of a run of ``bc`` or ``dagger``. Saved as ``config.json`` in the run directory.

    Both learn ppo_gail's actor (an MLP of the same sizes, on the same observation: lidar, a 32 x 0.125 m
    coverage patch, velocity) by regression on the boustrophedon expert's actions, in ``iterations`` rounds
    of ``episodes_per_iteration`` episodes each: ``bc`` lets the expert drive every round, ``dagger`` lets
    the policy of the previous round drive, mixed with the expert (``beta_decay``), and labels the states it
    visits with the expert's action (``baselines.imitation.expert``). Both refit on everything collected so
    far after each round, so they see as many expert labels.
    """

    method: str = "bc"
    """"bc" or "dagger" (the baseline trained)."""
    layouts: list[str] = option(default_factory=list, flag="--layout", metavar="NAME", repeat=True)
    """Training layouts, taken in turn by the episodes; empty: the study's cleaning and tracking cells, or
    none with ``suite``."""
    suite: str | None = option(None, metavar="NAME")
    """Train on this suite instead of ``layouts``: every episode draws one of its layouts."""
    seed: int = option(0)
    """Seed of torch, the start poses, the suite draws and DAgger's mixture."""
    iterations: int = option(10)
    """Rounds of collecting episodes and refitting; a checkpoint after each."""
    episodes_per_iteration: int = option(8, metavar="N")
    """Episodes each round collects, from seeded random start poses."""
    max_steps: int | None = option(None)
    """Episode step limit of the training and validation episodes; None keeps each layout's own."""
    random_start: bool = option(True)
    """Start each training episode at a random pose of the start cell."""
    coverage_patch: int = option(32, metavar="N")
    """Cells across the observation's coverage patch (ppo_gail's); see ``TrainConfig``."""
    coverage_patch_cell: float = option(0.125, metavar="M")
    """Size of a coverage patch cell in metres (ppo_gail's)."""
    beta_decay: float = option(0.5, metavar="P")
    """DAgger: round i (from 0) executes the expert's action at each step with probability beta_decay ** i,
    else the policy's (round 0: the expert alone). Ross et al. (2011) take beta_i = p^(i-1) likewise."""
    epochs: int = option(20)
    """Passes over all the data collected so far at each refit (the weights go on from the last round's)."""
    batch_size: int = 256
    """Mini-batch of the regression."""
    learning_rate: float = 1.0e-3
    """Adam's learning rate."""
    hidden_dims: list[int] = field(default_factory=lambda: [64, 64])
    """The actor's MLP, as ppo_gail's."""
    activation: str = "elu"
    """Its activation (rsl-rl's name), as ppo_gail's."""
    validation_episodes: int = option(20, metavar="N")
    """Layouts of cabin-v1-val (a sample drawn by ``VALIDATION_SEED``) on each of which every checkpoint
    plays one episode from a random start."""
    export: str = option("best", choices=("last", "best"))
    """Which checkpoint ``policy.pt`` holds: the best on cabin-v1-val (``validation_score``), or the last."""
    threads: int = option(1)
    """torch threads."""
    workers: int = option(0, metavar="N")
    """Processes that play the episodes (0: every core this process may run on); the results do not depend
    on it."""

    def __post_init__(self) -> None:
        if self.method not in METHODS:
            raise ValueError(f"method must be one of {METHODS}, got {self.method!r}")
        if self.suite:
            from cabinbench.layouts.suites import get_suite

            get_suite(self.suite)  # an unknown suite: a LayoutError naming the valid ones
            if self.layouts:
                raise ValueError(f"train on layouts {self.layouts} or on suite {self.suite}, not both")
        elif not self.layouts:
            self.layouts = list(CELL_LAYOUTS)
        for name in ("iterations", "episodes_per_iteration", "epochs", "batch_size", "threads"):
            if getattr(self, name) < 1:
                raise ValueError(f"{name} must be positive, got {getattr(self, name)}")
        if not 0.0 <= self.beta_decay <= 1.0:
            raise ValueError(f"beta_decay must be in [0, 1], got {self.beta_decay}")
        if self.workers < 0:
            raise ValueError(f"workers must be 0 (every core) or more, got {self.workers}")
        if self.export not in ("last", "best"):
            raise ValueError(f'export must be "last" or "best", got {self.export!r}')
        if self.validation_episodes:
            from cabinbench.layouts.suites import get_suite

            size = len(get_suite(VALIDATION_SUITE))
            if self.validation_episodes > size:
                raise ValueError(
                    f"validation_episodes must be at most {size}, the layouts of {VALIDATION_SUITE}"
                )
        if self.export == "best" and not self.validation_episodes:
            raise ValueError('export="best" chooses on cabin-v1-val: validation_episodes must be positive')

    @property
    def cores(self) -> int:
        return self.workers or len(os.sched_getaffinity(0))

    @property
    def policy_name(self) -> str:
        """The baseline that runs the exported policy: the method."""
        return self.method

    @property
    def num_envs(self) -> int:
        """Episodes per round: what the train command reports as its envs."""
        return self.episodes_per_iteration

    @property
    def num_steps_per_env(self) -> int | str:
        """Steps per episode, as the train command reports them."""
        return self.max_steps or "layout's limit of"

    @property
    def trained_on(self) -> str:
        return self.suite or " + ".join(self.layouts)

    @property
    def env_kwargs(self) -> dict:
        """Keyword arguments of every training env."""
        return {
            "max_steps": self.max_steps,
            "random_start": self.random_start,
            "coverage_patch": self.coverage_patch,
            "coverage_patch_cell": self.coverage_patch_cell,
        }

    @property
    def validation_layouts(self) -> list[str]:
        """The cabin-v1-val layouts every checkpoint plays one episode on."""
        return suite_sample(VALIDATION_SUITE, self.validation_episodes, VALIDATION_SEED)

    def beta(self, iteration: int) -> float:
        """Probability that the expert's action is executed in round ``iteration`` (from 0)."""
        return 1.0 if self.method == "bc" else self.beta_decay**iteration

    def to_dict(self) -> dict:
        """Every field but ``workers`` (how the run was spread over cores)."""
        values = dataclasses.asdict(self)
        del values["workers"]
        return values

    @classmethod
    def from_dict(cls, values: dict) -> ImitationConfig:
        """The config of a ``config.json``; unknown fields are an error."""
        known = {f.name for f in dataclasses.fields(cls)}
        unknown = sorted(set(values) - known)
        if unknown:
            raise ValueError(f"unknown ImitationConfig field(s) {unknown}; known: {sorted(known)}")
        return cls(**values)
