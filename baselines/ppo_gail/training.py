"""Training the learned baselines: PPO + curiosity (ICM) + GAIL and its ablations, with rsl-rl.

One policy, two behaviours. The seed trained a cleaning cell (reach every goal marker of a cell) and a
tracking cell (the cell is clean, the bound to the next cell is open and a green exit landmark shows: drive
to it, then clean the next cell). Here a single policy is trained on both layouts at once
(``TrainConfig.layouts``: half the parallel envs run ``a320_cell``, half ``a320_tracking_cell``). The policy
tells the two situations apart from what its lidar sees: while goal markers show it cleans, once an
``exit`` tag shows it tracks. Chained cell after cell, that is the seed's whole-cabin process (Fig. 4.15),
which ``full_cabin`` evaluates zero-shot.

Read top to bottom:

1. ``TrainConfig``: every setting of a run, with its default and why (``study.study_config`` gives the
   study's own configuration instead: two networks trained apart, ``ppo_gail_study``; ``team_training``'s
   ``TeamTrainConfig`` a policy shared by a team, ``ppo_gail_team``, through the same functions: the
   config's ``make_env``, ``obs_groups``, ``initialise``, ``policy_name`` and ``episode_options`` are what
   differs).
2. ``train(config, run_dir)``: records expert demonstrations with the boustrophedon planner (or reuses
   given ``.npz`` files), builds ``RslRlVecEnv(BatchedCoverageEnv(...))`` and rsl-rl's ``OnPolicyRunner``
   with the ``PPOCuriosityGail`` algorithm, then runs ``runner.learn(1)`` once per iteration under a tqdm
   bar; after each iteration it appends a row to ``metrics.csv``, every ``save_interval`` iterations it
   writes a checkpoint (atomically), and at the end it draws ``curves.png``.
3. ``validate_checkpoints``: every checkpoint's policy plays ``validation_episodes`` episodes on each
   training layout, with seeds the leaderboard does not use (``validation.csv``); then the last checkpoint
   (or, with ``export="best"``, the best on validation) is exported as the small shipped policy
   ``policy.pt``.
4. Interrupted runs (Ctrl-C, a crash) keep every finished checkpoint and validation row;
   ``train(..., resume=True)`` continues from the latest checkpoint exactly as the run would have gone on:
   same weights, optimisers, normalisers, ICM and discriminator, the environments back in their episodes
   (replayed from how each began and the actions since), torch's random state and the logger's running
   episode sums; the iteration count goes on.

The run directory holds ``config.json``, ``demos/<layout>.npz``, ``checkpoints/model_<iteration>.pt`` (full
rsl-rl checkpoints: actor, critic, optimisers, ICM, discriminator), ``metrics.csv``, ``curves.png``,
``validation/policy_<iteration>.pt`` (each checkpoint's actor), ``validation.csv`` (their validation
episodes), ``policy.pt`` (the exported actor, see ``baselines.ppo_gail.policy``) and ``rsl_rl.log`` (what
rsl-rl prints while building the models).

The runner is built with ``log_dir=None`` and its logger is replaced by ``TrainingLog``: rsl-rl's own logger
would write TensorBoard files and a full checkpoint at the end of every ``learn`` call (non-atomically);
``TrainingLog`` takes the same calls from the runner and turns them into one CSV row per iteration.

The shipped policies (``baselines/ppo_gail/checkpoints``) come from ``python -m cabinbench.train --baseline
NAME --ship`` with the defaults below: 3.3 M steps, seed 0, 12-27 minutes a run on a 2-core CPU. ``--ship``
also keeps the run's ``config.json``, ``metrics.csv`` and ``validation.csv`` in ``results/training/``, from
which the leaderboard draws the training curves. Training is deterministic on a CPU (seeded, one torch
thread, envs seeded per index): ``results/train_policies.sh`` retrains all twelve policies of the results
(four ablations, seeds 0-2). Training times and the trials behind every default: ``docs/experiments.md``.
"""

from __future__ import annotations

import contextlib
import csv
import dataclasses
import json
import os
import sys
from dataclasses import dataclass, field
from pathlib import Path

os.environ.setdefault("GIT_PYTHON_REFRESH", "quiet")  # rsl-rl's logger imports GitPython

import numpy as np
import torch
from cabinbench.baselines.ppo_gail.algorithm import ABLATIONS, REWARD_SIGNALS, make_train_cfg
from cabinbench.baselines.ppo_gail.policy import atomic_torch_save

from cabinbench.training_records import best_checkpoint, plot_curves, read_metrics

# ----------------------------------------------------------------------------------------------------
# 1. Configuration
# ----------------------------------------------------------------------------------------------------


