"""``TrainConfig``: every setting of a training run, with its default and why; the run folder's names.

Its fields marked ``option(...)`` are the train command's options (``baselines.ppo_gail.options``): the
first sentence of each field's docstring is the option's help.
"""

from __future__ import annotations

import dataclasses
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from cabinbench.baselines.ppo_gail.algorithm import ABLATIONS, REWARD_SIGNALS
from cabinbench.baselines.ppo_gail.options import option
from cabinbench.baselines.ppo_gail.runner_config import check_algorithm_settings

from cabinbench.sim.rewards import REWARD_PRESETS

VALIDATION_SUITE = "cabin-v1-val"
"""The only layouts a checkpoint is chosen on (never test, ood or the classic layouts)."""


@dataclass
class TrainConfig:
    """Every setting of a training run. Saved as ``config.json`` in the run directory.

    The defaults are the shipped policies' configuration, sized to train in about 20 minutes on a 2-core CPU
    (the study trained for 6 M + 2 M steps on a GPU in Unity). The ablations share it, and so the budget. How
    the defaults score over three seeds per ablation: ``results/ablation.md``; the trials behind them:
    ``docs/experiments.md``.
    """

    ablation: str = "ppo_gail"
    """One of ``ABLATIONS``: "ppo_gail", "ppo", "ppo_icm", "ppo_gail_only"."""
    layouts: list[str] = option(default_factory=list, flag="--layout", metavar="NAME", repeat=True)
    """Training layouts, shared round-robin by the parallel envs; empty: the study's cleaning and tracking
    cells (``CELL_LAYOUTS``), or none with ``suite``."""
    suite: str | None = option(None, metavar="NAME")
    """Train on this suite (``cabinbench.suites``) instead of ``layouts``, so that the policy learns the
    family rather than one map. Every parallel env is a ``CabinBench/Suite-v0`` env that draws a new layout of
    the suite at each reset from its seeded generator. The config records the suite's version too."""
    num_envs: int = option(64)
    """Parallel envs, whose rollouts together make an iteration's batch."""
    num_steps_per_env: int = option(64, flag="--steps-per-env")
    """Rollout length per env and iteration (ML-Agents' ``time_horizon``); an iteration collects ``num_envs *
    num_steps_per_env`` steps (ML-Agents' ``buffer_size``)."""
    num_mini_batches: int = 4
    """Mini-batches per epoch of the update (PPO, ICM and discriminator alike): 4096 / 4 = 1024 samples each.
    Few large mini-batches: on a CPU the update dominates the iteration time."""
    iterations: int = option(800)
    """Training iterations: 3.3 M steps with the defaults."""
    seed: int = option(0)
    """Seed of torch, numpy, the envs and the demonstrations."""
    disjoint_env_seeds: bool = True
    """Seed env i (and demonstration episode i) with ``seed * num_envs + i`` (``first_env_seed``), so that
    runs of different seeds share no env's generator. False: ``seed + i``, as the runs before this field
    (a ``config.json`` without it): there neighbouring seeds shared all but one env's generator, and on a
    suite nearly every layout drawn (``suite_draws``)."""
    reward: str = option("coverage", choices=REWARD_PRESETS)
    """Reward preset of the envs: the dense "coverage" (what the benchmark scores) rather than the study's
    "paper", whose episode ends at the last goal marker. Its penalties were tried: docs/experiments.md."""
    terminate_on_bound: bool = option(False)
    """End the episode on a bound contact; by default it goes on, as ending it would be an exit from the
    mostly negative GAIL reward (docs/experiments.md). The contact still costs the preset's bound penalty."""
    terminate_on_exit: bool = False
    """Keep the episode going after an exit landmark: the policy goes on to clean the next cell, as it must in
    ``full_cabin`` (the study's separate tracking training ends there instead)."""
    random_start: bool = option(True)
    """Start each training episode at a random pose of the start cell, as the policy enters each new cell of
    ``full_cabin`` (docs/experiments.md). The demonstrations keep the layout's start, where the plan
    begins."""
    coverage_patch: int = option(32, metavar="N")
    """Cells across the observation's coverage patch of the floor still to clean (0: none, the study's
    lidar-only observation, with which no policy tells a cleaned aisle from a dirty one; docs/experiments.md).
    The ICM and the discriminator do not see it (``shaping_columns``)."""
    coverage_patch_cell: float = option(0.125, metavar="M")
    """Size of a patch cell in metres: 32 x 0.125 m is a 4 m window, fine enough to show the strips of floor
    left along walls (docs/experiments.md)."""
    max_steps: int | None = option(None)
    """Episode step limit; None keeps each layout's own (1500 for both training cells)."""
    hidden_dims: list[int] = field(default_factory=lambda: [64, 64])
    """Actor and critic MLPs. Small: on a CPU the update dominates the iteration time."""
    activation: str = "elu"
    """Activation of the actor and critic MLPs (rsl-rl's name)."""
    obs_normalization: bool = True
    """Normalise the actor's and critic's inputs with running statistics: the lidar's one-hot tags are rare
    and the velocities small, and normalised they weigh like the distances."""
    init_noise_std: float = 1.0
    """Initial std of the Gaussian policy."""
    learning_rate_schedule: str = "fixed"
    """"fixed" keeps PPO's learning rate, clip range and entropy coefficient; "linear" decays them over
    ``iterations`` towards ``LINEAR_DECAY_FINAL``, as ML-Agents' default ``learning_rate_schedule`` does (the
    study's Table 5.2 gives the *initial* learning rate). The schedule is a function of the iteration and
    ``iterations``: a run resumed with other ``iterations`` follows the new total's."""
    min_action_std: float = option(0.25)
    """Lower clamp of the policy's std (rsl-rl's ``std_range``; 0 leaves it free): keeps the policy exploring
    while the discriminator pushes the std down (docs/experiments.md)."""
    algorithm: dict = option(
        default_factory=lambda: {"entropy_coef": 0.03, "gail_strength": 0.02},
        metavar="JSON",
    )
    """``PPOCuriosityGail`` settings as JSON in place of these defaults (give them too to keep them), such as
    {"entropy_coef": 0.03, "gail_strength": 0.1}; the others keep the study's Table 5.2/5.3 values. The
    entropy bonus is raised from 0.01 (the std collapsed) and the GAIL strength lowered from 0.3 (the policy
    imitated, ignoring the patch): docs/experiments.md. ``train`` says which defaults a run leaves out."""
    demo_episodes: int = option(4, metavar="N")
    """Expert (boustrophedon) episodes recorded per training layout for GAIL; planner and env are
    deterministic, so without ``demo_action_noise`` these are one trajectory repeated."""
    demo_action_noise: float = option(0.0, metavar="STD")
    """Std of the Gaussian noise added to the planner's executed actions while its own are recorded; 0:
    noisy demonstrations made the policies worse (docs/experiments.md)."""
    demo_random_start: bool = option(False)
    """Start each demonstration episode at a random pose of the start cell (drawn by the episode's seed)
    instead of the layout's start, where the plan begins."""
    demo_max_steps: int | None = None
    """Step limit of the demonstration episodes (None: the training ``max_steps``)."""
    demo_layouts: int = option(8, metavar="N")
    """With ``suite``: how many of its layouts (a sample drawn by ``seed``) the expert demonstrates, each
    ``demo_episodes`` times from the layout's start."""
    demonstrations: list[str] = option(default_factory=list, metavar="FILE")
    """Existing demonstration ``.npz`` files to use instead of recording new ones."""
    save_interval: int = option(50)
    """Write a checkpoint every this many iterations (and after the last one)."""
    validation_episodes: int = option(10, metavar="N")
    """Layouts of cabin-v1-val on each of which a validated checkpoint plays one episode (0: none). The
    layouts are a sample of ``validation_suite`` drawn by ``VALIDATION_SEED``, episode i from a random start
    drawn by seed ``VALIDATION_SEED + i``, as the imitation baselines validate; ``validation.csv`` holds a
    row per checkpoint and layout with the headline ``clean_score``, coverage and success (panel (g) of
    ``curves.png``). Cost (docs/experiments.md, "What validation costs"): the shipped ppo_gail's 20
    cabin-v1-val episodes (150 k steps, each to its layout's step limit unless the floor is cleaned) took
    42-73 CPU-s on this 2-core machine, against 2.5 CPU-s a training iteration under the same load: 0.8-1.45
    iterations per episode. 10 layouts every ``validation_interval`` = 200 iterations of the default 800 are
    4 rounds, 40 episodes, 34-58 iterations: 4-7 % of the training. With a
    ``validation_suite`` of None (runs before it existed): episodes per training layout, from its own start,
    or with ``suite`` one on each layout of a sample of the training suite from a random start."""
    validation_suite: str | None = VALIDATION_SUITE
    """Where checkpoints are validated: ``VALIDATION_SUITE``, the only layouts a choice made while training
    (a checkpoint, a setting, a seed) may read; never cabin-v1-test, cabin-v1-ood or the classic layouts.
    None: the training layouts (or a sample of the training suite) with the validation seeds, scored on
    success + coverage, the protocol of the runs before it; a ``config.json`` without this field is one of
    those (``from_dict`` reads it as None), so that committed records say where they were validated. A run
    whose episodes end at the exit (``terminate_on_exit``: the study's tracking stage) is not validated on
    cabin-v1-val: its layouts are single cells with no exit to track to, and their clean_score measures
    cleaning, not the stage's task (``validation_episodes`` 0, as ``study_config`` sets for that stage)."""
    validation_interval: int = option(200, metavar="N")
    """Validate the checkpoint of every this many iterations, and the last; a checkpoint is written there
    too. Runs before ``validation_suite`` validated every checkpoint (``from_dict``: ``save_interval``)."""
    export: str = option("last", choices=("last", "best"))
    """Which checkpoint ``policy.pt`` holds: "last", or "best": the validated checkpoint with the best mean
    ``clean_score`` on cabin-v1-val (``training_records.validation_score``; success + coverage for a
    ``validation_suite`` of None). The training scripts (``scripts/train_*.sh``) pass "best"; the policies
    trained before cabin-v1-val existed kept "last" (docs/experiments.md)."""
    threads: int = option(1)
    """torch threads: 1, as on a shared 2-core machine 2 threads spin waiting for each other
    (docs/experiments.md); ``workers`` uses the other cores instead."""
    workers: int = option(0, metavar="N")
    """Cores the training uses (0: every core this process may run on): the single-robot envs step in that
    many processes, and the ICM and the discriminator train in up to that many less one threads beside PPO
    (with 2 the ICM beside PPO, the discriminator after it). The results do not depend on it."""

    def __post_init__(self) -> None:
        if self.ablation not in ABLATIONS:
            raise ValueError(f"unknown ablation {self.ablation!r}; choose one of {', '.join(ABLATIONS)}")
        if self.suite:
            from cabinbench.layouts.suites import get_suite

            size = len(get_suite(self.suite))  # an unknown suite: a LayoutError naming the valid ones
            if self.layouts:
                raise ValueError(f"train on layouts {self.layouts} or on suite {self.suite}, not both")
            if not 1 <= self.demo_layouts <= size:
                raise ValueError(
                    f"demo_layouts must be 1 to {size} for suite {self.suite}, got {self.demo_layouts}"
                )
        elif not self.layouts:
            self.layouts = list(CELL_LAYOUTS)
        for name in (
            "num_envs",
            "num_steps_per_env",
            "num_mini_batches",
            "iterations",
            "save_interval",
            "threads",
        ):
            if getattr(self, name) < 1:
                raise ValueError(f"{name} must be positive, got {getattr(self, name)}")
        self.check_validation()
        if self.workers < 0:
            raise ValueError(f"workers must be 0 (every core) or more, got {self.workers}")
        if self.learning_rate_schedule not in LEARNING_RATE_SCHEDULES:
            raise ValueError(
                f"learning_rate_schedule must be one of {LEARNING_RATE_SCHEDULES}, got "
                f"{self.learning_rate_schedule!r}"
            )
        if self.export not in ("last", "best"):
            raise ValueError(f'export must be "last" or "best", got {self.export!r}')
        if self.uses_gail and not self.demonstrations and self.demo_episodes < 1:
            raise ValueError(f"{self.ablation} learns from demonstrations: demo_episodes must be positive")
        check_algorithm_settings(self.algorithm)  # before any work: a typo would fail after the envs started

    def check_validation(self) -> None:
        """The validation fields agree with each other and with the training (``__post_init__``)."""
        from cabinbench.layouts.suites import get_suite

        if self.validation_suite not in (VALIDATION_SUITE, None):
            raise ValueError(
                f"validation_suite must be {VALIDATION_SUITE!r} (or None), got {self.validation_suite!r}"
            )
        if self.validation_episodes < 0 or self.validation_interval < 1:
            raise ValueError(
                f"validation_episodes must be 0 or more and validation_interval positive, got "
                f"{self.validation_episodes} and {self.validation_interval}"
            )
        sampled = self.validation_suite or self.suite
        if sampled and self.validation_episodes > len(get_suite(sampled)):
            raise ValueError(
                f"validation_episodes must be at most {len(get_suite(sampled))}, the layouts of {sampled}"
            )
        if self.export == "best" and not self.validation_episodes:
            raise ValueError(
                'export="best" chooses on the validation episodes: validation_episodes must be positive'
            )
        if self.terminate_on_exit and self.validation_suite and self.validation_episodes:
            raise ValueError(
                f"episodes that end at the exit (terminate_on_exit: a tracking task) are not validated on "
                f"{self.validation_suite}, whose layouts have no exit to track to: validation_episodes 0"
            )

    @property
    def cores(self) -> int:
        """The cores ``workers`` means."""
        return self.workers or len(os.sched_getaffinity(0))

    @property
    def uses_gail(self) -> bool:
        return ABLATIONS[self.ablation]["use_gail"]

    @property
    def env_kwargs(self) -> dict:
        """Keyword arguments of every training env (``CoverageEnv``)."""
        return {
            "reward": self.reward,
            "terminate_on_bound": self.terminate_on_bound,
            "terminate_on_exit": self.terminate_on_exit,
            "max_steps": self.max_steps,
            "random_start": self.random_start,
            "coverage_patch": self.coverage_patch,
            "coverage_patch_cell": self.coverage_patch_cell,
        }

    @property
    def policy_name(self) -> str:
        """The baseline that runs the exported policy (``--baseline``): the ablation."""
        return self.ablation

    @property
    def episode_options(self) -> dict:
        """Further ``run_episode`` keywords of the validation episodes (a team's ``n_agents``)."""
        return {}

    @property
    def obs_groups(self) -> dict | None:
        """rsl-rl's observation groups of the actor and the critic; None: both see the policy observation."""
        return None

    @property
    def first_env_seed(self) -> int:
        """The seed of env 0 at its first reset; env i's is this + i (``disjoint_env_seeds``)."""
        return self.seed * self.num_envs if self.disjoint_env_seeds else self.seed

    def make_env(self):
        """The training envs as an rsl-rl ``VecEnv``, their observation config and observation layout."""
        from cabinbench.envs.batched import BatchedCoverageEnv, RslRlVecEnv

        batched = BatchedCoverageEnv(
            self.layouts,
            self.num_envs,
            seed=self.first_env_seed,
            num_workers=self.cores,
            suite=self.suite,
            **self.env_kwargs,
        )
        example = batched.example_env
        return RslRlVecEnv(batched), example.observation_config, example.observation_layout

    @property
    def model_settings(self) -> dict:
        """rsl-rl model settings of the actor and the critic over ``make_train_cfg``'s MLP ones."""
        return {}

    def initialise(self, runner) -> None:
        """Set the weights a new run starts from; here rsl-rl's random ones are kept."""

    @property
    def suite_version(self) -> int | None:
        from cabinbench.layouts.suites import get_suite

        return get_suite(self.suite).version if self.suite else None

    @property
    def trained_on(self) -> str:
        """What the policy trained on, in words: ``cabin-v1-train (v1)`` or ``a320_cell +
        a320_tracking_cell``."""
        return f"{self.suite} (v{self.suite_version})" if self.suite else " + ".join(self.layouts)

    @property
    def demo_layout_names(self) -> list[str]:
        """The layouts the expert demonstrates: the training layouts, or a sample of the suite drawn by
        ``seed``."""
        return suite_sample(self.suite, self.demo_layouts, self.seed) if self.suite else list(self.layouts)

    @property
    def validation_layouts(self) -> list[str]:
        """The layouts every validated checkpoint plays on: a sample of ``validation_suite`` drawn by
        ``VALIDATION_SEED`` (one episode each); with none, a sample of the training suite likewise, or the
        training layouts (``validation_episodes`` each)."""
        sampled = self.validation_suite or self.suite
        if sampled:
            return suite_sample(sampled, self.validation_episodes, VALIDATION_SEED)
        return list(dict.fromkeys(self.layouts))

    def to_dict(self) -> dict:
        """Every field but ``workers``, the suite's version (``suite_version``, None without a suite) and the
        ablation's ``REWARD_SIGNALS`` (``use_curiosity``, ``use_gail``): the leaderboard reads those from
        ``config.json`` without importing this baseline (``cabinbench.training_records``)."""
        values = {**dataclasses.asdict(self), "suite_version": self.suite_version, **ABLATIONS[self.ablation]}
        del values["workers"]  # how the run was spread over cores, on which its results do not depend
        if not self.suite:  # a run on layouts: its config.json reads as it did before suites existed
            for name in SUITE_FIELDS:
                del values[name]
        for name in ("demo_random_start", "disjoint_env_seeds"):
            if not values[name]:  # its config.json reads as it did before the field existed
                del values[name]
        if not (self.validation_suite and self.validation_episodes):  # validated as before, or not at all
            for name in VALIDATION_FIELDS:
                del values[name]
        return values

    @classmethod
    def from_dict(cls, values: dict) -> TrainConfig:
        """The config of a ``config.json`` (the inverse of ``to_dict``); unknown fields are an error."""
        values = {
            key: value for key, value in values.items() if key not in (*REWARD_SIGNALS, "suite_version")
        }
        known = {f.name for f in dataclasses.fields(cls)}
        unknown = sorted(set(values) - known)
        if unknown:
            raise ValueError(f"unknown TrainConfig field(s) {unknown}; known: {sorted(known)}")
        values.setdefault("disjoint_env_seeds", False)  # a run from before the field
        if "validation_suite" not in values:  # validated on its training layouts, every checkpoint, or not
            values["validation_suite"] = None
            values.setdefault("validation_interval", values.get("save_interval", cls.save_interval))
        return cls(**values)


