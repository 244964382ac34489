"""The leaderboard's suites section: the records that carry a ``suite`` (written by
``python -m cabinbench.run --suite ...``), one part per suite. Nothing when there are none.

Per suite, a table with one row per (baseline, protocol, K) over every training seed, layout and
distinct episode it ran (:mod:`cabinbench.stats`): the mean over layouts of per-layout means
(over training seeds too for a learned baseline) with a stratified bootstrap 95% interval, the
IQM of the per-(seed, layout) means, success with a Wilson interval, the fraction of episodes that
reached 90% coverage. Then performance profiles (fraction of layouts above each coverage and path
efficiency level; a figure and a table at a few levels), the probability that each baseline beats
each other one (a figure and a table), and whether the layout's navigation complexity predicts
difficulty: per baseline, Spearman's ρ between complexity (total, normalised) and time to 90%
coverage, path efficiency and coverage over the suite's layouts, with bootstrap intervals, and
the scatter plots. A per-layout score is the mean over the baseline's training seeds of each
seed's mean over its distinct episodes.

Last, the generalisation gap (:func:`gap_section`): every baseline that has records on the
training suite ``cabin-v1-train`` (the learners: ``ppo_gail`` trained on the seed's two cells,
``ppo_gail_suite`` on the suite) scored on it, on ``cabin-v1-test`` and on ``cabin-v1-ood``, and
the differences test − train and ood − train, over every training seed, with a generated finding.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from matplotlib import colormaps
from matplotlib.figure import Figure

from cabinbench.leaderboard.figures import save_figure
from cabinbench.leaderboard.table import layout_complexity_of, markdown_cell, policy_of, row_label
from cabinbench.records import safe_name
from cabinbench.stats import (
    MIN_CORRELATION_PAIRS,
    Summary,
    distinct_episodes,
    iqm,
    performance_profile,
    probability_of_improvement,
    spearman,
    stratified_bootstrap,
    stratified_difference,
    success_rate,
)

SUITE_KEY = ["baseline", "protocol", "n_agents"]
SCORES = {"coverage": ".3f", "path_efficiency": ".3f", "time": ".1f"}  # stratified bootstrap, format
PROFILES = {"coverage": (0.5, 0.8, 0.9, 0.95), "path_efficiency": (0.2, 0.4, 0.6)}  # levels in the table
PROFILE_LEVELS = np.linspace(0.0, 1.0, 101)  # the figure's levels
IMPROVEMENT_METRIC = "coverage"
# difficulty measures correlated with complexity: per episode, t90 counts its whole time (the time
# limit, a lower bound) when the episode never reached 90% coverage
DIFFICULTY = ("t90", "path_efficiency", "coverage")
COMPLEXITY = ("total", "normalized")
GAP_SPLITS = {"train": "cabin-v1-train", "test": "cabin-v1-test", "ood": "cabin-v1-ood"}
"""The generalisation gap's splits: the training suite, its held-out test split, out of distribution."""
GAP_METRIC = "coverage"


def classic(records: pd.DataFrame) -> pd.DataFrame:
    """The records of the classic table: outside any suite, or in the ``classic`` suite."""
    if "suite" not in records.columns:
        return records
    return records[records["suite"].isna() | (records["suite"] == "classic")]


def suite_records(records: pd.DataFrame) -> pd.DataFrame:
    """The records run in a suite (``classic`` included)."""
    if "suite" not in records.columns:
        return records.iloc[0:0]
    return records[records["suite"].notna()]


def episode_value(episodes: pd.DataFrame, metric: str) -> pd.Series:
    """An episode's value of a difficulty measure (``t90`` censored at the episode's time)."""
    if metric == "t90":
        return episodes["t90"].astype(float).fillna(episodes["time"].astype(float))
    return episodes[metric].astype(float)


def suite_cells(episodes: pd.DataFrame) -> tuple[dict[tuple[str, str], pd.DataFrame], list[str]]:
    """(policy, layout) → that cell's distinct episodes, on the layouts every policy ran, and the
    layouts left out because some policy did not run them."""
    episodes = episodes.assign(policy=[policy_of(config) for config in episodes["baseline_config"]])
    distinct = distinct_episodes(episodes, within=("policy", "layout"))
    cells = {key: group for key, group in distinct.groupby(["policy", "layout"], sort=True)}
    names = sorted({policy for policy, _ in cells})
    layouts = sorted({layout for _, layout in cells})
    kept = [layout for layout in layouts if all((policy, layout) in cells for policy in names)]
    cells = {key: cell for key, cell in cells.items() if key[1] in kept}
    return cells, sorted(set(layouts) - set(kept))