@dataclass
class TrainConfig:
    """Every setting of a training run. Saved as ``config.json`` in the run directory.

    The defaults are the shipped policies' configuration, sized to train in about 20 minutes on a 2-core CPU
    (the seed trained for 6 M + 2 M steps on a GPU in Unity). The ablations share it, and so the budget. How
    the defaults score over three seeds per ablation: ``results/ablation.md``; the trials behind them:
    ``docs/experiments.md``.
    """

    ablation: str = "ppo_gail"
    """One of ``ABLATIONS``: "ppo_gail", "ppo", "ppo_icm", "ppo_gail_only"."""
    layouts: list[str] = field(default_factory=list)
    """Training layouts, shared round-robin by the parallel envs; empty: the seed's cleaning and tracking
    cells (``CELL_LAYOUTS``), or none with ``suite``."""
    suite: str | None = None
    """Train on a suite (``cabinbench.suites``) instead of ``layouts``: every parallel env is a
    ``CabinBench/Suite-v0`` env that draws a new layout of the suite at each reset from its seeded
    generator, so the policy trains on the family, not on one map. The config records the suite's version
    too."""
    num_envs: int = 64
    """Parallel envs."""
    num_steps_per_env: int = 64
    """Rollout length per env and iteration (ML-Agents' ``time_horizon``); an iteration collects ``num_envs *
    num_steps_per_env`` steps (ML-Agents' ``buffer_size``)."""
    num_mini_batches: int = 4
    """Mini-batches per epoch of the update (PPO, ICM and discriminator alike): 4096 / 4 = 1024 samples each.
    Few large mini-batches: on a CPU the update dominates the iteration time."""
    iterations: int = 800
    """Training iterations: 3.3 M steps with the defaults."""
    seed: int = 0
    """Seed of torch, numpy, the envs and the demonstrations."""
    reward: str = "coverage"
    """Reward preset of the envs: the dense "coverage" (what the benchmark scores) rather than the seed's
    "paper", whose episode ends at the last goal marker. Its penalties were tried: docs/experiments.md."""
    terminate_on_bound: bool = False
    """Keep the episode going on a bound contact: ending it would be an exit from the mostly negative GAIL
    reward (docs/experiments.md). The contact still costs the preset's bound penalty."""
    terminate_on_exit: bool = False
    """Keep the episode going after an exit landmark: the policy goes on to clean the next cell, as it must in
    ``full_cabin`` (the study's separate tracking training ends there instead)."""
    random_start: bool = True
    """Start each training episode at a random pose of the start cell, as the policy enters each new cell of
    ``full_cabin`` (docs/experiments.md). The demonstrations keep the layout's start, where the plan
    begins."""
    coverage_patch: int = 32
    """Cells across the observation's coverage patch of the floor still to clean (0: none, the study's
    lidar-only observation, with which no policy tells a cleaned aisle from a dirty one; docs/experiments.md).
    The ICM and the discriminator do not see it (``shaping_columns``)."""
    coverage_patch_cell: float = 0.125
    """Size of a patch cell in metres: 32 x 0.125 m is a 4 m window, fine enough to show the strips of floor
    left along walls (docs/experiments.md)."""
    max_steps: int | None = None
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
    min_action_std: float = 0.25
    """Lower clamp of the policy's std (rsl-rl's ``std_range``; 0 leaves it free): keeps the policy exploring
    while the discriminator pushes the std down (docs/experiments.md)."""
    algorithm: dict = field(default_factory=lambda: {"entropy_coef": 0.03, "gail_strength": 0.02})
    """Further ``PPOCuriosityGail`` keyword arguments; the others keep the study's Table 5.2/5.3 values. The
    entropy bonus is raised from 0.01 (the std collapsed) and the GAIL strength lowered from 0.3 (the policy
    imitated and ignored the patch): docs/experiments.md."""
    demo_episodes: int = 4
    """Expert (boustrophedon) episodes recorded per training layout for GAIL; planner and env are
    deterministic, so without ``demo_action_noise`` these are one trajectory repeated."""
    demo_action_noise: float = 0.0
    """Std of the Gaussian noise added to the planner's executed actions while its own are recorded; 0:
    noisy demonstrations made the policies worse (docs/experiments.md)."""
    demo_max_steps: int | None = None
    """Step limit of the demonstration episodes (None: the training ``max_steps``)."""
    demo_layouts: int = 8
    """With ``suite``: how many of its layouts (a sample drawn by ``seed``) the expert demonstrates, each
    ``demo_episodes`` times from the layout's start."""
    demonstrations: list[str] = field(default_factory=list)
    """Existing demonstration ``.npz`` files to use instead of recording new ones."""
    save_interval: int = 50
    """Write a checkpoint every this many iterations (and after the last one)."""
    validation_episodes: int = 20
    """Episodes per training layout on which every checkpoint plays at the end of training, with seeds from
    ``VALIDATION_SEED`` (``validation.csv``, panel (g) of ``curves.png``; 0: none). With ``suite``: episodes
    in all, one on each layout of a sample of the suite drawn by ``VALIDATION_SEED``, from a random start (the
    suites' protocol)."""
    export: str = "last"
    """Which checkpoint ``policy.pt`` holds: "last", or "best" on validation (``validation_score``). The
    results keep "last"; "best" would reorder the ablations (docs/experiments.md)."""
    threads: int = 1
    """torch threads. 1: on a shared 2-core machine 2 threads spin waiting for each other
    (docs/experiments.md); ``workers`` uses the other cores instead."""
    workers: int = 0
    """Cores the training uses (0: every core this process may run on): the single-robot envs step in that
    many processes, and with 2 or more the ICM and the discriminator each train in a thread beside PPO. The
    results do not depend on it."""

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
            if self.validation_episodes > size:
                raise ValueError(f"validation_episodes must be at most {size} for suite {self.suite}")
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
        if self.validation_episodes < 0:
            raise ValueError(f"validation_episodes must be 0 or more, got {self.validation_episodes}")
        if self.workers < 0:
            raise ValueError(f"workers must be 0 (every core) or more, got {self.workers}")
        if self.learning_rate_schedule not in LEARNING_RATE_SCHEDULES:
            raise ValueError(
                f"learning_rate_schedule must be one of {LEARNING_RATE_SCHEDULES}, got "
                f"{self.learning_rate_schedule!r}"
            )
        if self.export not in ("last", "best"):
            raise ValueError(f'export must be "last" or "best", got {self.export!r}')
        if self.export == "best" and not self.validation_episodes:
            raise ValueError(
                'export="best" chooses on the validation episodes: validation_episodes must be positive'
            )
        if self.uses_gail and not self.demonstrations and self.demo_episodes < 1:
            raise ValueError(f"{self.ablation} learns from demonstrations: demo_episodes must be positive")

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

    def make_env(self):
        """The training envs as an rsl-rl ``VecEnv``, their observation config and observation layout."""
        from cabinbench.envs.batched import BatchedCoverageEnv, RslRlVecEnv

        batched = BatchedCoverageEnv(
            self.layouts,
            self.num_envs,
            seed=self.seed,
            num_workers=self.cores,
            suite=self.suite,
            **self.env_kwargs,
        )
        example = batched.example_env
        return RslRlVecEnv(batched), example.observation_config, example.observation_layout

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
        """The layouts every checkpoint is validated on: the training layouts (``validation_episodes`` each),
        or a sample of the suite drawn by ``VALIDATION_SEED`` (one episode each)."""
        if self.suite:
            return suite_sample(self.suite, self.validation_episodes, VALIDATION_SEED)
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
        return cls(**values)