@dataclass
class RecurrentTrainConfig(TrainConfig):
    """``ppo_lstm``: memory instead of a map. PPO alone (no curiosity, no GAIL) whose actor and critic are
    rsl-rl's ``RNNModel`` (normaliser, LSTM, then the MLP), on lidar and velocity only: no coverage patch,
    so what the robot has cleaned lives only in its LSTM state. rsl-rl resets a robot's state when its
    episode ends (the batched env's dones) and trains on whole stretches of episodes, so each mini-batch is
    ``num_envs / num_mini_batches`` envs' rollouts."""

    ablation: str = "ppo"
    coverage_patch: int = option(0, metavar="N")
    """Cells across the coverage patch: 0, none (the memory ablation); see ``TrainConfig``."""
    rnn_type: str = "lstm"
    """rsl-rl's RNN: "lstm" (or "gru")."""
    rnn_hidden_dim: int = option(64, metavar="N")
    """Size of the LSTM state, which the MLP head reads."""
    rnn_num_layers: int = 1
    """Stacked LSTM layers."""

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.ablation != "ppo":
            raise ValueError(f"ppo_lstm is PPO alone, ablation 'ppo', not {self.ablation!r}")
        if self.rnn_type not in ("lstm", "gru"):
            raise ValueError(f'rnn_type must be "lstm" or "gru", got {self.rnn_type!r}')
        if self.num_envs % self.num_mini_batches:
            raise ValueError(
                f"num_envs ({self.num_envs}) must be a multiple of num_mini_batches "
                f"({self.num_mini_batches}): a recurrent mini-batch is whole envs' rollouts"
            )

    @property
    def policy_name(self) -> str:
        return "ppo_lstm"

    @property
    def model_settings(self) -> dict:
        return {
            "class_name": "RNNModel",
            "rnn_type": self.rnn_type,
            "rnn_hidden_dim": self.rnn_hidden_dim,
            "rnn_num_layers": self.rnn_num_layers,
        }