def per_layout(cells: dict, metric: str) -> pd.Series:
    """A baseline's score per layout: the mean over policies of each policy's mean."""
    means = {key: float(episode_value(cell, metric).mean()) for key, cell in cells.items()}
    frame = pd.Series(means)
    return frame.groupby(level=1).mean()


def suite_rows(episodes: pd.DataFrame) -> tuple[list[dict], list[str]]:
    """One row per (baseline, protocol, K) of one suite, and notes on layouts left out."""
    rows, notes = [], []
    for values, group in episodes.groupby(SUITE_KEY, sort=True):
        key = dict(zip(SUITE_KEY, values))
        cells, left_out = suite_cells(group)
        if left_out:
            notes.append(
                f"{row_label(key)}: {len(left_out)} layouts left out, not run by every training seed "
                f"({', '.join(left_out[:3])}{' ...' if len(left_out) > 3 else ''})"
            )
        pooled = pd.concat(cells.values())
        row = {
            **key,
            "policies": len({policy for policy, _ in cells}),
            "layouts": len({layout for _, layout in cells}),
            "episodes": len(group),
            "distinct_episodes": len(pooled),
            "coverage_iqm": iqm([cell["coverage"].astype(float).mean() for cell in cells.values()]),
            "success": success_rate(pooled["success"]),
            "t90_reached": float(pooled["t90"].notna().mean()),
            "cells": cells,
        }
        for metric in SCORES:
            row[metric] = stratified_bootstrap({k: cell[metric].astype(float) for k, cell in cells.items()})
        rows.append(row)
    return rows, notes


def improvement_table(rows: list[dict], metric: str) -> dict[tuple[str, str], Summary]:
    """(X, Y) → P(X > Y) on ``metric`` over the layouts both ran, every ordered pair of rows."""
    table = {}
    for x in rows:
        for y in rows:
            if x is y:
                continue
            layouts = sorted({lay for _, lay in x["cells"]} & {lay for _, lay in y["cells"]})
            if not layouts:
                continue

            def scores(row, layout):
                return pd.concat([c for (_, lay), c in row["cells"].items() if lay == layout])[metric]

            table[row_label(x), row_label(y)] = probability_of_improvement(
                [scores(x, layout).astype(float) for layout in layouts],
                [scores(y, layout).astype(float) for layout in layouts],
            )
    return table


def complexity_rows(rows: list[dict], episodes: pd.DataFrame) -> list[dict]:
    """Per baseline and difficulty measure: Spearman's ρ with each complexity over the layouts."""
    complexity = {
        layout: layout_complexity_of(group) for layout, group in episodes.groupby("layout", sort=True)
    }
    result = []
    for row in rows:
        for metric in DIFFICULTY:
            scores = per_layout(row["cells"], metric)
            name = metric
            if metric == "t90":  # how much of it is censored at the time limit
                reached = pd.concat(row["cells"].values())["t90"].notna().mean()
                name = f"t90 [reached {reached:.0%}]"
            line = {"label": row_label(row), "metric": metric, "difficulty": name, "layouts": len(scores)}
            line["scores"] = scores
            for kind in COMPLEXITY:
                x = [complexity[layout][kind] for layout in scores.index]
                line[kind] = spearman(x, scores.to_numpy())
                line[f"x_{kind}"] = x
            result.append(line)
    return result


def profile_figure(rows: list[dict], suite: str, path) -> None:
    figure = Figure(figsize=(4.0 * len(PROFILES), 3.6))
    for axes, metric in zip(figure.subplots(1, len(PROFILES)), PROFILES):
        for index, row in enumerate(rows):
            profile = performance_profile(per_layout(row["cells"], metric), PROFILE_LEVELS)
            axes.step(
                PROFILE_LEVELS,
                profile,
                where="post",
                label=row_label(row),
                color=colormaps["tab10"](index % 10),
            )
        axes.set_xlabel(f"{metric} level τ")
        axes.set_ylabel("fraction of layouts above τ")
        axes.set_ylim(-0.02, 1.02)
        axes.grid(alpha=0.3)
    axes.legend(fontsize=7)
    figure.suptitle(f"{suite}: performance profiles", fontsize=10)
    save_figure(figure, path)