SUITE_FIELDS = ("suite", "suite_version", "demo_layouts")
"""What ``to_dict`` records of a run on a suite only."""
CELL_LAYOUTS = ("a320_cell", "a320_tracking_cell")
"""The default training layouts: the seed's cleaning and tracking cells."""


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

RESUMABLE_CHANGES = ("iterations", "threads", "save_interval", "export")
"""Fields a resumed run may change (e.g. train further, or export another checkpoint); any other difference to
the saved config is an error."""

CONFIG_FILE, METRICS_FILE, CURVES_FILE, POLICY_FILE = "config.json", "metrics.csv", "curves.png", "policy.pt"
VALIDATION_FILE = "validation.csv"
CHECKPOINT_DIR, DEMO_DIR, VALIDATION_DIR = "checkpoints", "demos", "validation"


def default_run_dir(config: TrainConfig, root: str | os.PathLike = "runs/train", name: str = "") -> Path:
    """``runs/train/<name>__seed<S>``; the name defaults to the policy's (the ablation)."""
    return Path(root) / f"{name or config.policy_name}__seed{config.seed}"


# ----------------------------------------------------------------------------------------------------
# 2. Per-iteration metrics: the runner's logger interface, written to metrics.csv
# ----------------------------------------------------------------------------------------------------

