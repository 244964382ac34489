"""The leaderboard table, ``leaderboard.md`` and ``leaderboard.csv``: one row per (layout,
baseline, protocol, K), sorted; per metric the mean and its 95% bootstrap interval
(:mod:`cabinbench.stats`), the interquartile mean of coverage, ``t90`` over the episodes that
reached 90% with the fraction that did, the number of episodes and of distinct episode seeds,
and the layout's navigation complexity (normalised and total). No timestamps: the same records
give byte-identical files. The rows (:func:`group_rows`) are what every other report is drawn
per.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
import pandas as pd

from .records import read_trajectories
from .stats import Summary, iqm, summarize

ROW_KEY = ["layout", "baseline", "protocol", "n_agents"]
SORT_KEY = ["layout", "protocol", "n_agents", "baseline"]  # baselines side by side per setting
# metric → (column title, format of its numbers)
COLUMNS = {
    "coverage": ("coverage", ".3f"),
    "coverage_free": ("coverage_free", ".3f"),
    "path_length": ("path_length (m)", ".1f"),
    "path_efficiency": ("path_efficiency", ".3f"),
    "time": ("time (s)", ".1f"),
    "t90": ("t90 (s) [reached]", ".1f"),
    "collisions": ("collisions", ".1f"),
    "success": ("success", ".2f"),
}
CONFIG_FIELDS = ("layout_hash", "env_config", "baseline_config")  # should not differ within a row
stored_run = lru_cache(maxsize=None)(read_trajectories)  # each .npz is read once per leaderboard


def row_label(row) -> str:
    """How a row is named in figures: the baseline, plus protocol and K when not the default."""
    if row["protocol"] == "sequential" and row["n_agents"] == 1:
        return str(row["baseline"])
    return f"{row['baseline']} [{row['protocol']}, K={row['n_agents']}]"


def group_rows(records: pd.DataFrame) -> list[tuple[dict, pd.DataFrame]]:
    """(row key, its episodes sorted by seed, episode, file) for every row, in table order."""
    records = records.sort_values(["seed", "episode", "source"], kind="stable")
    groups = []
    for values, episodes in records.groupby(ROW_KEY, sort=False):
        groups.append((dict(zip(ROW_KEY, values)), episodes))
    return sorted(groups, key=lambda group: tuple(group[0][name] for name in SORT_KEY))


def summarize_row(key: dict, episodes: pd.DataFrame) -> dict:
    """One leaderboard row: identifiers, counts, complexity, and a Summary per metric."""
    complexity = episodes["layout_complexity"].iloc[0]
    row = {
        **key,
        "episodes": len(episodes),
        "seeds": int((episodes["seed"] + episodes["episode"]).nunique()),
        "complexity_normalized": complexity["normalized"],
        "complexity_total": complexity["total"],
        "coverage_iqm": iqm(episodes["coverage"]),
    }
    for metric in COLUMNS:
        row[metric] = summarize(metric, episodes[metric].tolist())
    return row


def mixed_settings(key: dict, episodes: pd.DataFrame) -> list[str]:
    """Notes for rows that pool episodes run under different layouts files or settings."""
    notes = []
    for name in CONFIG_FIELDS:
        distinct = sorted({repr(value) for value in episodes[name]})
        if len(distinct) > 1:
            notes.append(
                f"{row_name(key)} pools {len(distinct)} different `{name}` values: {', '.join(distinct)}"
            )
    return notes


def row_name(key: dict) -> str:
    return f"{key['layout']} / {key['baseline']} / {key['protocol']} / K={key['n_agents']}"


def csv_table(rows: list[dict]) -> pd.DataFrame:
    table = []
    for row in rows:
        line = {
            name: row[name]
            for name in (*ROW_KEY, "episodes", "seeds", "complexity_normalized", "complexity_total")
        }
        for metric in COLUMNS:
            summary: Summary = row[metric]
            line.update(
                {
                    f"{metric}_mean": summary.mean,
                    f"{metric}_ci_low": summary.low,
                    f"{metric}_ci_high": summary.high,
                }
            )
            if metric == "coverage":
                line["coverage_iqm"] = row["coverage_iqm"]
            if summary.reached is not None:
                line[f"{metric}_reached"] = summary.reached
        table.append(line)
    return pd.DataFrame(table)


def markdown_cell(summary: Summary, number_format: str) -> str:
    """``mean ± half-width of the 95% interval``; the mean alone when there is no interval."""
    if np.isnan(summary.mean):
        cell = "—"
    elif np.isnan(summary.low):
        cell = f"{summary.mean:{number_format}}"
    else:
        cell = f"{summary.mean:{number_format}} ± {(summary.high - summary.low) / 2:{number_format}}"
    return cell if summary.reached is None else f"{cell} [{summary.reached:.0%}]"


def markdown(rows: list[dict], records: pd.DataFrame, runs: str, command: str, notes: list[str]) -> str:
    versions = ", ".join(sorted(set(records["benchmark_version"].astype(str))))
    commits = sorted({str(commit)[:12] for commit in records["git_commit"] if isinstance(commit, str)})
    lines = [
        "# cabinbench leaderboard",
        "",
        f"Generated by `{command}` from the per-episode records in `{runs}`; do not edit by hand.",
        "If you use these results, please cite cabinbench as described in `CITATION.cff` at the repository "
        "root.",
        "",
        f"{len(records)} episodes from {records['source'].nunique()} record files; benchmark version "
        f"{versions}; "
        f"code commits {', '.join(commits) if commits else 'unknown'}.",
        "",
        "Cells are `mean ± half-width of the 95% percentile-bootstrap interval` over episodes (exact, "
        "possibly "
        "asymmetric bounds in `leaderboard.csv`); a lone episode has no interval. IQM: interquartile mean. "
        "t90: mean over the episodes that reached 90% coverage, [the fraction that did]. Seeds: distinct "
        "episode "
        "seeds (run seed + episode index). Complexity: the layout's navigation complexity (seed §4.1), "
        "normalised / total. Metric definitions: `cabinbench/metrics.py`.",
        "",
    ]
    titles = [
        "layout",
        "complexity",
        "baseline",
        "protocol",
        "K",
        "episodes",
        "seeds",
        "coverage",
        "coverage IQM",
        *(title for metric, (title, _) in COLUMNS.items() if metric != "coverage"),
    ]
    lines.append("| " + " | ".join(titles) + " |")
    lines.append("|" + "|".join("---" if index < 5 else "---:" for index in range(len(titles))) + "|")
    for row in rows:
        cells = [
            row["layout"],
            f"{row['complexity_normalized']:.4f} / {row['complexity_total']:.2f}",
            row["baseline"],
            row["protocol"],
            str(row["n_agents"]),
            str(row["episodes"]),
            str(row["seeds"]),
            markdown_cell(row["coverage"], ".3f"),
            f"{row['coverage_iqm']:.3f}",
        ]
        cells += [
            markdown_cell(row[metric], number_format)
            for metric, (_, number_format) in COLUMNS.items()
            if metric != "coverage"
        ]
        lines.append("| " + " | ".join(cells) + " |")
    if notes:
        lines += ["", "Notes:", "", *(f"- {note}" for note in notes)]
    return "\n".join(lines) + "\n"
