"""The leaderboard's teams section: what K robots do together, for every layout, protocol and
baseline run with more than one robot.

One row per (layout, protocol, baseline, training seed, K), K = 1 included where it was run, so
the K rows of one policy sit together: coverage, makespan (simulated seconds until the last robot
stopped; a single robot's is its episode time, :func:`cabinbench.metrics.team_of_one`), load
balance (longest over mean path of the team's robots), contacts between robots and with obstacles,
and success; a single robot has no load balance or robot contacts. Rows and statistics are the main
table's (:mod:`cabinbench.leaderboard.table`): the same episodes, distinct episodes only, a row per
training seed and one over all seeds.
"""

from __future__ import annotations

import math

import pandas as pd

from cabinbench.leaderboard.table import ALL_SEEDS, markdown_cell, summarize_row
from cabinbench.metrics import team_of_one
from cabinbench.stats import RATES, Summary

TEAM_KEY = ("layout", "protocol", "baseline")
NOT_FOR_ONE = ("load_balance", "robot_collisions")  # what a single robot's row leaves empty
# metric → (column title, format of its numbers)
TEAM_COLUMNS = {
    "coverage": ("coverage", ".3f"),
    "makespan": ("makespan (s)", ".1f"),
    "load_balance": ("load balance", ".2f"),
    "robot_collisions": ("robot contacts", ".1f"),
    "collisions": ("obstacle contacts", ".1f"),
    "success": ("success [Wilson]", ".2f"),
}


def team_rows(rows: list[tuple[dict, pd.DataFrame]]) -> list[dict]:
    """The teams table's rows from the main table's (row, episodes) pairs, sorted so a policy's K
    values are adjacent."""
    teams = {tuple(row[name] for name in TEAM_KEY) for row, _ in rows if row["n_agents"] > 1}
    chosen = []
    for row, episodes in rows:
        if tuple(row[name] for name in TEAM_KEY) not in teams:
            continue
        key = {name: row[name] for name in (*TEAM_KEY, "n_agents")}
        if row["n_agents"] > 1:
            chosen.append(summarize_row(key, episodes, row["policy"], TEAM_COLUMNS))
            continue
        measured = {metric: column for metric, column in TEAM_COLUMNS.items() if metric not in NOT_FOR_ONE}
        alone = summarize_row(key, team_of_one(episodes), row["policy"], measured)
        chosen.append(
            {**alone, **{metric: Summary(math.nan, math.nan, math.nan, 0) for metric in NOT_FOR_ONE}}
        )
    return sorted(
        chosen,
        key=lambda row: (
            *(row[name] for name in TEAM_KEY),
            row["policy"] == ALL_SEEDS,
            row["policy"],
            row["n_agents"],
        ),
    )


def teams_section(rows: list[dict]) -> str:
    """The markdown of the teams section; empty without team rows."""
    if not rows:
        return ""
    titles = [
        "layout",
        "protocol",
        "baseline",
        "policy",
        "K",
        "episodes",
        *(t for t, _ in TEAM_COLUMNS.values()),
    ]
    lines = [
        "",
        "### Teams",
        "",
        "Every layout, protocol and baseline run with several robots, one row per K (K = 1 where it was run) "
        "and training seed; same episodes and intervals as the table above. Makespan: simulated seconds "
        "until the last robot stopped moving (one robot: its episode time). Load balance: the longest "
        "robot path over the team's mean path (1 is even). Robot contacts: contacts between two robots, "
        "each counted once. The makespan against K is figure `makespan_agents.png`.",
        "",
        "| " + " | ".join(titles) + " |",
        "|" + "|".join("---" if index < 5 else "---:" for index in range(len(titles))) + "|",
    ]
    for row in rows:
        cells = [*(str(row[name]) for name in TEAM_KEY), row["policy"], str(row["n_agents"])]
        cells.append(str(row["episodes"]))
        cells += [
            markdown_cell(row[metric], number_format, bounds=metric in RATES)
            for metric, (_, number_format) in TEAM_COLUMNS.items()
        ]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def teams_csv(rows: list[dict]) -> pd.DataFrame:
    """``teams.csv``: the section's rows with each metric's mean and exact interval bounds."""
    table = []
    for row in rows:
        line = {
            name: row[name] for name in (*TEAM_KEY, "policy", "n_agents", "episodes", "distinct_episodes")
        }
        for metric in TEAM_COLUMNS:
            summary = row[metric]
            line.update(
                {
                    f"{metric}_mean": summary.mean,
                    f"{metric}_ci_low": summary.low,
                    f"{metric}_ci_high": summary.high,
                }
            )
        table.append(line)
    return pd.DataFrame(table)
