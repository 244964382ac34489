"""The learned baselines across training runs, ``ablation.md``, ``ablation.csv`` and
``figures/ablation_coverage.png``.

One training run per ablation says little: two seeds of the same command differ as much as the
ablations do. So the policies of further training seeds
(``results/training/<baseline>/seed<S>/policy.pt``) are run like the shipped ones, into their own
records folder (the leaderboard shows a row per policy and one over all of them, with the
interval over seeds); per (layout, baseline) this table sets the ablations side by side: each
policy's mean over its episodes, and the mean over policies with the lowest and highest policy.
The figure draws the coverage: a bar for the mean over policies, a dot per policy.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib import colormaps
from matplotlib.figure import Figure  # no pyplot: figures render with Agg, no window, no global state

from cabinbench.leaderboard.figures import save_figure
from cabinbench.leaderboard.table import SHIPPED, policy_name, policy_of

ABLATION_METRICS = {"coverage": ".3f", "success": ".2f", "cells_cleared": ".2f"}  # metric → number format
SIGNALS = (
    "use_curiosity",
    "use_gail",
)  # the reward signals a learned baseline adds to PPO (its training config)


def ablation_rows(records: pd.DataFrame, training: Path) -> list[dict]:
    """Per (layout, learned baseline), sequential and one robot: each trained policy's mean of
    every ``ABLATION_METRICS`` metric over its episodes (the shipped policy first), in table order.
    The learned baselines and their reward signals are those of the shipped training records,
    ``<training>/<baseline>/``."""
    signals = ablation_signals(training)
    learned = records[
        records["baseline"].isin(list(signals))
        & (records["protocol"] == "sequential")
        & (records["n_agents"] == 1)
    ]
    learned = learned.assign(policy=[policy_of(config) for config in learned["baseline_config"]])
    rows = []
    for (layout, baseline), episodes in learned.groupby(["layout", "baseline"]):
        policies = sorted(episodes.groupby("policy"), key=lambda item: (item[0] != SHIPPED, item[0]))
        rows.append(
            {
                "layout": layout,
                "baseline": baseline,
                **signals[baseline],
                "policies": [policy for policy, _ in policies],
                "episodes": [len(group) for _, group in policies],
                **{
                    metric: [float(group[metric].mean()) for _, group in policies]
                    for metric in ABLATION_METRICS
                },
            }
        )
    baseline_order = list(signals)
    return sorted(rows, key=lambda row: (row["layout"], baseline_order.index(row["baseline"])))


def ablation_signals(training: Path) -> dict[str, dict[str, bool]]:
    """``{baseline: {"use_curiosity": ..., "use_gail": ...}}`` from each
    ``<training>/<baseline>/config.json``, in the study's order: PPO alone, + curiosity, + GAIL,
    + both."""
    signals = {}
    for path in sorted(training.glob("*/config.json")):
        config = json.loads(path.read_text(encoding="utf-8"))
        if not all(name in config for name in SIGNALS):  # bc and dagger: no reward signals to ablate
            continue
        signals[path.parent.name] = {name: bool(config[name]) for name in SIGNALS}
    return dict(sorted(signals.items(), key=lambda item: (item[1]["use_gail"], item[1]["use_curiosity"])))


def ablation_figure(rows: list[dict], path: Path) -> None:
    """Coverage of each learned baseline per layout: a bar for the mean over its policies, a dot per
    policy."""
    layouts = sorted({row["layout"] for row in rows})
    baselines = list(dict.fromkeys(row["baseline"] for row in rows))
    width = 0.8 / len(baselines)
    figure = Figure(figsize=(max(6.4, 1.6 * len(layouts)), 4.0))
    axes = figure.subplots()
    for index, baseline in enumerate(baselines):
        colour = colormaps["tab10"](index % 10)
        chosen = {row["layout"]: row["coverage"] for row in rows if row["baseline"] == baseline}
        offset = (index - (len(baselines) - 1) / 2) * width
        positions = [layout_index + offset for layout_index, layout in enumerate(layouts) if layout in chosen]
        values = [chosen[layout] for layout in layouts if layout in chosen]
        axes.bar(
            positions,
            [np.mean(policies) for policies in values],
            width,
            color=colour,
            alpha=0.6,
            label=baseline,
        )
        for position, policies in zip(positions, values):
            axes.plot(
                [position] * len(policies), policies, "o", color=colour, markeredgecolor="black", markersize=4
            )
    axes.set_xticks(range(len(layouts)), layouts, rotation=20, ha="right")
    axes.set_ylabel("coverage")
    axes.set_ylim(0, 1.0)
    axes.set_title("learned baselines: mean over training runs (bar), each trained policy (dot)", fontsize=10)
    axes.legend(fontsize=8)
    axes.grid(axis="y", alpha=0.3)
    save_figure(figure, path)


def ablation_csv(rows: list[dict]) -> pd.DataFrame:
    """One line per (layout, baseline, policy): its episodes and metric means."""
    lines = []
    for row in rows:
        for index, policy in enumerate(row["policies"]):
            lines.append(
                {
                    "layout": row["layout"],
                    "baseline": row["baseline"],
                    "policy": policy,
                    "episodes": row["episodes"][index],
                    **{metric: row[metric][index] for metric in ABLATION_METRICS},
                }
            )
    return pd.DataFrame(lines)


def ablation_markdown(rows: list[dict], sources: str, command: str) -> str:
    def spread(values: list[float], number_format: str) -> str:
        if len(values) == 1:
            return f"{values[0]:{number_format}}"
        low, high = min(values), max(values)
        return f"{np.mean(values):{number_format}} [{low:{number_format}}, {high:{number_format}}]"

    lines = [
        "# cabinbench: the learned baselines across training runs",
        "",
        f"Generated by `{command}` from the per-episode records in {sources}; do not edit by hand.",
        "",
        "Each learned baseline is trained by the same command with the same budget under several seeds "
        "(`python -m cabinbench.train --baseline NAME --seed S`). `shipped`: the policy in "
        "`baselines/ppo_gail/checkpoints/` (the leaderboard's `(shipped)` rows); `seedS`: "
        "`results/training/NAME/seedS/policy.pt`. "
        "Each policy is scored by its mean over its episodes; a cell gives the mean over the policies and, "
        "in "
        "brackets, the lowest and highest policy; the leaderboard's `all seeds` rows give the interval over "
        "training seeds. Sequential protocol, one robot; zero-shot on all but `a320_cell`.",
        "",
        "| layout | baseline | ICM | GAIL | policies | episodes | "
        + " | ".join(metric for metric in ABLATION_METRICS)
        + " | per policy: coverage / cells_cleared |",
        "|---|---|---|---|---:|---:|" + "---:|" * len(ABLATION_METRICS) + "---|",
    ]
    for row in rows:
        per_policy = ", ".join(
            f"{policy_name(policy)} {coverage:.3f} / {cells:.2f}"
            for policy, coverage, cells in zip(row["policies"], row["coverage"], row["cells_cleared"])
        )
        cells = [
            row["layout"],
            row["baseline"],
            "yes" if row["use_curiosity"] else "no",
            "yes" if row["use_gail"] else "no",
            str(len(row["policies"])),
            str(sum(row["episodes"])),
            *(spread(row[metric], number_format) for metric, number_format in ABLATION_METRICS.items()),
            per_policy,
        ]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"
