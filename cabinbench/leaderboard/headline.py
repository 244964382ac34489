"""The headline table: one row per method (per team size K), read on one screen.

Each row shows what the method observes, its headline score (:func:`cabinbench.metrics.clean_score`)
on ``cabin-v1-test`` and on ``cabin-v1-ood`` (the IQM over layouts, with its interval and n),
``full_cabin`` coverage and time (makespan for teams), the share of test episodes that cleaned the
floor, what training cost (env steps and wall-clock, from the training records) and how many
training seeds stand behind the row.

The interval depends on what varies (:mod:`cabinbench.stats`): a method with several training
seeds gets a Student-t interval over the seeds' scores (n = seeds); one policy (a planner, or a
single trained seed) a percentile bootstrap over layouts (n = layouts). Scores live in [0, 1], and
intervals are clipped to it.
"""

from __future__ import annotations

import importlib.util
import json
import math
from dataclasses import dataclass
from html import escape
from pathlib import Path

import numpy as np
import pandas as pd

from cabinbench.leaderboard.table import policy_of
from cabinbench.stats import Summary, iqm_over_layouts, t_interval

CHECKPOINTS = Path(importlib.util.find_spec("cabinbench.baselines.ppo_gail").origin).with_name("checkpoints")
"""The shipped checkpoints and their training records, found without importing the learner (the core
imports no baseline, and reading them needs no torch)."""
HEADLINE_SUITES = ("cabin-v1-test", "cabin-v1-ood")
HEADLINE_LAYOUT = "full_cabin"
OBSERVES = {
    # what each built-in method sees while it acts (DESIGN, "Observation"); a submission's row shows "?"
    "boustrophedon": "map, pose",
    "random_bounce": "bumper",
    "random_bounce_study": "bumper",
    "ppo": "lidar, velocity, coverage patch",
    "ppo_icm": "lidar, velocity, coverage patch",
    "ppo_gail_only": "lidar, velocity, coverage patch",
    "ppo_gail": "lidar, velocity, coverage patch",
    "ppo_gail_suite": "lidar, velocity, coverage patch",
    "ppo_gail_team": "lidar, velocity, coverage patch",
    "ppo_gail_study": "lidar, velocity",
    "ppo_lstm": "lidar, velocity, memory",
    "bc": "lidar, velocity, coverage patch",
    "dagger": "lidar, velocity, coverage patch",
    "path": "a given plan, pose",
    "coverage_path_planner": "map, pose",
}


@dataclass(frozen=True)
class TrainingCost:
    """What training one method cost from scratch, over its recorded training runs (one per seed): a run
    started from another run's policy (``run_chain``) costs that run's training too."""

    env_steps: float  # mean over runs
    wall_clock_s: float  # mean over runs
    runs: int
    all_runs_wall_clock_s: float  # every run's, a start that several runs share counted once


def headline_score(episodes: pd.DataFrame) -> Summary:
    """A method's headline score on one set of layouts: per policy (training seed), the IQM over
    the layouts every policy played of each layout's mean ``clean_score``; over several policies a
    t interval of those (n = policies), over one a bootstrap over layouts (n = layouts)."""
    per_layout = _common_layouts(episodes.groupby(["policy", "layout"])["clean_score"].mean())
    policies = per_layout.index.get_level_values("policy").unique()
    if len(policies) == 1:
        return _clipped(iqm_over_layouts(per_layout.to_numpy()))
    return _clipped(t_interval([iqm_over_layouts(per_layout[policy]).mean for policy in policies]))


def success_share(episodes: pd.DataFrame) -> Summary:
    """The share of episodes that cleaned the floor: per policy the mean over layouts of each
    layout's share; over several policies a t interval of those (n = policies), else a plain mean
    with n = episodes (its interval is the Wilson one of the detailed tables)."""
    per_layout = _common_layouts(episodes.groupby(["policy", "layout"])["success"].mean())
    per_policy = per_layout.groupby(level="policy").mean()
    if len(per_policy) > 1:
        return _clipped(t_interval(per_policy.to_numpy()))
    return Summary(float(per_policy.iloc[0]), math.nan, math.nan, len(episodes))


def _common_layouts(per_layout: pd.Series) -> pd.Series:
    """Per-(policy, layout) values on the layouts every policy played: seeds are compared on the
    same layouts."""
    table = per_layout.unstack("policy").dropna()
    return table.stack().swaplevel().sort_index()


def _clipped(summary: Summary) -> Summary:
    low, high = (
        min(1.0, max(0.0, bound)) if not math.isnan(bound) else bound for bound in (summary.low, summary.high)
    )
    return Summary(summary.mean, low, high, summary.n)


