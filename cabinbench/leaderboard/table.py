"""The leaderboard table, ``leaderboard.md`` and ``leaderboard.csv``: one row per (layout,
baseline, protocol, K) and, for a learned baseline, per training seed, then one row over all its
training seeds; sorted. Per metric the mean and its 95% interval (:mod:`cabinbench.stats`: over
distinct episodes only, so a deterministic baseline's repeated episode has no interval; success
with a Wilson interval; across training seeds a t interval over the seeds' own values), the
interquartile mean of coverage, ``t90`` over the episodes that reached 90% with the fraction
that did, the number of episodes and of distinct ones, and the layout's navigation complexity
(normalised and total). No
timestamps: the same records give byte-identical files. The shipped policies' rows
(:func:`group_rows`) are what every other report is drawn per.
"""

from __future__ import annotations

import json
from functools import lru_cache
from pathlib import Path

import numpy as np
import pandas as pd

from cabinbench.records import read_trajectories
from cabinbench.stats import RATES, Summary, distinct_episodes, iqm, summarize_cells

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
    "clean_score": ("score", ".3f"),
    "success": ("cleaned [Wilson]", ".2f"),
}
CONFIG_FIELDS = ("layout_hash", "env_config", "baseline_config")  # should not differ within a row
SHIPPED = "shipped"  # the policy a learned baseline runs when no checkpoint is given
ALL_SEEDS = "all seeds"  # the policy column of a learned baseline's row over every training seed
stored_run = lru_cache(maxsize=None)(read_trajectories)  # each .npz is read once per leaderboard


def layout_complexity_of(episodes: pd.DataFrame) -> dict:
    """The navigation complexity (``normalized``, ``total``) of the layout these episodes ran on:
    the one place every report reads it from."""
    return episodes["layout_complexity"].iloc[0]


def policy_of(baseline_config: dict) -> str:
    """The trained policy an episode ran: its ``checkpoint`` file (the study's pair: its ``cleaning``
    network's), or the shipped one."""
    return str(baseline_config.get("checkpoint", baseline_config.get("cleaning", SHIPPED)))


def policy_name(policy: str) -> str:
    """Short name of a policy in the tables: ``shipped``, or the folder holding its file (``seed1``)."""
    return policy if policy == SHIPPED else Path(policy).parent.name or policy


def shipped_seeds(training: Path) -> dict[str, int]:
    """``{learned baseline: the training seed of its shipped policy}``, from
    ``<training>/<baseline>/config.json``."""
    return {
        path.parent.name: json.loads(path.read_text(encoding="utf-8"))["seed"]
        for path in sorted(training.glob("*/config.json"))
    }


def seed_label(policy: str, seeds: dict[str, int], baseline: str) -> str:
    """A learned policy in the table: ``seed0 (shipped)`` (``shipped`` when its training records
    are not there), ``seed1`` ..."""
    if policy != SHIPPED:
        return policy_name(policy)
    return f"seed{seeds[baseline]} (shipped)" if baseline in seeds else SHIPPED


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


def summarize_row(key: dict, episodes: pd.DataFrame, policy: str = "", metrics=COLUMNS) -> dict:
    """One leaderboard row over the episodes of one policy or, for ``ALL_SEEDS``, of several
    (column ``policy``): identifiers, counts, complexity, and a Summary per metric of ``metrics``
    over the distinct episodes, each policy a stratum."""
    complexity = layout_complexity_of(episodes)
    per_policy = {
        name: distinct_episodes(group)
        for name, group in episodes.groupby(
            [policy_of(config) for config in episodes["baseline_config"]], sort=True
        )
    }
    distinct = pd.concat(per_policy.values())
    row = {
        **key,
        "policy": policy,
        "policies": len(per_policy),
        "episodes": len(episodes),
        "distinct_episodes": len(distinct),
        "complexity_normalized": complexity["normalized"],
        "complexity_total": complexity["total"],
        "coverage_iqm": iqm(distinct["coverage"]),
    }
    for metric in metrics:
        cells = {(name, key["layout"]): group[metric].tolist() for name, group in per_policy.items()}
        row[metric] = summarize_cells(metric, cells)
    return row


def table_rows(records: pd.DataFrame, training: Path) -> list[tuple[dict, pd.DataFrame]]:
    """Every row of the table with the episodes it summarises: per (layout, baseline, protocol, K)
    one row; for a learned baseline (one with shipped training records in ``training``, or episodes
    of several policies) one per training seed's policy, the shipped one first, then one over all."""
    seeds = shipped_seeds(training)
    rows = []
    for key, episodes in group_rows(records):
        policies = [policy_of(config) for config in episodes["baseline_config"]]
        order = sorted(set(policies), key=lambda policy: (policy != SHIPPED, policy_name(policy)))
        if key["baseline"] not in seeds and len(order) == 1:
            rows.append((summarize_row(key, episodes), episodes))
            continue
        for policy in order:
            chosen = episodes[[name == policy for name in policies]]
            rows.append((summarize_row(key, chosen, seed_label(policy, seeds, key["baseline"])), chosen))
        if len(order) > 1:
            rows.append((summarize_row(key, episodes, ALL_SEEDS), episodes))
    return rows


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


def deterministic(row: dict) -> bool:
    """A row whose episodes are all one episode repeated: a mean and no interval."""
    return row["episodes"] > 1 and row["distinct_episodes"] == 1


