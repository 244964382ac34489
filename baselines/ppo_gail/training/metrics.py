"""What a run records of each iteration: ``TrainingLog`` takes the calls rsl-rl's ``OnPolicyRunner`` makes on
its logger and turns them into one row of ``metrics.csv`` (``MetricsFile``); ``training_summary`` is what the
exported policy records of them, and the progress bar shows them while training.

The runner is built with ``log_dir=None`` and its logger is replaced by ``TrainingLog``: rsl-rl's own logger
would write TensorBoard files and a full checkpoint at the end of every ``learn`` call (non-atomically).
"""

from __future__ import annotations

import csv
import os
import sys
from pathlib import Path

import numpy as np
import torch
from cabinbench.baselines.ppo_gail.training.config import TrainConfig

from cabinbench.training_records import read_metrics

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


def progress_bar(config: TrainConfig, start: int, enabled: bool):
    """The bar of the run's iterations on stderr, from ``start`` (a resumed run's); off unless ``enabled``."""
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


def postfix(row: dict) -> dict:
    """What the bar shows of an iteration's row: its episodes' reward, coverage and success."""
    shown = {}
    for name, label in (("episode_reward", "reward"), ("coverage", "cov"), ("success", "succ")):
        if row[name] is not None:
            shown[label] = f"{row[name]:.3g}"
    return shown