EPISODE_METRICS = ("coverage", "success", "cells_cleared", "collisions", "bound_violations")
LOSSES = {
    # CSV column: key in the algorithm's loss dict
    "gail_discriminator": "gail_discriminator",
    "gail_accuracy": "gail_accuracy",
    "gail_reward": "gail_reward",
    "curiosity_forward": "curiosity_forward",
    "curiosity_inverse": "curiosity_inverse",
    "curiosity_reward": "curiosity_reward",
    "policy_loss": "surrogate",
    "value_loss": "value",
    "entropy": "entropy",
}
METRIC_COLUMNS = (
    "iteration",
    "timesteps",
    "train_time",
    "iteration_time",
    "episodes",
    "episode_reward",
    "episode_length",
    *EPISODE_METRICS,
    *LOSSES,
    "action_std",
    "learning_rate",
)
"""``metrics.csv`` columns. Episode columns average the episodes that ended during the iteration (empty when
none did); ``episode_reward`` is the environment reward (without the curiosity and GAIL bonuses, so ablations
compare); ``policy_loss`` is PPO's clipped surrogate loss; losses of modules an ablation does not use are
empty."""


class TrainingLog:
    """Takes the calls ``OnPolicyRunner`` makes on its logger and keeps one row of metrics per iteration.

    ``process_env_step`` sees every step's environment reward, dones and ``extras["log"]`` (the means of the
    episode records that ended on that step, from ``RslRlVecEnv``); ``log`` receives the losses after the
    update. ``writer`` is None, so the runner saves no checkpoints of its own.
    """

    writer = None

    def __init__(self, num_envs: int, steps_per_iteration: int) -> None:
        self.steps_per_iteration = steps_per_iteration
        self.git_status_repos: list[str] = []  # the runner's add_git_repo_to_log appends here
        self.reward_sum = torch.zeros(num_envs)
        self.length = torch.zeros(num_envs)
        self.row: dict | None = None
        self._clear()

    def _clear(self) -> None:
        self.finished_rewards: list[float] = []
        self.finished_lengths: list[float] = []
        self.metric_sums = dict.fromkeys(EPISODE_METRICS, 0.0)

    # The runner's logger interface --------------------------------------------------------------------------

    def init_logging_writer(self) -> None:
        pass

    def process_env_step(self, rewards, dones, extras, intrinsic_rewards=None) -> None:
        self.reward_sum += rewards.cpu()
        self.length += 1
        done = dones.cpu().bool()
        if done.any():
            self.finished_rewards += self.reward_sum[done].tolist()
            self.finished_lengths += self.length[done].tolist()
            self.reward_sum[done] = 0.0
            self.length[done] = 0.0
            count = int(done.sum())  # extras["log"] holds means over the episodes that ended on this step
            for name in EPISODE_METRICS:
                self.metric_sums[name] += count * float(extras["log"][f"/episode/{name}"])

    def log(self, *, it, collect_time, learn_time, loss_dict, learning_rate, action_std, **_) -> None:
        episodes = len(self.finished_rewards)
        row = {
            "iteration": it + 1,  # iterations completed
            "timesteps": (it + 1) * self.steps_per_iteration,
            "iteration_time": collect_time + learn_time,
            "episodes": episodes,
            "episode_reward": float(np.mean(self.finished_rewards)) if episodes else None,
            "episode_length": float(np.mean(self.finished_lengths)) if episodes else None,
            **{name: (total / episodes if episodes else None) for name, total in self.metric_sums.items()},
            **{column: loss_dict.get(key) for column, key in LOSSES.items()},
            "action_std": float(action_std.detach().mean()),
            "learning_rate": float(learning_rate),
        }
        self.row = row
        self._clear()

    def save_model(self, path, it) -> None:
        pass

    def stop_logging_writer(self) -> None:
        pass


class MetricsFile:
    """``metrics.csv``: one row per iteration, appended and flushed as soon as the iteration is done."""

    def __init__(self, path: Path, keep_until: int) -> None:
        """Open ``path``, keeping only rows of iterations ``<= keep_until`` (the checkpoint a run resumes
        from: later rows belong to iterations that are trained again)."""
        self.path = path
        rows = (
            [row for row in read_metrics(path) if int(row["iteration"]) <= keep_until]
            if path.exists()
            else []
        )
        temporary = path.with_suffix(".csv.tmp")
        with open(temporary, "w", newline="") as file:
            writer = csv.DictWriter(file, METRIC_COLUMNS)
            writer.writeheader()
            writer.writerows(rows)
        os.replace(temporary, path)
        self.file = open(path, "a", newline="")
        self.writer = csv.DictWriter(self.file, METRIC_COLUMNS)

    def append(self, row: dict) -> None:
        self.writer.writerow({key: ("" if value is None else value) for key, value in row.items()})
        self.file.flush()

    def close(self) -> None:
        self.file.close()


# ----------------------------------------------------------------------------------------------------
# 3. Checkpoints
# ----------------------------------------------------------------------------------------------------


def checkpoint_path(run_dir: Path, iteration: int) -> Path:
    return run_dir / CHECKPOINT_DIR / f"model_{iteration:06d}.pt"


