"""A suite's page of the leaderboard site: one row per (baseline, protocol, K) from
:func:`~cabinbench.leaderboard.suites.suite_rows`, its complexity range, figures and finding, and its
table as CSV. No page per suite layout: a suite has hundreds."""

from __future__ import annotations

import shutil
from pathlib import Path

import pandas as pd

from cabinbench.errors import LayoutError
from cabinbench.layouts.suites import get_suite
from cabinbench.layouts.suites import summary as suite_summary
from cabinbench.leaderboard.predictors import predictor_finding
from cabinbench.leaderboard.site_board import OWN_ENTRY, Entry
from cabinbench.leaderboard.site_html import (
    baseline_page_name,
    board_filters,
    escape,
    figure_html,
    metric_cell,
    number_cell,
    page,
    sortable_table,
)
from cabinbench.leaderboard.suites import SCORES, complexity_tests, suite_rows
from cabinbench.leaderboard.table import layout_complexity_of, markdown_cell
from cabinbench.records import safe_name


def suite_columns() -> list[tuple[str, str]]:
    """(key, title) of every column of a suite's board, in order."""
    titles = {"clean_score": "score", "time": "time (s)"}
    scores = [
        (metric, titles.get(metric, metric.replace("_", " "))) for metric in SCORES if metric != "coverage"
    ]
    return [
        ("baseline", "baseline"),
        ("protocol", "protocol"),
        ("k", "K"),
        ("entry", "entry"),
        ("seeds", "training seeds"),
        ("layouts", "layouts"),
        ("episodes", "episodes"),
        ("distinct", "distinct episodes"),
        ("coverage", "coverage"),
        ("coverage_iqm", "coverage IQM"),
        *scores,
        ("success", "cleaned"),
        ("t90_reached", "t90 reached"),
    ]


def suite_board_row(row: dict, source: str, linked: set[str]) -> str:
    """One row of :func:`~cabinbench.leaderboard.suites.suite_rows`, its cells as in ``leaderboard.md``."""
    name = escape(row["baseline"])
    if row["baseline"] in linked:
        name = f'<a href="{baseline_page_name(row["baseline"])}">{name}</a>'
    cells = [
        f"<td>{name}</td>",
        f"<td>{escape(row['protocol'])}</td>",
        number_cell(row["n_agents"], str(row["n_agents"])),
        f"<td>{escape(source)}</td>",
        *(
            number_cell(row[key], str(row[key]))
            for key in ("policies", "layouts", "episodes", "distinct_episodes")
        ),
        metric_cell(row["coverage"], SCORES["coverage"]),
        number_cell(row["coverage_iqm"], f"{row['coverage_iqm']:.3f}"),
        *(metric_cell(row[metric], form) for metric, form in SCORES.items() if metric != "coverage"),
        number_cell(row["success"].mean, markdown_cell(row["success"], ".2f", bounds=True)),
        number_cell(row["t90_reached"], f"{row['t90_reached']:.0%}"),
    ]
    entry = "own" if source == OWN_ENTRY else "submission"
    attributes = f'data-protocol="{escape(row["protocol"])}" data-k="{row["n_agents"]}" data-entry="{entry}"'
    marked = ' class="submission"' if entry == "submission" else ""
    return f"<tr{marked} {attributes}>" + "".join(cells) + "</tr>"


def complexity_range(suite: str, records: pd.DataFrame) -> str:
    """The normalised (and total) navigation complexity's range over the layouts run, and over the
    whole suite as its manifest lists it (when this cabinbench still ships the suite)."""
    run = [layout_complexity_of(group) for _, group in records.groupby("layout", sort=True)]

    def span(low_high: list[float], total: list[float]) -> str:
        return f"{low_high[0]:.4f}–{low_high[1]:.4f} (total {total[0]:.2f}–{total[1]:.2f})"

    def bounds(key: str) -> list[float]:
        return [min(value[key] for value in run), max(value[key] for value in run)]

    text = f"on the {len(run)} layouts run, {span(bounds('normalized'), bounds('total'))}"
    try:
        shipped = suite_summary(get_suite(suite))
    except LayoutError:
        return text + f"; this cabinbench does not ship suite {escape(suite)}"
    return (
        text + f"; over all {shipped['size']} layouts of the suite (its manifest), "
        f"{span(shipped['complexity_normalized'], shipped['complexity_total'])}"
    )


