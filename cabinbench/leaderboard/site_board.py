"""The rows of the classic board on the leaderboard site: one :class:`Entry` per (layout, baseline,
protocol, K), ours or a submission's, and the sortable, filterable table of them."""

from __future__ import annotations

from dataclasses import dataclass

import pandas as pd

from cabinbench.leaderboard.site_html import (
    baseline_page_name,
    board_filters,
    escape,
    filter_select,
    layout_page_name,
    metric_cell,
    number_cell,
    sortable_table,
)
from cabinbench.leaderboard.table import COLUMNS, distinct_cell
from cabinbench.records import safe_name

OWN_ENTRY = "cabinbench"  # the entry column of rows recorded by scripts/make_results.sh


@dataclass
class Entry:
    """One row of a board: a leaderboard row (:func:`~cabinbench.leaderboard.table.summarize_row`),
    its episodes, and where it comes from (``cabinbench``, or a submission and its status)."""

    row: dict
    episodes: pd.DataFrame
    source: str = OWN_ENTRY

    @property
    def suite(self) -> str:
        suite = self.episodes["suite"].iloc[0] if "suite" in self.episodes else None
        return suite if isinstance(suite, str) else "classic"

    @property
    def is_submission(self) -> bool:
        return self.source != OWN_ENTRY

    @property
    def setting(self) -> str:
        """The file-name part shared with the leaderboard's figure of this row."""
        parts = "__".join(safe_name(self.row[name]) for name in ("layout", "baseline", "protocol"))
        return f"{parts}__k{self.row['n_agents']}"


def board_columns() -> list[tuple[str, str]]:
    """(key, title) of every column of a board, in order."""
    metrics = [(metric, title) for metric, (title, _) in COLUMNS.items()]
    return [
        ("layout", "layout"),
        ("complexity", "complexity"),
        ("baseline", "baseline"),
        ("policy", "policy"),
        ("protocol", "protocol"),
        ("k", "K"),
        ("entry", "entry"),
        ("episodes", "episodes"),
        ("distinct", "distinct episodes"),
        metrics[0],
        ("coverage_iqm", "coverage IQM"),
        *metrics[1:],
    ]


def board_row(entry: Entry, root: str) -> str:
    row = entry.row
    cells = [
        f'<td><a href="{root}{layout_page_name(row["layout"])}">{escape(row["layout"])}</a></td>',
        number_cell(
            row["complexity_normalized"],
            f"{row['complexity_normalized']:.4f}",
            f"normalised; total {row['complexity_total']:.2f}",
        ),
        f'<td><a href="{root}{baseline_page_name(row["baseline"])}">{escape(row["baseline"])}</a></td>',
        f"<td>{escape(row['policy'])}</td>",
        f"<td>{escape(row['protocol'])}</td>",
        number_cell(row["n_agents"], str(row["n_agents"])),
        f"<td>{escape(entry.source)}</td>",
        number_cell(row["episodes"], str(row["episodes"])),
        number_cell(row["distinct_episodes"], distinct_cell(row)),
        metric_cell(row["coverage"], COLUMNS["coverage"][1]),
        number_cell(row["coverage_iqm"], f"{row['coverage_iqm']:.3f}"),
        *(metric_cell(row[metric], form) for metric, (_, form) in COLUMNS.items() if metric != "coverage"),
    ]
    attributes = (
        f'data-protocol="{escape(row["protocol"])}" data-k="{row["n_agents"]}" '
        f'data-layout="{escape(row["layout"])}" data-entry="{"submission" if entry.is_submission else "own"}"'
    )
    marked = ' class="submission"' if entry.is_submission else ""
    return f"<tr{marked} {attributes}>" + "".join(cells) + "</tr>"


def board_table(entries: list[Entry], root: str) -> str:
    layouts = sorted({entry.row["layout"] for entry in entries})
    filters = board_filters(
        [entry.row["protocol"] for entry in entries], [int(e.row["n_agents"]) for e in entries]
    )
    filters.insert(2, filter_select("layout", "layout", [(value, value) for value in layouts]))
    return sortable_table(board_columns(), [board_row(entry, root) for entry in entries], filters)