def improvement_figure(table: dict, labels: list[str], suite: str, path) -> None:
    matrix = np.full((len(labels), len(labels)), np.nan)
    for (x, y), summary in table.items():
        matrix[labels.index(x), labels.index(y)] = summary.mean
    figure = Figure(figsize=(1.2 * len(labels) + 3, 1.0 * len(labels) + 2))
    axes = figure.subplots()
    image = axes.imshow(matrix, vmin=0, vmax=1, cmap="RdBu")
    for (i, j), value in np.ndenumerate(matrix):
        if not np.isnan(value):
            axes.text(j, i, f"{value:.2f}", ha="center", va="center", fontsize=8)
    axes.set_xticks(range(len(labels)), labels, rotation=30, ha="right", fontsize=8)
    axes.set_yticks(range(len(labels)), labels, fontsize=8)
    axes.set_xlabel("Y")
    axes.set_ylabel("X")
    figure.colorbar(image, ax=axes, label=f"P(X > Y), {IMPROVEMENT_METRIC}")
    axes.set_title(f"{suite}: probability of improvement", fontsize=10)
    save_figure(figure, path)


def complexity_figure(lines: list[dict], suite: str, path) -> None:
    figure = Figure(figsize=(4.0 * len(DIFFICULTY), 3.4 * len(COMPLEXITY)))
    grid = figure.subplots(len(COMPLEXITY), len(DIFFICULTY), squeeze=False)
    labels = list(dict.fromkeys(line["label"] for line in lines))
    for line in lines:
        colour = colormaps["tab10"](labels.index(line["label"]) % 10)
        for row, kind in enumerate(COMPLEXITY):
            axes = grid[row][DIFFICULTY.index(line["metric"])]
            axes.plot(
                line[f"x_{kind}"],
                line["scores"].to_numpy(),
                "o",
                markersize=3,
                color=colour,
                label=line["label"],
            )
            axes.set_xlabel(f"complexity ({kind})")
            axes.set_ylabel(
                line["metric"] + (" (s; never reached: its time)" if line["metric"] == "t90" else "")
            )
            axes.grid(alpha=0.3)
    grid[0][0].legend(fontsize=7)
    figure.suptitle(f"{suite}: navigation complexity against difficulty, one point per layout", fontsize=10)
    save_figure(figure, path)


def finding(lines: list[dict]) -> str:
    """The complexity finding in words, from the intervals: where ρ's interval excludes 0."""
    if all(np.isnan(line[kind].low) for line in lines for kind in COMPLEXITY):
        return (
            f"Finding: too few layouts (under {MIN_CORRELATION_PAIRS}) or no variation for an interval on ρ: "
            "this suite cannot tell whether complexity predicts difficulty."
        )
    clear = [
        f"{line['label']}'s {line['difficulty']} (ρ = {line[kind].mean:.2f} with {kind} complexity)"
        for line in lines
        for kind in COMPLEXITY
        if not np.isnan(line[kind].low) and (line[kind].low > 0 or line[kind].high < 0)
    ]
    if not clear:
        return (
            "Finding: no rank correlation between navigation complexity and difficulty has an interval "
            "that excludes zero on this suite: complexity does not predict difficulty here."
        )
    return (
        "Finding: complexity predicts difficulty where the interval excludes zero: "
        + "; ".join(clear)
        + ". Total complexity grows with a layout's size, and so do times and time limits (a t90 that "
        "was rarely reached is mostly the time limit); the normalised complexity is the size-free test."
    )


def suite_part(suite: str, episodes: pd.DataFrame, folder) -> tuple[list[str], list]:
    """The Markdown of one suite in ``leaderboard.md`` (scores, performance profiles, probability of
    improvement, complexity against difficulty, notes) and its three figures, drawn into ``folder``:
    (the lines, the figures' paths)."""
    rows, notes = suite_rows(episodes)
    labels = [row_label(row) for row in rows]
    name = safe_name(suite)
    figures = [folder / f"suite__{name}__profiles.png", folder / f"suite__{name}__improvement.png"]
    figures.append(folder / f"suite__{name}__complexity.png")
    table = improvement_table(rows, IMPROVEMENT_METRIC)
    complexity = complexity_rows(rows, episodes)
    lines = [
        f"#### Suite `{suite}`",
        "",
        *_score_lines(rows, episodes),
        "",
        *_profile_lines(rows, figures[0].name),
        "",
        *_improvement_lines(table, labels, figures[1].name),
        "",
        *_complexity_lines(complexity, figures[2].name),
        "",
        finding(complexity),
    ]
    if notes:
        lines += ["", "Notes:", "", *(f"- {note}" for note in notes)]
    profile_figure(rows, suite, figures[0])
    improvement_figure(table, labels, suite, figures[1])
    complexity_figure(complexity, suite, figures[2])
    return lines, figures