def training_cost(training: Path, baseline: str) -> TrainingCost | None:
    """Env steps and wall-clock of a learned baseline's training runs, ``<training>/<baseline>/`` and its
    ``seed*/`` folders, each with the runs it started from (``run_chain``): ``metrics.csv``'s last row of
    each, summed along the chain."""
    runs = [training / baseline, *sorted((training / baseline).glob("seed*"))]
    chains = [run_chain(run, training) for run in runs if (run / "metrics.csv").is_file()]
    if not chains:
        return None
    cost = {run: _run_cost(run) for chain in chains for run in chain}
    steps, seconds = np.mean([np.sum([cost[run] for run in chain], axis=0) for chain in chains], axis=0)
    all_runs = sum(seconds for _, seconds in cost.values())
    return TrainingCost(float(steps), float(seconds), len(chains), float(all_runs))


def run_chain(run: Path, training: Path) -> list[Path]:
    """``run`` and the runs it started from, latest first: a run whose ``config.json`` names an
    ``init_policy`` (the team's stages) went on from that policy's run, the folder of a policy file (a path
    from the repository root, ``training``'s grandparent) or, for a shipped policy's name,
    ``<training>/<name>/``. The chain stops at a start without training records."""
    chain = [run.resolve()]
    while True:
        config = chain[-1] / "config.json"
        start = (
            json.loads(config.read_text(encoding="utf-8")).get("init_policy") if config.is_file() else None
        )
        if not start:
            return chain
        folder = (training.parents[1] / start).parent if start.endswith(".pt") else training / start
        folder = folder.resolve()
        if folder in chain or not (folder / "metrics.csv").is_file():
            return chain
        chain.append(folder)


def _run_cost(run: Path) -> tuple[float, float]:
    """(env steps, seconds of training) of one run: its ``metrics.csv``'s last row."""
    last = pd.read_csv(run / "metrics.csv").iloc[-1]
    return float(last["timesteps"]), float(last["train_time"])


def staged_training_cost(training: Path, baseline: str) -> TrainingCost | None:
    """The cost of a baseline trained in stages, each stage's runs in ``<training>/<baseline>_<stage>/`` (the
    study's pair: a seed's cleaning and tracking networks): the stages' costs summed, a run a seed's pair."""
    folders = sorted(folder.name for folder in training.glob(f"{baseline}_*") if folder.is_dir())
    stages = [cost for name in folders if (cost := training_cost(training, name))]
    if not stages:
        return None
    return TrainingCost(
        sum(stage.env_steps for stage in stages),
        sum(stage.wall_clock_s for stage in stages),
        min(stage.runs for stage in stages),
        sum(stage.all_runs_wall_clock_s for stage in stages),
    )


def headline_rows(records: pd.DataFrame, training: Path) -> list[dict]:
    """One row per (baseline, K) with records on a headline suite or layout, best test score first."""
    records = records.assign(policy=records["baseline_config"].map(policy_of))
    methods = records.loc[
        records["suite"].isin(HEADLINE_SUITES) | (records["layout"] == HEADLINE_LAYOUT),
        ["baseline", "n_agents"],
    ].drop_duplicates()
    rows = []
    for baseline, n_agents in methods.itertuples(index=False):
        method = records[(records["baseline"] == baseline) & (records["n_agents"] == n_agents)]
        row = {"baseline": baseline, "n_agents": int(n_agents), "observes": OBSERVES.get(baseline, "?")}
        for suite in HEADLINE_SUITES:  # scored in the benchmark's protocol, cell by cell
            episodes = method[(method["suite"] == suite) & (method["protocol"] == "sequential")]
            row[suite] = headline_score(episodes) if len(episodes) else None
            row[f"{suite} seeds"] = episodes["policy"].nunique()
        test = method[(method["suite"] == HEADLINE_SUITES[0]) & (method["protocol"] == "sequential")]
        row["success"] = success_share(test) if len(test) else None
        cabin = method[(method["layout"] == HEADLINE_LAYOUT) & method["suite"].isna()]
        cabin = cabin[cabin["protocol"] == "sequential"]
        row["full_cabin_coverage"] = float(cabin["coverage"].mean()) if len(cabin) else math.nan
        time = cabin["makespan"] if n_agents > 1 and "makespan" in cabin else cabin["time"]
        row["full_cabin_time"] = float(time.mean()) if len(cabin) else math.nan
        row["cost"] = training_cost(training, baseline) or staged_training_cost(training, baseline)
        row["seeds"] = max(row[f"{suite} seeds"] for suite in HEADLINE_SUITES) or cabin["policy"].nunique()
        rows.append(row)
    return sorted(rows, key=_rank)