SUITE_FIELDS = ("suite", "suite_version", "demo_layouts")
"""What ``to_dict`` records of a run on a suite only."""
VALIDATION_FIELDS = ("validation_suite", "validation_interval")
"""What ``to_dict`` records of a run validated on ``validation_suite`` only: a ``config.json`` without them
predates it (or validates nothing)."""
CELL_LAYOUTS = ("a320_cell", "a320_tracking_cell")
"""The default training layouts: the study's cleaning and tracking cells."""


def suite_sample(suite: str, count: int, seed: int) -> list[str]:
    """``count`` different layouts of ``suite``, drawn by ``seed``, in suite order."""
    from cabinbench.layouts.suites import get_suite

    names = get_suite(suite).layout_names
    return [
        names[index] for index in sorted(np.random.default_rng(seed).choice(len(names), count, replace=False))
    ]


LEARNING_RATE_SCHEDULES = ("fixed", "linear")
LINEAR_DECAY_FINAL = {"learning_rate": 1.0e-10, "clip_param": 0.1, "entropy_coef": 1.0e-5}
"""Where the "linear" schedule ends, at ``iterations``: ML-Agents' ``DecayedValue`` of the learning rate,
epsilon and beta (ml-agents PR 4318)."""

RESUMABLE_CHANGES = ("iterations", "threads", "save_interval", "validation_interval", "export")
"""Fields a resumed run may change (e.g. train further, or export another checkpoint); any other difference to
the saved config is an error."""

CONFIG_FILE, METRICS_FILE, CURVES_FILE, POLICY_FILE = "config.json", "metrics.csv", "curves.png", "policy.pt"
VALIDATION_FILE, LOCK_FILE = "validation.csv", "train.lock"
CHECKPOINT_DIR, DEMO_DIR, VALIDATION_DIR = "checkpoints", "demos", "validation"

VALIDATION_SEED = 1_000_000
"""Validation episode ``i`` uses seed ``VALIDATION_SEED + i``: not a seed the leaderboard plays (0-403,
``scripts/make_results.sh``), so a policy is never judged (or, with ``export="best"``, chosen) on the episodes
it is scored on."""


def default_run_dir(config: TrainConfig, root: str | os.PathLike = "runs/train", name: str = "") -> Path:
    """``runs/train/<name>__seed<S>``; the name defaults to the policy's (the ablation)."""
    return Path(root) / f"{name or config.policy_name}__seed{config.seed}"