def csv_table(rows: list[dict]) -> pd.DataFrame:
    table = []
    for row in rows:
        line = {
            name: row[name]
            for name in (
                *ROW_KEY,
                "policy",
                "policies",
                "episodes",
                "distinct_episodes",
                "complexity_normalized",
                "complexity_total",
            )
        }
        for metric in COLUMNS:
            summary: Summary = row[metric]
            line.update(
                {
                    f"{metric}_mean": summary.mean,
                    f"{metric}_ci_low": summary.low,
                    f"{metric}_ci_high": summary.high,
                    f"{metric}_n": summary.n,  # the units behind the interval: episodes, or seeds
                }
            )
            if metric == "coverage":
                line["coverage_iqm"] = row["coverage_iqm"]
            if summary.reached is not None:
                line[f"{metric}_reached"] = summary.reached
        table.append(line)
    return pd.DataFrame(table)


def markdown_cell(summary: Summary, number_format: str, bounds: bool = False) -> str:
    """``mean ± half-width of the 95% interval`` (``mean [low, high]`` with ``bounds``); the mean
    alone when there is no interval."""
    if np.isnan(summary.mean):
        cell = "—"
    elif np.isnan(summary.low):
        cell = f"{summary.mean:{number_format}}"
    elif bounds:
        cell = (
            f"{summary.mean:{number_format}} [{summary.low:{number_format}}, {summary.high:{number_format}}]"
        )
    else:
        cell = f"{summary.mean:{number_format}} ± {(summary.high - summary.low) / 2:{number_format}}"
    return cell if summary.reached is None else f"{cell} [{summary.reached:.0%}]"


def distinct_cell(row: dict) -> str:
    if deterministic(row):
        return f"deterministic: {row['episodes']} identical episodes"
    return str(row["distinct_episodes"])


def document_header(records: pd.DataFrame, runs: str, command: str) -> str:
    """The top of ``leaderboard.md``: what generated it, from what, and how to cite it."""
    versions = ", ".join(sorted(set(records["benchmark_version"].astype(str))))
    commits = sorted({str(commit)[:12] for commit in records["git_commit"] if isinstance(commit, str)})
    lines = [
        "# cabinbench leaderboard",
        "",
        f"Generated by `{command}` from the per-episode records in {runs}; do not edit by hand.",
        "If you use these results, please cite cabinbench as described in `CITATION.cff` at the repository "
        "root.",
        "",
        f"{len(records)} episodes from {records['source'].nunique()} record files; benchmark version "
        f"{versions}; code commits {', '.join(commits) if commits else 'unknown'}.",
        "",
    ]
    return "\n".join(lines) + "\n"


def markdown(rows: list[dict], notes: list[str]) -> str:
    """The named layouts' table: a row per layout, method, policy, protocol and K."""
    lines = [
        "## Named layouts: every method, policy and protocol",
        "",
        "Cells are `mean ± half-width of the 95% interval` (exact, possibly asymmetric bounds in "
        "`leaderboard.csv`). Intervals run over distinct episodes only: episodes with the same outcome "
        "in every metric are one episode repeated and count once, so a deterministic baseline from the "
        "layout's fixed start has a mean and no interval (`deterministic: n identical episodes`), and so "
        "has a lone episode. Within one policy the interval is a percentile bootstrap over its distinct "
        "episodes; a learned baseline has a row per training seed (`seed0 (shipped)` is the policy the "
        "package ships) and an `all seeds` row: the mean over seeds of each seed's own value, with a "
        "Student-t interval over the seeds (n = seeds in `leaderboard.csv`; a bootstrap over three seeds "
        "cannot reach beyond them). Score: the headline score (see above). Cleaned: the share of episodes "
        "that cleaned the floor, with its Wilson interval `[low, high]` over the distinct episodes. "
        "IQM: interquartile mean of "
        "coverage. t90: mean over the episodes that reached 90% coverage, [the fraction that did]. "
        "Complexity: the layout's navigation complexity (the study's §4.1), normalised / total. Definitions: "
        "`cabinbench/metrics.py` (metrics), `cabinbench/stats.py` (statistics).",
        "",
    ]
    titles = [
        "layout",
        "complexity",
        "baseline",
        "policy",
        "protocol",
        "K",
        "episodes",
        "distinct",
        "coverage",
        "coverage IQM",
        *(title for metric, (title, _) in COLUMNS.items() if metric != "coverage"),
    ]
    lines.append("| " + " | ".join(titles) + " |")
    lines.append("|" + "|".join("---" if index < 6 else "---:" for index in range(len(titles))) + "|")
    for row in rows:
        cells = [
            row["layout"],
            f"{row['complexity_normalized']:.4f} / {row['complexity_total']:.2f}",
            row["baseline"],
            row["policy"],
            row["protocol"],
            str(row["n_agents"]),
            str(row["episodes"]),
            distinct_cell(row),
            markdown_cell(row["coverage"], ".3f"),
            f"{row['coverage_iqm']:.3f}",
        ]
        cells += [
            markdown_cell(row[metric], number_format, bounds=metric in RATES)
            for metric, (_, number_format) in COLUMNS.items()
            if metric != "coverage"
        ]
        lines.append("| " + " | ".join(cells) + " |")
    if notes:
        lines += ["", "Notes:", "", *(f"- {note}" for note in notes)]
    return "\n".join(lines) + "\n"