def _rank(row: dict) -> tuple:
    test = row[HEADLINE_SUITES[0]]
    return (-(test.mean if test is not None else -1.0), row["baseline"], row["n_agents"])


def _score_cell(summary: Summary | None) -> str:
    if summary is None:
        return "—"
    if math.isnan(summary.low):
        return f"{summary.mean:.3f} (n={summary.n})"
    return f"{summary.mean:.3f} [{summary.low:.3f}, {summary.high:.3f}] (n={summary.n})"


def _cost_cell(cost: TrainingCost | None) -> str:
    if cost is None:
        return "—"
    return f"{cost.env_steps / 1e6:.2f} M, {cost.wall_clock_s / 3600:.2f} h"


HEADER = (
    "method",
    "K",
    "observes",
    "score, cabin-v1-test",
    "score, cabin-v1-ood",
    "full_cabin coverage",
    "full_cabin time (s)",
    "cleaned, test",
    "training (env steps, wall-clock)",
    "training seeds",
)
EXPLANATION = (
    "Score: the headline score (`cabinbench/metrics.py`, `clean_score`): an episode that cleans the floor "
    "(coverage reaches the layout's level, 0.98) scores 1 - (time to clean) / (2 × time limit), in [0.5, 1); "
    "one that does not scores its coverage at the time limit / (2 × level), under 0.5, so stopping early "
    "with floor left dirty never beats cleaning it, and among cleaned episodes the faster wins. A method's "
    "score "
    "on a suite is the interquartile mean over layouts of each layout's mean, with its 95% interval and n: "
    "a Student-t interval over training seeds (n = seeds, compared on the layouts every seed played) for a "
    "learned method with several, else a bootstrap over layouts (n = layouts); intervals are clipped to "
    "[0, 1]. Suites are scored in the sequential protocol; every suite episode starts from a pose drawn "
    "from its seed. full_cabin: the mean over the method's episodes from the layout's own start "
    "(time: makespan for teams). Cleaned: the share of test "
    "episodes that cleaned the floor. Training: env steps and wall-clock per run, the mean over the "
    "method's recorded training runs, each counted from scratch (a run started from another policy, as the "
    "team's stages are, includes that policy's training). Sorted by the test score."
)


def headline_section(rows: list[dict]) -> str:
    """The headline table of ``leaderboard.md`` with what a reader needs to read it."""
    return "\n".join(["## Headline: one row per method", "", EXPLANATION, "", headline_markdown(rows), ""])


def _cells(row: dict) -> list[str]:
    return [
        f"`{row['baseline']}`",
        str(row["n_agents"]),
        row["observes"],
        *(_score_cell(row[suite]) for suite in HEADLINE_SUITES),
        _number(row["full_cabin_coverage"], ".3f"),
        _number(row["full_cabin_time"], ".1f"),
        _score_cell(row["success"]),
        _cost_cell(row["cost"]),
        str(row["seeds"]),
    ]


def headline_markdown(rows: list[dict]) -> str:
    """The headline table in Markdown."""
    lines = ["| " + " | ".join(HEADER) + " |", "|" + "---|" * len(HEADER)]
    lines += ["| " + " | ".join(_cells(row)) + " |" for row in rows]
    return "\n".join(lines)


def headline_html(rows: list[dict]) -> str:
    """The same table for the site's first page."""
    head = "".join(f"<th>{escape(title)}</th>" for title in HEADER)
    body = "".join(
        "<tr>" + "".join(f"<td>{escape(cell.strip('`'))}</td>" for cell in _cells(row)) + "</tr>"
        for row in rows
    )
    return (
        f"<h2>Headline: one row per method</h2><p>{escape(EXPLANATION)}</p>"
        f"<table><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>"
    )


def _number(value: float, number_format: str) -> str:
    return "—" if math.isnan(value) else format(value, number_format)


def headline_csv(rows: list[dict]) -> pd.DataFrame:
    """The headline table as CSV columns (intervals as low/high, n beside each)."""
    table = []
    for row in rows:
        entry = {"baseline": row["baseline"], "n_agents": row["n_agents"], "observes": row["observes"]}
        for key in (*HEADLINE_SUITES, "success"):
            values = (row[key] or Summary(math.nan, math.nan, math.nan, 0)).as_dict()
            for field in ("mean", "ci_low", "ci_high", "n"):
                entry[f"{key}_{field}"] = values[field]
        entry.update(
            full_cabin_coverage=row["full_cabin_coverage"],
            full_cabin_time=row["full_cabin_time"],
            train_env_steps=row["cost"].env_steps if row["cost"] else None,
            train_wall_clock_s=row["cost"].wall_clock_s if row["cost"] else None,
            seeds=row["seeds"],
        )
        table.append(entry)
    return pd.DataFrame(table)