def latest_checkpoint(run_dir: str | os.PathLike) -> Path | None:
    """The checkpoint with the most iterations in ``run_dir/checkpoints``, or None."""
    folder = Path(run_dir) / CHECKPOINT_DIR
    found = sorted(folder.glob("model_*.pt")) if folder.is_dir() else []
    return found[-1] if found else None


def save_checkpoint(runner, run_dir: Path, iteration: int, config: TrainConfig, train_time: float) -> Path:
    """The algorithm's full state (rsl-rl's checkpoint dict plus the ICM and discriminator) after
    ``iteration`` completed iterations, and the rest of the run's state a resumed run goes on from
    (``rollout``: the envs' episodes in play, torch's random state, the logger's running sums)."""
    saved = runner.alg.save()
    saved["iter"] = iteration
    saved["infos"] = {"config": config.to_dict(), "train_time": train_time}
    saved["rollout"] = {
        "episodes": [(start, torch.from_numpy(actions)) for start, actions in runner.env.episodes()],
        "torch_random_state": torch.get_rng_state(),
        "episode_reward_sums": runner.logger.reward_sum.clone(),
        "episode_lengths": runner.logger.length.clone(),
    }
    path = checkpoint_path(run_dir, iteration)
    atomic_torch_save(saved, path)
    return path


def load_checkpoint(runner, path: Path) -> dict:
    """Restore the algorithm's full state from a checkpoint of ``save_checkpoint``; returns the checkpoint."""
    state = torch.load(path, weights_only=True, map_location="cpu")
    runner.alg.load(state, load_cfg=None, strict=True)
    return state


def resume_rollout(runner, state: dict, path: Path) -> None:
    """Put the run back where the checkpoint ``state`` (read from ``path``) left it: the envs into their
    episodes, torch's random state and the logger's sums. Call it last, after everything that draws
    random numbers while the runner is built."""
    rollout = state.get("rollout")
    if rollout is None:  # written before checkpoints kept it
        print(f"{path.name} keeps no episodes: the environments start new ones", file=sys.stderr)
        return
    runner.env.restore([(start, actions.numpy()) for start, actions in rollout["episodes"]])
    runner.logger.reward_sum.copy_(rollout["episode_reward_sums"])
    runner.logger.length.copy_(rollout["episode_lengths"])
    torch.set_rng_state(rollout["torch_random_state"])


# ----------------------------------------------------------------------------------------------------
# 4. The training loop
# ----------------------------------------------------------------------------------------------------


@dataclass
class TrainResult:
    run_dir: Path
    policy_path: Path | None  # None when the run was interrupted
    iterations: int  # completed
    train_time: float  # seconds spent in training iterations, over all sessions of the run
    summary: dict  # final training metrics (see ``training_summary``)
    interrupted: bool = False


def train(
    config: TrainConfig, run_dir: str | os.PathLike | None = None, resume: bool = False, progress: bool = True
) -> TrainResult:
    """Train (or, with ``resume``, continue training) the policy of ``config`` in ``run_dir``.

    Without ``resume`` the run directory must not hold checkpoints yet. With ``resume`` the saved
    ``config.json`` must agree with ``config`` except in ``RESUMABLE_CHANGES``; training continues from the
    latest checkpoint (or starts, if there is none). Ctrl-C stops after the finished checkpoints and returns
    with ``interrupted=True``.
    """
    run_dir = Path(run_dir) if run_dir is not None else default_run_dir(config)
    checkpoint = prepare_run_dir(config, run_dir, resume)
    runner, obs_config = build_runner(config, run_dir)
    initial = {name: getattr(runner.alg, name) for name in LINEAR_DECAY_FINAL}

    iteration, train_time = 0, 0.0
    if checkpoint is not None:
        state = load_checkpoint(runner, checkpoint)
        resume_rollout(runner, state, checkpoint)
        iteration, train_time = int(state["iter"]), float(state["infos"]["train_time"])
    metrics = MetricsFile(run_dir / METRICS_FILE, keep_until=iteration)

    interrupted = False
    bar = _progress_bar(config, iteration, progress)
    try:
        while iteration < config.iterations:
            runner.current_learning_iteration = iteration  # learn() numbers its iteration from here
            if config.learning_rate_schedule == "linear":
                decay_linearly(runner.alg, initial, iteration / config.iterations)
            runner.learn(num_learning_iterations=1)
            iteration += 1
            row = runner.logger.row
            train_time += row["iteration_time"]
            metrics.append({**row, "train_time": train_time})
            bar.update()
            bar.set_postfix(_postfix(row), refresh=False)
            if iteration % config.save_interval == 0 or iteration == config.iterations:
                save_checkpoint(runner, run_dir, iteration, config, train_time)
    except KeyboardInterrupt:
        interrupted = True
    finally:
        bar.close()
        metrics.close()
        runner.env.close()  # its workers; validation plays episodes of its own

    rows = read_metrics(run_dir / METRICS_FILE)
    summary = training_summary(rows, config, train_time)

    def export(path: Path, training: dict) -> Path:
        return export_run_policy(runner, config, obs_config, path, training)

    if not interrupted and config.validation_episodes:
        try:
            validate_checkpoints(runner, config, run_dir, lambda path: export(path, summary))
        except KeyboardInterrupt:
            interrupted = True
    validation = read_validation(run_dir, config)
    if rows:
        plot_curves(
            rows,
            run_dir / CURVES_FILE,
            title=f"{config.policy_name} on {config.trained_on}",
            validation=validation,
        )
    if interrupted:
        last = latest_checkpoint(run_dir)
        print(
            f"interrupted at iteration {iteration}: checkpoints kept up to {last.name if last else 'none'}"
            f"{' (all trained; validating them)' if iteration >= config.iterations else ''}; "
            f"continue with --resume --run-dir {run_dir}",
            file=sys.stderr,
        )
        return TrainResult(run_dir, None, iteration, train_time, summary, interrupted=True)

    exported = best_checkpoint(validation)[0] if config.export == "best" else iteration
    load_checkpoint(runner, checkpoint_path(run_dir, exported))  # validation left another one loaded
    summary["exported_iteration"] = exported
    policy_path = export(run_dir / POLICY_FILE, summary)
    return TrainResult(run_dir, policy_path, iteration, train_time, summary)


