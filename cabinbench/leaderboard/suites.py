"""The leaderboard's suites section: the records that carry a ``suite`` (written by
``python -m cabinbench.run --suite ...``), one part per suite. Nothing when there are none.

Per suite, a table with one row per (baseline, protocol, K) over every training seed, layout and
distinct episode it ran (:mod:`cabinbench.stats`): the mean over layouts of per-layout means
(a stratified bootstrap 95% interval; over several training seeds a t interval of the seeds' own
scores), the
IQM of the per-(seed, layout) means, success with a Wilson interval, the fraction of episodes that
reached 90% coverage. Then performance profiles (fraction of layouts above each coverage and path
efficiency level; a figure and a table at a few levels), the probability that each baseline beats
each other one (a figure and a table), and whether the layout's navigation complexity predicts
difficulty: per baseline, Spearman's ρ between complexity (total, normalised) and time to 90%
coverage, path efficiency and coverage over the suite's layouts, with bootstrap intervals, and
the scatter plots. A per-layout score is the mean over the baseline's training seeds of each
seed's mean over its distinct episodes.

The generalisation gap that follows the suites is :mod:`cabinbench.leaderboard.gap`'s.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from matplotlib import colormaps
from matplotlib.figure import Figure

from cabinbench.leaderboard.figures import save_figure
from cabinbench.leaderboard.predictors import (
    CONTROL,
    HYPOTHESES,
    layout_features,
    predictor_finding,
    predictor_markdown,
    predictor_tests,
)
from cabinbench.leaderboard.table import markdown_cell, policy_of, row_label
from cabinbench.records import safe_name
from cabinbench.stats import (
    Summary,
    distinct_episodes,
    iqm,
    performance_profile,
    probability_of_improvement,
    summarize_cells,
)

SUITE_KEY = ["baseline", "protocol", "n_agents"]
SCORES = {
    "clean_score": ".3f",
    "coverage": ".3f",
    "path_efficiency": ".3f",
    "time": ".1f",
}  # stratified bootstrap, format
PROFILES = {"coverage": (0.5, 0.8, 0.9, 0.95), "path_efficiency": (0.2, 0.4, 0.6)}  # levels in the table
PROFILE_LEVELS = np.linspace(0.0, 1.0, 101)  # the figure's levels
IMPROVEMENT_METRIC = "coverage"


def from_random_starts(records: pd.DataFrame) -> pd.Series:
    """Which records started from a pose drawn from the episode's seed (``env_config.random_start``)."""
    return records["env_config"].map(lambda config: bool((config or {}).get("random_start")))


def classic(records: pd.DataFrame) -> pd.DataFrame:
    """The records of the named layouts' table: from each layout's own start, outside any suite or
    in the ``classic`` suite (the classic suite's random-start runs are a suite of their own)."""
    if "suite" not in records.columns:
        return records
    return records[records["suite"].isna() | ((records["suite"] == "classic") & ~from_random_starts(records))]


def suite_records(records: pd.DataFrame) -> pd.DataFrame:
    """The records run in a suite (the ``classic`` suite's from random starts: its fixed-start ones
    are the named layouts' rows)."""
    if "suite" not in records.columns:
        return records.iloc[0:0]
    return records[records["suite"].notna() & ~records.index.isin(classic(records).index)]


def episode_value(episodes: pd.DataFrame, metric: str) -> pd.Series:
    """An episode's value of a measure (``t90``: NaN where the episode never reached 90%)."""
    return episodes[metric].astype(float)


def suite_cells(
    episodes: pd.DataFrame, crossed: bool = True
) -> tuple[dict[tuple[str, str], pd.DataFrame], list[str]]:
    """(policy, layout) → that cell's distinct episodes, on the layouts every policy ran, and the
    layouts left out because some policy did not run them; with ``crossed`` False (each policy on layouts
    of its own) every cell, none left out."""
    episodes = episodes.assign(policy=[policy_of(config) for config in episodes["baseline_config"]])
    distinct = distinct_episodes(episodes, within=("policy", "layout"))
    cells = {key: group for key, group in distinct.groupby(["policy", "layout"], sort=True)}
    names = sorted({policy for policy, _ in cells})
    layouts = sorted({layout for _, layout in cells})
    kept = [layout for layout in layouts if not crossed or all((policy, layout) in cells for policy in names)]
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
            "success": summarize_cells("success", {k: cell["success"] for k, cell in cells.items()}),
            "t90_reached": float(pooled["t90"].notna().mean()),
            "cells": cells,
        }
        for metric in SCORES:
            row[metric] = summarize_cells(
                metric, {k: cell[metric].astype(float) for k, cell in cells.items()}
            )
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


def complexity_tests(rows: list[dict], episodes: pd.DataFrame) -> tuple[pd.DataFrame, pd.DataFrame]:
    """The predictor tests of one suite (:mod:`cabinbench.leaderboard.predictors`): each row's
    per-layout means of every hypothesised measure (T90 over the episodes that reached 90 %), against
    the layouts' features; (the tests, the features)."""
    features = layout_features(episodes["layout"].unique())
    measures = {
        row_label(row): pd.DataFrame({measure: per_layout(row["cells"], measure) for measure in HYPOTHESES})
        for row in rows
    }
    return predictor_tests(measures, features), features


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