def _score_lines(rows: list[dict], episodes: pd.DataFrame) -> list[str]:
    """What the scores are, and the table of every row's scores."""
    lines = [
        f"{len(episodes)} episodes on {episodes['layout'].nunique()} layouts. Scores: the mean over layouts "
        "(and training seeds) of per-layout means ± half-width of the stratified bootstrap 95% interval "
        "(layouts, training seeds and episodes resampled); IQM over the per-(seed, layout) means; success "
        "with its Wilson interval over distinct episodes; t90 reached: the fraction of episodes that "
        "reached 90% coverage.",
        "",
        "| baseline | protocol | K | seeds | layouts | episodes | distinct | coverage | coverage IQM | "
        "path_efficiency | time (s) | success [Wilson] | t90 reached |",
        "|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for row in rows:
        lines.append(
            f"| {row['baseline']} | {row['protocol']} | {row['n_agents']} | {row['policies']} | "
            f"{row['layouts']} | {row['episodes']} | {row['distinct_episodes']} | "
            + " | ".join(
                [markdown_cell(row["coverage"], ".3f"), f"{row['coverage_iqm']:.3f}"]
                + [markdown_cell(row[metric], fmt) for metric, fmt in SCORES.items() if metric != "coverage"]
                + [markdown_cell(row["success"], ".2f", bounds=True), f"{row['t90_reached']:.0%}"]
            )
            + " |"
        )
    return lines


def _profile_lines(rows: list[dict], figure: str) -> list[str]:
    """The performance profiles at the levels of ``PROFILES``, a row each."""
    levels = [(metric, level) for metric, values in PROFILES.items() for level in values]
    lines = [
        f"Performance profiles (fraction of layouts above each level; figure `{figure}`):",
        "",
        "| baseline | " + " | ".join(f"{metric} > {level}" for metric, level in levels) + " |",
        "|---|" + "---:|" * len(levels),
    ]
    for row in rows:
        cells = [
            f"{performance_profile(per_layout(row['cells'], metric), [level])[0]:.2f}"
            for metric, level in levels
        ]
        lines.append(f"| {row_label(row)} | " + " | ".join(cells) + " |")
    return lines


def _improvement_lines(table: dict, labels: list[str], figure: str) -> list[str]:
    """The probability of improvement of every row over every other, as a matrix."""
    lines = [
        f"Probability of improvement P(X > Y) on {IMPROVEMENT_METRIC}: per layout, the chance that an "
        "episode of X (row) covers more than one of Y (column), ties half, averaged over layouts, with a "
        "bootstrap "
        f"95% interval over layouts (figure `{figure}`):",
        "",
        "| X \\ Y | " + " | ".join(labels) + " |",
        "|---|" + "---:|" * len(labels),
    ]
    for x in labels:
        cells = [
            "—" if (x, y) not in table else markdown_cell(table[x, y], ".2f", bounds=True) for y in labels
        ]
        lines.append(f"| {x} | " + " | ".join(cells) + " |")
    return lines


def _complexity_lines(complexity: list[dict], figure: str) -> list[str]:
    """Spearman's ρ between the layouts' complexity and each baseline's per-layout difficulty."""
    lines = [
        "Does navigation complexity predict difficulty? Spearman's ρ over the suite's layouts between each "
        "layout's complexity and the baseline's per-layout score, with a bootstrap 95% interval over layouts "
        "(t90: an episode that never reached 90% counts its whole time, a lower bound; figure "
        f"`{figure}`):",
        "",
        "| baseline | difficulty | layouts | ρ with total complexity | ρ with normalised complexity |",
        "|---|---|---:|---:|---:|",
    ]
    for line in complexity:
        lines.append(
            f"| {line['label']} | {line['difficulty']} | {line['layouts']} | "
            + " | ".join(markdown_cell(line[kind], ".2f", bounds=True) for kind in COMPLEXITY)
            + " |"
        )
    return lines


def gap_rows(records: pd.DataFrame) -> list[dict]:
    """Per baseline (sequential, K = 1) with records on the training split: its ``GAP_METRIC`` score on each
    split (:func:`~cabinbench.stats.stratified_bootstrap` over its training seeds and the split's layouts),
    and each held-out split's difference to the training split (seeds paired)."""
    episodes = records[(records["protocol"] == "sequential") & (records["n_agents"] == 1)]
    learners = sorted(set(episodes.loc[episodes["suite"] == GAP_SPLITS["train"], "baseline"]))
    rows = []
    for baseline in learners:
        row = {"baseline": baseline}
        cells = {}
        for split, suite in GAP_SPLITS.items():
            chosen = episodes[(episodes["baseline"] == baseline) & (episodes["suite"] == suite)]
            if chosen.empty:
                continue
            found, _ = suite_cells(chosen)
            cells[split] = {key: cell[GAP_METRIC].astype(float) for key, cell in found.items()}
            row[split] = stratified_bootstrap(cells[split])
            row[f"{split}_layouts"] = len({layout for _, layout in found})
            row[f"{split}_seeds"] = len({policy for policy, _ in found})
        for split in ("test", "ood"):
            if split in cells:
                row[f"{split}_gap"] = stratified_difference(cells["train"], cells[split])
        rows.append(row)
    return rows


def gap_finding(rows: list[dict]) -> str:
    """The gap in words, from the intervals."""
    said = []
    for row in rows:
        parts = []
        for split in ("test", "ood"):
            gap = row.get(f"{split}_gap")
            if gap is None:
                continue
            if np.isnan(gap.low):
                verdict = "no interval: not the same training seeds on both"
            elif gap.high < 0 or gap.low > 0:
                verdict = "its interval excludes 0"
            else:
                verdict = "its interval includes 0: no gap shown"
            parts.append(f"{split} {gap.mean:+.3f} ({verdict})")
        said.append(
            f"{row['baseline']} covers {row['train'].mean:.3f} of its train-split layouts, and differs on "
            + ", ".join(parts)
        )
    text = "Finding: " + "; ".join(said) + "."
    test = [row for row in rows if "test" in row]
    if len(test) > 1:
        best = max(test, key=lambda row: row["test"].mean)
        text += f" On the held-out test layouts {best['baseline']} covers most ({best['test'].mean:.3f})."
    return text


def gap_section(records: pd.DataFrame) -> list[str]:
    """The generalisation-gap table and its finding (nothing without records on the training split)."""
    rows = gap_rows(records)
    if not rows:
        return []
    lines = [
        "#### Generalisation gap",
        "",
        f"{GAP_METRIC} of each learner on layouts of its training distribution ({GAP_SPLITS['train']}: the "
        "first layouts of the suite, which the generator draws independently by index), on the held-out "
        f"{GAP_SPLITS['test']} and on the out-of-distribution {GAP_SPLITS['ood']}: one episode per layout "
        "from a random start (the suite protocol), the mean over training seeds and layouts ± half-width "
        "of the stratified bootstrap 95% interval (training seeds, layouts and episodes resampled); a gap is "
        "held-out minus train, its interval with the training seeds resampled jointly. ppo_gail trained on "
        "the seed's two A320 cells, ppo_gail_suite on every layout of cabin-v1-train "
        "(`results/train_suite_policies.sh`). Training seeds: per split when they differ (train/test/ood).",
        "",
        "| baseline | training seeds | train (layouts) | test (layouts) | ood (layouts) | test − train | "
        "ood − train |",
        "|---|---:|---:|---:|---:|---:|---:|",
    ]
    for row in rows:
        scores = [
            f"{markdown_cell(row[split], '.3f')} ({row[f'{split}_layouts']})" if split in row else "—"
            for split in GAP_SPLITS
        ]
        gaps = [
            markdown_cell(row[f"{split}_gap"], "+.3f", bounds=True) if f"{split}_gap" in row else "—"
            for split in ("test", "ood")
        ]
        seeds = [str(row[f"{split}_seeds"]) for split in GAP_SPLITS if split in row]
        seeds = seeds[:1] if len(set(seeds)) == 1 else seeds
        lines.append(f"| {row['baseline']} | {'/'.join(seeds)} | " + " | ".join(scores + gaps) + " |")
    return lines + ["", gap_finding(rows), ""]


def suites_section(records: pd.DataFrame, out) -> tuple[str, list]:
    """The markdown of every suite's part (empty without suite records), the generalisation gap, and the
    figures written."""
    if records.empty:
        return "", []
    folder = out / "figures"
    folder.mkdir(parents=True, exist_ok=True)
    lines, figures = ["", "### Suites", ""], []
    for suite, episodes in records.groupby("suite", sort=True):
        part, written = suite_part(str(suite), episodes, folder)
        lines += part + [""]
        figures += written
    lines += gap_section(records)
    return "\n".join(lines), figures