def suite_page(
    suite: str,
    records: pd.DataFrame,
    submitted: list[Entry],
    figures: Path,
    out: Path,
    linked: set[str],
    nav: str,
    command: str,
) -> str:
    """A suite's board: one row per (baseline, protocol, K) from :func:`suite_rows` (the suites
    section of ``leaderboard.md``), its submissions' rows after ours, its complexity, figures and
    finding. No page per layout: a suite has hundreds."""
    boards = [(OWN_ENTRY, records)] if not records.empty else []
    per_file: dict[tuple[str, str], list[pd.DataFrame]] = {}
    for entry in submitted:
        per_file.setdefault((entry.source, entry.episodes["source"].iloc[0]), []).append(entry.episodes)
    boards += [
        (source, pd.concat(frames, ignore_index=True)) for (source, _), frames in sorted(per_file.items())
    ]
    rows, scored, notes, finding_text = [], [], [], ""
    for source, episodes in boards:
        found, left_out = suite_rows(episodes)
        rows += [suite_board_row(row, source, linked) for row in found]
        scored += [(row, source) for row in found]
        notes += left_out
        if source == OWN_ENTRY:
            finding_text = predictor_finding(complexity_tests(found, episodes)[0], suite)
    every = pd.concat([episodes for _, episodes in boards], ignore_index=True)
    protocols, teams = every["protocol"], every["n_agents"].astype(int)
    body = [
        f"<h1>cabinbench leaderboard: suite {escape(suite)}</h1>",
        f"<p>{len(rows)} rows from {len(every)} episodes on {every['layout'].nunique()} layouts. "
        "Scores: the mean over layouts of per-layout means ± half-width of the 95% interval (one policy: a "
        "stratified bootstrap over layouts and episodes; several training seeds: a t interval over the "
        "seeds' own scores; hover a cell for the exact bounds); IQM over the per-(seed, layout) means; "
        "success (the floor cleaned) with its interval; t90 reached: the fraction of episodes that "
        "reached 90% coverage. "
        "Click a column title to sort by it. The suite's layouts: "
        f"<code>python -m cabinbench.suites --png {escape(suite)} FILE</code> draws them. "
        f'<a href="{suite_file(suite, "csv")}">Download the table (CSV)</a>.</p>',
        f"<p>Navigation complexity (normalised, the study §4.1) {complexity_range(suite, every)}.</p>",
        sortable_table(suite_columns(), rows, board_filters(protocols, teams)),
    ]
    if notes:
        body.append("<ul>" + "".join(f'<li class="note">{escape(note)}</li>' for note in notes) + "</ul>")
    body.append(
        f"<h2>Does complexity predict difficulty?</h2><p>{escape(finding_text)}</p>" if finding_text else ""
    )
    captions = {
        "profiles": "performance profiles: the fraction of layouts above each level",
        "improvement": "probability of improvement P(X > Y) on coverage",
        "complexity": "navigation complexity against difficulty, one point per layout",
    }
    for kind, caption in captions.items():
        figure = figures / f"suite__{safe_name(suite)}__{kind}.png"
        if figure.exists():
            shutil.copyfile(figure, out / "images" / figure.name)
            body.append(figure_html(f"images/{figure.name}", f"{suite}: {kind}", caption))
    (out / suite_file(suite, "csv")).write_text(suite_csv(scored), encoding="utf-8")
    return page(f"leaderboard: {suite}", "\n".join(body), "", nav, command)


def suite_file(suite: str, extension: str) -> str:
    return f"suite__{safe_name(suite)}.{extension}"


def suite_csv(scored: list[tuple[dict, str]]) -> str:
    """A suite board's rows as CSV: every mean with its interval's bounds."""
    table = []
    for row, source in scored:
        line = {"baseline": row["baseline"], "protocol": row["protocol"], "n_agents": row["n_agents"]}
        line |= {"entry": source} | {key: row[key] for key in ("policies", "layouts", "episodes")}
        line["distinct_episodes"] = row["distinct_episodes"]
        for metric in [*SCORES, "success"]:
            summary = row[metric]
            line |= {f"{metric}_mean": summary.mean, f"{metric}_ci_low": summary.low}
            line[f"{metric}_ci_high"] = summary.high
        line |= {"coverage_iqm": row["coverage_iqm"], "t90_reached": row["t90_reached"]}
        table.append(line)
    return pd.DataFrame(table).to_csv(index=False, float_format="%.6g", lineterminator="\n")