def export_run_policy(runner, config: TrainConfig, obs_config: dict, path: Path, training: dict) -> Path:
    """Write the runner's current actor as the policy file ``path`` (``policy.export_policy``)."""
    from cabinbench.baselines.ppo_gail.policy import export_policy

    return export_policy(
        runner,
        path,
        ablation=config.policy_name,
        observation_config=obs_config,
        env_config={
            "layouts": config.layouts,
            "suite": config.suite,
            "suite_version": config.suite_version,
            **config.env_kwargs,
        },
        training=training,
    )


def export_latest(config: TrainConfig, run_dir: str | os.PathLike) -> TrainResult:
    """Export the latest checkpoint of ``run_dir`` as its ``policy.pt`` without training: the policy of a run
    stopped before its ``iterations`` (its training summary says how far it got; resume the run to go on)."""
    run_dir = Path(run_dir)
    checkpoint = latest_checkpoint(run_dir)
    if checkpoint is None:
        raise FileNotFoundError(f"{run_dir} holds no checkpoint to export; train first")
    runner, obs_config = build_runner(config, run_dir)
    state = load_checkpoint(runner, checkpoint)
    iteration, train_time = int(state["iter"]), float(state["infos"]["train_time"])
    rows = [row for row in read_metrics(run_dir / METRICS_FILE) if int(row["iteration"]) <= iteration]
    summary = training_summary(rows, config, train_time)
    summary["exported_iteration"] = iteration
    policy_path = export_run_policy(runner, config, obs_config, run_dir / POLICY_FILE, summary)
    return TrainResult(run_dir, policy_path, iteration, train_time, summary)


def build_runner(config: TrainConfig, run_dir: Path):
    """The run's rsl-rl ``OnPolicyRunner`` (seeded; demonstrations recorded into ``run_dir`` if missing) and
    the training envs' observation config. Its logger is a ``TrainingLog``."""
    from rsl_rl.runners import OnPolicyRunner

    torch.set_num_threads(config.threads)
    torch.manual_seed(config.seed)
    np.random.seed(config.seed)

    demonstrations = expert_demonstrations(config, run_dir) if config.uses_gail else []
    env, obs_config, obs_layout = config.make_env()
    train_cfg = make_train_cfg(
        config.ablation,
        expert_demonstrations=demonstrations,
        expected_observation_config=obs_config,
        shaping_columns=shaping_columns(obs_layout),
        obs_groups=config.obs_groups,
        num_steps_per_env=config.num_steps_per_env,
        num_mini_batches=config.num_mini_batches,
        hidden_dims=config.hidden_dims,
        activation=config.activation,
        init_noise_std=config.init_noise_std,
        obs_normalization=config.obs_normalization,
        save_interval=config.save_interval,
        shaping_update_threads=config.cores > 1,
        **config.algorithm,
    )
    if config.min_action_std > 0:
        train_cfg["actor"]["distribution_cfg"]["std_range"] = [config.min_action_std, 1.0e6]
    with open(run_dir / "rsl_rl.log", "a") as log, contextlib.redirect_stdout(log):
        runner = OnPolicyRunner(env, train_cfg, log_dir=None, device="cpu")  # prints the models
    runner.logger = TrainingLog(env.num_envs, env.num_envs * config.num_steps_per_env)
    config.initialise(runner)

    return runner, obs_config


