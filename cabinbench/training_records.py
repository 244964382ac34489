"""The files a training run leaves that the leaderboard reads, and the figure drawn from them.

A learned baseline's trainer writes, in its run folder, ``config.json`` (its settings, with
``ablation``, ``layouts``, ``seed`` and the reward signals it uses, ``use_curiosity`` and
``use_gail``), ``metrics.csv`` (one row per iteration) and, when it validates its checkpoints,
``validation.csv`` (one row per checkpoint and training layout). The leaderboard draws the training
curves and the ablation table from these files alone, without importing the baseline.
"""

from __future__ import annotations

import csv
import os
from pathlib import Path

import numpy as np


def read_metrics(path: str | os.PathLike) -> list[dict]:
    """Rows of a ``metrics.csv`` as dicts of strings (empty string: no value)."""
    with open(path, newline="") as file:
        return list(csv.DictReader(file))


def validation_score(rows: list[dict]) -> float:
    """A checkpoint's validation score, the mean over its rows: the headline ``clean_score`` where they
    record it (runs validated on cabin-v1-val), else success rate + coverage (runs validated on their
    training layouts). Both, because an episode ends at success: a policy that never finishes may
    cover more by wandering until the step limit, and one that finishes early may leave floor uncleaned."""
    if all(row.get("clean_score") not in (None, "") for row in rows):
        return float(np.mean([float(row["clean_score"]) for row in rows]))
    return float(np.mean([float(row["success"]) + float(row["coverage"]) for row in rows]))


def best_checkpoint(validation: list[dict]) -> tuple[int, float]:
    """(iteration, score) of the checkpoint with the best ``validation_score`` in ``validation.csv``'s rows
    (the later one on a tie)."""
    scores = {
        iteration: validation_score([row for row in validation if int(row["iteration"]) == iteration])
        for iteration in {int(row["iteration"]) for row in validation}
    }
    best = max(scores, key=lambda iteration: (scores[iteration], iteration))
    return best, scores[best]


CURVE_PANELS = (
    ("episode_reward", "(a) Cumulative reward"),
    ("gail_discriminator", "(b) GAIL loss"),
    ("curiosity_forward", "(c) Curiosity forward loss"),
    ("curiosity_inverse", "(d) Curiosity inverse loss"),
    ("policy_loss", "(e) Policy loss"),
    ("value_loss", "(f) Value loss"),
)


def plot_curves(
    rows: list[dict],
    path: str | os.PathLike,
    title: str = "",
    smoothing: int = 10,
    validation: list[dict] | None = None,
) -> None:
    """2 x 3 panels like the study's Fig. 5.8: the raw value per iteration (light) and a running mean (dark).
    Panels of modules the ablation does not use say so. With ``validation`` (``validation.csv``'s rows) a
    seventh panel shows each checkpoint's validation coverage and success and marks the best one. The same
    rows give a byte-identical PNG."""
    from matplotlib.figure import Figure  # no pyplot: no window, no global state

    figure = Figure(figsize=(17, 7) if validation else (13, 7))
    axes = figure.subplots(2, 4 if validation else 3)
    if validation:
        _plot_validation(axes[0, 3], validation)
        axes[1, 3].set_axis_off()
    for axis, (column, label) in zip(axes[:, :3].flat, CURVE_PANELS):
        points = [
            (int(row["iteration"]), float(row[column])) for row in rows if row[column] not in ("", None)
        ]
        axis.set_title(label, fontsize=10)
        axis.set_xlabel("iteration")
        axis.grid(alpha=0.3)
        if not points:
            axis.text(
                0.5,
                0.5,
                "not used by this ablation",
                ha="center",
                va="center",
                transform=axis.transAxes,
                color="grey",
            )
            axis.set_xticks([])
            axis.set_yticks([])
            continue
        x, y = np.array(points).T
        axis.plot(x, y, color="tab:blue", alpha=0.25, linewidth=0.8)
        window = min(smoothing, len(y))
        smooth = np.convolve(y, np.ones(window) / window, mode="valid")
        axis.plot(x[window - 1 :], smooth, color="tab:blue", linewidth=1.5)
    if title:
        figure.suptitle(title)
    figure.tight_layout()
    temporary = Path(path).with_name(Path(path).stem + ".tmp.png")
    figure.savefig(
        temporary, dpi=100, metadata={"Software": None}
    )  # no matplotlib version in committed figures
    os.replace(temporary, path)


def _plot_validation(axis, validation: list[dict]) -> None:
    """Mean validation coverage and success rate (and clean_score where recorded) over the validation layouts
    per checkpoint; the best one marked."""
    iterations = sorted({int(row["iteration"]) for row in validation})
    scored = ("clean_score", "tab:blue") if validation[0].get("clean_score") not in (None, "") else None
    for metric, colour in filter(None, (scored, ("coverage", "tab:green"), ("success", "tab:orange"))):
        means = [
            np.mean([float(row[metric]) for row in validation if int(row["iteration"]) == iteration])
            for iteration in iterations
        ]
        axis.plot(iterations, means, marker="o", markersize=3, color=colour, label=metric)
    best, _ = best_checkpoint(validation)
    axis.axvline(best, color="grey", linestyle="--", linewidth=1, label=f"best ({best})")
    held_out = all(row["layout"].startswith("cabin-v1-val/") for row in validation)
    axis.set_title(
        f"(g) Validation: {'cabin-v1-val' if held_out else 'training cells, other seeds'}", fontsize=10
    )
    axis.set_xlabel("iteration")
    axis.set_ylim(-0.02, 1.02)
    axis.grid(alpha=0.3)
    axis.legend(fontsize=8)