def complexity_figure(rows: list[dict], features: pd.DataFrame, suite: str, path) -> None:
    """Each hypothesised measure against normalised complexity and against coverable area, one point
    per layout and one colour per row."""
    predictors = ("complexity", CONTROL)
    figure = Figure(figsize=(3.6 * len(HYPOTHESES), 3.2 * len(predictors)))
    grid = figure.subplots(len(predictors), len(HYPOTHESES), squeeze=False)
    for index, row in enumerate(rows):
        colour = colormaps["tab10"](index % 10)
        for column, measure in enumerate(HYPOTHESES):
            values = per_layout(row["cells"], measure)
            for line, predictor in enumerate(predictors):
                axes = grid[line][column]
                x = features.reindex(values.index)[predictor]
                axes.plot(x, values.to_numpy(), "o", markersize=3, color=colour, label=row_label(row))
                axes.set_xlabel(
                    predictor.replace("_", " ") + (" (normalised)" if predictor == "complexity" else " (m²)")
                )
                axes.set_ylabel(measure + (" (s, reached only)" if measure == "t90" else ""))
                axes.grid(alpha=0.3)
    grid[0][0].legend(fontsize=6)
    figure.suptitle(f"{suite}: difficulty against complexity and area, one point per layout", fontsize=10)
    figure.tight_layout()
    save_figure(figure, path)


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
    tests, features = complexity_tests(rows, episodes)
    lines = [
        f"#### Suite `{suite}`",
        "",
        *_score_lines(rows, episodes),
        "",
        *_profile_lines(rows, figures[0].name),
        "",
        *_improvement_lines(table, labels, figures[1].name),
        "",
        *_complexity_lines(tests, figures[2].name),
        "",
        predictor_finding(tests, suite),
    ]
    if notes:
        lines += ["", "Notes:", "", *(f"- {note}" for note in notes)]
    profile_figure(rows, suite, figures[0])
    improvement_figure(table, labels, suite, figures[1])
    complexity_figure(rows, features, suite, figures[2])
    return lines, figures


def _score_lines(rows: list[dict], episodes: pd.DataFrame) -> list[str]:
    """What the scores are, and the table of every row's scores."""
    lines = [
        f"{len(episodes)} episodes on {episodes['layout'].nunique()} layouts. Scores: the mean over layouts "
        "of per-layout means ± half-width of the 95% interval: for one policy a stratified bootstrap "
        "(layouts, and episodes within each, resampled), for several training seeds each seed's own score, "
        "then a Student-t interval over the seeds; IQM over the per-(seed, layout) means; success (the floor "
        "cleaned) with its Wilson interval over distinct episodes, or over seeds as the scores; t90 reached: "
        "the fraction of episodes that reached 90% coverage.",
        "",
        "| baseline | protocol | K | seeds | layouts | episodes | distinct | coverage | coverage IQM | "
        "score | path_efficiency | time (s) | cleaned | t90 reached |",
        "|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
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


def _complexity_lines(tests: pd.DataFrame, figure: str) -> list[str]:
    """The predictor tests as a table (figure ``figure``)."""
    return [
        "Does navigation complexity predict difficulty? Each measure's hypothesis names its sign in "
        "advance (harder: lower coverage, longer T90 among the episodes that reach 90 %); Spearman's ρ "
        "over the suite's layouts with each predictor, and with complexity once coverable area is held "
        "fixed (partial ρ); "
        f"figure `{figure}`:",
        "",
        predictor_markdown(tests),
    ]


def suites_csv(records: pd.DataFrame) -> pd.DataFrame:
    """Every suite's rows (:func:`suite_rows`) as CSV columns, one row per (suite, baseline, protocol, K)."""
    table = []
    for suite, episodes in records.groupby("suite", sort=True):
        for row in suite_rows(episodes)[0]:
            entry = {
                "suite": suite,
                **{key: row[key] for key in (*SUITE_KEY, "policies", "layouts", "episodes")},
            }
            for metric in (*SCORES, "success"):
                for field, value in row[metric].as_dict().items():
                    entry[f"{metric}_{field}"] = value
            table.append(entry)
    return pd.DataFrame(table)


def suites_section(records: pd.DataFrame, out) -> tuple[str, list]:
    """The markdown of every suite's part (empty without suite records) and the figures written (the
    generalisation gap follows it: :func:`cabinbench.leaderboard.gap.gap_section`)."""
    if records.empty:
        return "", []
    folder = out / "figures"
    folder.mkdir(parents=True, exist_ok=True)
    lines, figures = ["", "### Suites", ""], []
    for suite, episodes in records.groupby("suite", sort=True):
        part, written = suite_part(str(suite), episodes, folder)
        lines += part + [""]
        figures += written
    return "\n".join(lines), figures