def decay_linearly(algorithm, initial: dict, progress: float) -> None:
    """Set PPO's learning rate, clip range and entropy coefficient ``progress`` (0 to 1) of the way from
    their ``initial`` values to ``LINEAR_DECAY_FINAL`` (rsl-rl's "fixed" schedule leaves them as set)."""
    for name, final in LINEAR_DECAY_FINAL.items():
        setattr(algorithm, name, final + (initial[name] - final) * (1.0 - progress))
    for group in algorithm.optimizer.param_groups:
        group["lr"] = algorithm.learning_rate


def shaping_columns(layout: dict[str, slice]) -> list[int] | None:
    """The observation columns the ICM and the discriminator see: every part of the observation's ``layout``
    but the coverage patch, whose expert sweep would give the expert away (``PPOCuriosityGail``); None (all
    columns) when there is no patch."""
    if "coverage_patch" not in layout:
        return None
    kept = [span for part, span in layout.items() if part != "coverage_patch"]
    return [column for span in kept for column in range(span.start, span.stop)]


def prepare_run_dir(config: TrainConfig, run_dir: Path, resume: bool) -> Path | None:
    """Create the run directory and its ``config.json``; return the checkpoint to resume from (or None)."""
    saved_config_path = run_dir / CONFIG_FILE
    checkpoint = latest_checkpoint(run_dir)
    if not resume:
        if checkpoint is not None:
            raise FileExistsError(
                f"{run_dir} already holds checkpoints (latest {checkpoint.name}); "
                "resume it (--resume) or choose another --run-dir"
            )
    elif saved_config_path.exists():
        # through TrainConfig: a field added since the run started takes its default, as the resumed run does
        saved = json.loads(
            json.dumps(type(config).from_dict(json.loads(saved_config_path.read_text())).to_dict())
        )
        differences = sorted(
            key
            for key, value in config.to_dict().items()
            if key not in RESUMABLE_CHANGES and saved.get(key) != json.loads(json.dumps(value))
        )
        if differences:
            raise ValueError(
                f"cannot resume {run_dir}: the config differs from the saved one in {differences}; "
                f"only {list(RESUMABLE_CHANGES)} may change"
            )
    if resume and checkpoint is None:  # a sweep's run that never reached a checkpoint: from the start
        print(f"nothing to resume in {run_dir}: starting a new run", file=sys.stderr)
    (run_dir / CHECKPOINT_DIR).mkdir(parents=True, exist_ok=True)
    temporary = saved_config_path.with_suffix(".json.tmp")
    temporary.write_text(json.dumps(config.to_dict(), indent=2) + "\n")
    os.replace(temporary, saved_config_path)
    return checkpoint if resume else None


def expert_demonstrations(config: TrainConfig, run_dir: Path) -> list[str]:
    """The given ``.npz`` files, or boustrophedon demonstrations of every layout of ``demo_layout_names``
    recorded into ``run_dir/demos`` (kept, so a resumed run imitates the same data)."""
    from cabinbench.baselines.boustrophedon import record_demonstrations

    if config.demonstrations:
        return [str(path) for path in config.demonstrations]
    folder = run_dir / DEMO_DIR
    folder.mkdir(exist_ok=True)
    paths = []
    for layout in dict.fromkeys(config.demo_layout_names):
        path = folder / f"{Path(layout).stem}.npz"  # a suite layout's: its number
        if not path.exists():
            temporary = folder / f"{Path(layout).stem}.tmp.npz"
            env_kwargs = {
                **config.env_kwargs,
                "max_steps": config.demo_max_steps or config.max_steps,
                "random_start": False,
            }
            record_demonstrations(
                layout,
                config.demo_episodes,
                str(temporary),
                seed=config.seed,
                action_noise=config.demo_action_noise,
                **env_kwargs,
            )
            os.replace(temporary, path)
        paths.append(str(path))
    return paths


def training_summary(rows: list[dict], config: TrainConfig, train_time: float, window: int = 20) -> dict:
    """Iterations, steps and time, and the episode metrics averaged over the last ``window`` iterations
    (weighted by their episodes): what the shipped policy's file records about its training."""
    last = rows[-window:]
    summary: dict = {
        "ablation": config.ablation,
        "layouts": list(config.layouts),
        "suite": config.suite,
        "suite_version": config.suite_version,
        "iterations": int(rows[-1]["iteration"]) if rows else 0,
        "iterations_planned": config.iterations,
        "timesteps": int(rows[-1]["timesteps"]) if rows else 0,
        "train_time_s": round(train_time, 1),
        "seed": config.seed,
        "reward": config.reward,
    }
    episodes = sum(int(row["episodes"]) for row in last)
    for name in ("episode_reward", "episode_length", *EPISODE_METRICS):
        total = sum(float(row[name]) * int(row["episodes"]) for row in last if row[name] not in ("", None))
        summary[f"final_{name}"] = round(total / episodes, 4) if episodes else None
    summary["final_episodes"] = episodes
    return summary


