"""Validation of checkpoints: a checkpoint's policy plays episodes with seeds the leaderboard does not use,
one row per checkpoint and validation layout in ``validation.csv``. ``validation_rows`` plays them for every
trainer (this one's and ``baselines.imitation``'s), so that both validate alike."""

from __future__ import annotations

import csv
from dataclasses import dataclass, field
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
"""``validation.csv`` of the runs validated on their training layouts (before
``TrainConfig.validation_suite``), and of bc and dagger before they recorded ``clean_score``: one row per
checkpoint and layout, the means over its episodes there."""
SCORED_COLUMNS = (*VALIDATION_COLUMNS, "clean_score")
"""``validation.csv`` of the runs validated on ``validation_suite`` and of bc and dagger: the headline score
too, on which ``export="best"`` chooses (``training_records.validation_score``)."""


@dataclass(frozen=True)
class Play:
    """One validation episode: on ``layout`` with ``seed``, entering the means of ``validation.csv``'s row
    ``row``."""

    row: str
    layout: str
    seed: int


@dataclass(frozen=True)
class Player:
    """Who plays the validation episodes: the policy file ``policy`` run by ``baseline`` in envs of
    ``env_kwargs``, with further ``run_episode`` keywords ``options`` (a team's ``n_agents``)."""

    baseline: str
    policy: str
    env_kwargs: dict
    options: dict = field(default_factory=dict)


def one_episode_each(layouts: list[str], row: str | None = None) -> list[Play]:
    """One episode on each of ``layouts``, episode i with seed ``VALIDATION_SEED + i``, each its own row
    (or all in ``row``)."""
    return [Play(row or name, name, VALIDATION_SEED + index) for index, name in enumerate(layouts)]


def validation_plays(config: TrainConfig) -> list[Play]:
    """The episodes every validated checkpoint of ``config`` plays: one on each layout of
    ``validation_layouts`` (a sample of ``validation_suite``, or, validated on the training suite, a sample
    of it in one row named after it), or ``validation_episodes`` on each training layout."""
    if config.validation_suite or config.suite:
        return one_episode_each(config.validation_layouts, None if config.validation_suite else config.suite)
    return [
        Play(name, name, VALIDATION_SEED + index)
        for name in config.validation_layouts
        for index in range(config.validation_episodes)
    ]


def validation_env_kwargs(config: TrainConfig) -> dict:
    """The validation episodes' env settings: a random start where the episodes are one per layout (as
    ``run --suite`` plays a suite), else each layout's own start; the run's step limit if it sets one."""
    random_start = bool(config.validation_suite or config.suite)
    return {
        **({"random_start": True} if random_start else {}),
        **({"max_steps": config.max_steps} if config.max_steps else {}),
    }


def play_validation_episode(job: tuple[Player, Play]) -> dict:
    """The record of one validation episode, with its ``row`` and ``seed`` (run in a worker, too)."""
    import torch

    from cabinbench.episodes import run_episode

    player, play = job
    torch.set_num_threads(1)
    record = run_episode(
        player.baseline,
        play.layout,
        play.seed,
        env_kwargs=player.env_kwargs,
        config={"checkpoint": player.policy},
        **player.options,
    )[0]
    return {**record, "row": play.row, "seed": play.seed}


def validation_rows(
    iteration: int, plays: list[Play], player: Player, executor, columns: tuple[str, ...]
) -> list[dict]:
    """Checkpoint ``iteration``'s rows of ``validation.csv``: ``player`` plays ``plays`` (on ``executor``'s
    workers); per row its episodes and the means of ``columns``' metrics over them, rows in the order of the
    plays."""
    order = {(play.row, play.seed): position for position, play in enumerate(plays)}
    records = sorted(
        executor.map(play_validation_episode, [(player, play) for play in plays]),
        key=lambda record: order[record["row"], record["seed"]],
    )
    rows: dict[str, list[dict]] = {}
    for record in records:
        rows.setdefault(record["row"], []).append(record)
    return [
        {
            "iteration": iteration,
            "layout": row,
            "episodes": len(played),
            **{
                metric: float(np.mean([float(record[metric]) for record in played])) for metric in columns[3:]
            },
        }
        for row, played in rows.items()
    ]


def read_validation(run_dir: Path, config: TrainConfig) -> list[dict]:
    """The rows of the run's ``validation.csv`` for checkpoints up to ``config.iterations`` ([] when none)."""
    path = run_dir / VALIDATION_FILE
    rows = read_metrics(path) if path.exists() else []
    return [row for row in rows if int(row["iteration"]) <= config.iterations]


def validated_iterations(config: TrainConfig, checkpoints: list[int]) -> list[int]:
    """The checkpoints (their iterations) that are validated: every ``validation_interval`` iterations and
    the last, up to ``config.iterations``."""
    return [
        iteration
        for iteration in checkpoints
        if iteration <= config.iterations
        and (iteration % config.validation_interval == 0 or iteration == config.iterations)
    ]


def validate_checkpoints(runner, config: TrainConfig, run_dir: Path, export, executor) -> None:
    """Validate every checkpoint of ``validated_iterations``: its policy, exported (by ``export(path)``) to
    ``validation/policy_<iteration>.pt``, plays ``validation_plays(config)`` (sampled actions: as the
    leaderboard plays them), and its rows are appended to ``validation.csv`` as soon as they are measured: a
    resumed run validates only the checkpoints not done yet."""
    path = run_dir / VALIDATION_FILE
    rows = read_metrics(path) if path.exists() else []
    done = {int(row["iteration"]) for row in rows}
    columns = SCORED_COLUMNS if config.validation_suite else VALIDATION_COLUMNS
    checkpoints = {
        int(path.stem.split("_")[1]): path for path in (run_dir / CHECKPOINT_DIR).glob("model_*.pt")
    }
    with open(path, "a", newline="") as file:
        writer = csv.DictWriter(file, columns)
        if not rows:
            writer.writeheader()
        for iteration in validated_iterations(config, sorted(checkpoints)):
            if iteration in done:
                continue
            load_checkpoint(runner, checkpoints[iteration])
            policy = export(run_dir / VALIDATION_DIR / f"policy_{iteration:06d}.pt")
            player = Player(
                config.policy_name, str(policy), validation_env_kwargs(config), config.episode_options
            )
            # a checkpoint's rows together: an interruption never leaves half of them
            writer.writerows(validation_rows(iteration, validation_plays(config), player, executor, columns))
            file.flush()
