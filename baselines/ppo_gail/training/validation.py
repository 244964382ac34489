"""Validation of every checkpoint: its policy plays episodes on the training layouts (or a sample of the
suite) with seeds the leaderboard does not use, one row per checkpoint and layout in ``validation.csv``."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
from cabinbench.baselines.ppo_gail.training.checkpoints import load_checkpoint
from cabinbench.baselines.ppo_gail.training.config import (
    CHECKPOINT_DIR,
    VALIDATION_DIR,
    VALIDATION_FILE,
    VALIDATION_SEED,
    TrainConfig,
)

from cabinbench.training_records import read_metrics

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