def _progress_bar(config: TrainConfig, start: int, enabled: bool):
    from tqdm import tqdm

    return tqdm(
        total=config.iterations,
        initial=start,
        unit="it",
        desc=config.policy_name,
        file=sys.stderr,
        dynamic_ncols=True,
        disable=not enabled,
    )


def _postfix(row: dict) -> dict:
    shown = {}
    for name, label in (("episode_reward", "reward"), ("coverage", "cov"), ("success", "succ")):
        if row[name] is not None:
            shown[label] = f"{row[name]:.3g}"
    return shown


# ----------------------------------------------------------------------------------------------------
# 5. Validation of every checkpoint on the training layouts
# ----------------------------------------------------------------------------------------------------

VALIDATION_SEED = 1_000_000
"""Validation episode ``i`` uses seed ``VALIDATION_SEED + i``: not a seed the leaderboard plays (0-403,
``results/make_results.sh``), so a policy is never judged (or, with ``export="best"``, chosen) on the episodes
it is scored on."""
VALIDATION_COLUMNS = ("iteration", "layout", "episodes", "coverage", "success", "cells_cleared", "time")
"""``validation.csv``: one row per checkpoint and training layout, the means over its validation episodes."""


def read_validation(run_dir: Path, config: TrainConfig) -> list[dict]:
    """The rows of the run's ``validation.csv`` for checkpoints up to ``config.iterations`` ([] when none)."""
    path = run_dir / VALIDATION_FILE
    rows = read_metrics(path) if path.exists() else []
    return [row for row in rows if int(row["iteration"]) <= config.iterations]


def validate_checkpoints(runner, config: TrainConfig, run_dir: Path, export) -> None:
    """Play ``config.validation_episodes`` episodes on each training layout (sequential protocol, the layout's
    own start, sampled actions: as the leaderboard plays them) with the policy of every checkpoint up to
    ``config.iterations``; with a suite, one episode on each of its ``validation_layouts`` from a random start
    (as ``run --suite`` plays them), one row named after the suite. Each checkpoint's policy file is exported
    (by ``export(path)``) to ``validation/policy_<iteration>.pt``, and its rows are appended to
    ``validation.csv`` as soon as they are measured: a resumed run validates only the checkpoints not done
    yet."""
    from cabinbench.episodes import run_episode
    from cabinbench.layouts.resolve import load_layout

    path = run_dir / VALIDATION_FILE
    rows = read_metrics(path) if path.exists() else []
    done = {int(row["iteration"]) for row in rows}
    env_kwargs = {"max_steps": config.max_steps} if config.max_steps else {}
    if config.suite:  # one row: one episode on each layout of the sample, from a random start
        sample = [load_layout(name) for name in config.validation_layouts]
        episodes = {config.suite: [(layout, VALIDATION_SEED + index) for index, layout in enumerate(sample)]}
        env_kwargs["random_start"] = True
    else:  # a row per training layout, validation_episodes episodes each
        episodes = {}
        for name in config.validation_layouts:
            layout = load_layout(name)
            episodes[name] = [
                (layout, VALIDATION_SEED + index) for index in range(config.validation_episodes)
            ]
    checkpoints = sorted((run_dir / CHECKPOINT_DIR).glob("model_*.pt"))
    with open(path, "a", newline="") as file:
        writer = csv.DictWriter(file, VALIDATION_COLUMNS)
        if not rows:
            writer.writeheader()
        for checkpoint in checkpoints:
            iteration = int(checkpoint.stem.split("_")[1])
            if iteration in done or iteration > config.iterations:
                continue
            load_checkpoint(runner, checkpoint)
            policy = export(run_dir / VALIDATION_DIR / f"policy_{iteration:06d}.pt")
            measured = []
            for name, played in episodes.items():
                records = [
                    run_episode(
                        config.policy_name,
                        layout,
                        seed,
                        env_kwargs=env_kwargs,
                        config={"checkpoint": str(policy)},
                        **config.episode_options,
                    )[0]
                    for layout, seed in played
                ]
                measured.append(
                    {
                        "iteration": iteration,
                        "layout": name,
                        "episodes": len(records),
                        **{
                            metric: float(np.mean([record[metric] for record in records]))
                            for metric in VALIDATION_COLUMNS[3:]
                        },
                    }
                )
            writer.writerows(
                measured
            )  # a checkpoint's rows together: an interruption never leaves half of them
            file.flush()
