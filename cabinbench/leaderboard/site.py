"""The leaderboard as a static web site: ``python -m cabinbench.leaderboard --site DIR``.

Plain HTML and CSS with a little JavaScript of our own (``cabinbench/leaderboard/site_files/``): no CDN, no
network fetch, so it works opened from ``file://`` and from any static host. From the records
only, and byte-identical from the same records (no timestamps, sorted everything):

- ``index.html``: the ``classic`` board: one row per (layout, baseline, protocol, K), with the
  numbers and intervals of :mod:`cabinbench.leaderboard.table` (the same functions as
  ``leaderboard.md``), sortable by any column and filterable by protocol, team size, layout and
  entry; the layouts' complexity; the "cite this" block (BibTeX and CFF from ``CITATION.cff``) and
  ``leaderboard.csv`` to download;
- ``suite__<name>.html`` for each other suite in the records: one row per (baseline, protocol, K)
  from :func:`~cabinbench.leaderboard.suites.suite_rows` (the suites section of ``leaderboard.md``),
  sortable and filterable the same way; the suite's complexity range, its three figures (copied
  from the leaderboard's ``figures/``) and the complexity finding. No page per suite layout;
- ``layouts/<layout>.html``: the layout's picture and complexity map, and per row its trajectory
  figure (copied from the leaderboard's ``figures/``) and a replay of the stored trajectory;
- ``baselines/<baseline>.html``: what it is (its docstring, read without importing it), its
  entry point, configs, the versions and commits its records came from, its training curves.

Submissions (:mod:`cabinbench.leaderboard.submissions`) are rows like the others, marked with their status.
Images live once, in ``images/``.
"""

from __future__ import annotations

import ast
import html
import importlib.util
import json
import shutil
from dataclasses import dataclass
from importlib.resources import files
from pathlib import Path
from string import Template

import numpy as np
import pandas as pd
import yaml
from PIL import Image

from cabinbench.agents import registered_baselines
from cabinbench.errors import LayoutError, UsageError
from cabinbench.layouts.complexity import layout_complexity, save_complexity_png
from cabinbench.layouts.fields import RESOLUTION
from cabinbench.layouts.load import available_layouts
from cabinbench.layouts.resolve import load_layout
from cabinbench.layouts.suites import get_suite
from cabinbench.layouts.suites import summary as suite_summary
from cabinbench.leaderboard.suites import SCORES, complexity_rows, finding, suite_rows
from cabinbench.leaderboard.table import (
    COLUMNS,
    csv_table,
    distinct_cell,
    layout_complexity_of,
    markdown_cell,
    stored_run,
)
from cabinbench.records import safe_name
from cabinbench.sim.render import draw_frame, frame_scale
from cabinbench.sim.world import World

MARKER = ".cabinbench-site"  # a folder holding it was written by this module and may be rebuilt
REPLAY_FRAMES = 240  # at most this many positions per robot in a replay: keeps pages small
OWN_ENTRY = "cabinbench"  # the entry column of rows recorded by results/make_results.sh
ASSETS = ("style.css", "site.js")


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


def escape(value) -> str:
    return html.escape(str(value), quote=True)


def page(title: str, body: str, root: str, nav: str, command: str) -> str:
    template = Template(
        files("cabinbench.leaderboard").joinpath("site_files", "page.html").read_text(encoding="utf-8")
    )
    return template.substitute(
        title=escape(title), body=body, root=root, nav=nav.replace("{root}", root), command=escape(command)
    )


def layout_page_name(layout: str) -> str:
    return f"layouts/{safe_name(layout)}.html"


def baseline_page_name(baseline: str) -> str:
    return f"baselines/{safe_name(baseline)}.html"


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


def code(text: str) -> str:
    return f"<code>{escape(text)}</code>"


def figure_html(source: str, alt: str, caption: str) -> str:
    return (
        f'<figure><img src="{source}" alt="{escape(alt)}"><figcaption>{escape(caption)}</figcaption></figure>'
    )


def number_cell(value: float, text: str, title: str = "") -> str:
    sort = "" if np.isnan(value) else repr(float(value))
    hint = f' title="{escape(title)}"' if title else ""
    return f'<td class="num" data-sort="{sort}"{hint}>{escape(text)}</td>'


def metric_cell(summary, number_format: str) -> str:
    """The Markdown leaderboard's cell, with the exact interval as a tooltip and the mean to sort by."""
    title = ""
    if not np.isnan(summary.low):
        title = f"95% CI [{summary.low:{number_format}}, {summary.high:{number_format}}], n = {summary.n}"
    return number_cell(summary.mean, markdown_cell(summary, number_format), title)


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


def filter_select(name: str, title: str, values) -> str:
    options = '<option value="">all</option>' + "".join(
        f'<option value="{escape(value)}">{escape(label)}</option>' for value, label in values
    )
    return f'<label>{title}<select data-filter="{name}">{options}</select></label>'


def board_filters(entries_protocols, teams) -> list[str]:
    """The protocol, team size and entry filters every board has."""
    return [
        filter_select("protocol", "protocol", [(value, value) for value in sorted(set(entries_protocols))]),
        filter_select("k", "team size K", [(str(value), str(value)) for value in sorted(set(teams))]),
        filter_select("entry", "entry", [("own", "cabinbench runs"), ("submission", "submissions")]),
    ]


def sortable_table(columns: list[tuple[str, str]], rows: list[str], filters: list[str]) -> str:
    """A board: filters, the count of rows shown, and a table that ``site.js`` sorts by any column."""
    headers = "".join(f'<th data-key="{key}">{escape(title)}</th>' for key, title in columns)
    return (
        f'<p class="filters">{"".join(filters)}'
        f'<span id="shown">{len(rows)}</span> of {len(rows)} rows shown</p>'
        f'<table class="board"><thead><tr>{headers}</tr></thead>\n<tbody>\n'
        + "\n".join(rows)
        + "\n</tbody></table>"
    )


def board_table(entries: list[Entry], root: str) -> str:
    layouts = sorted({entry.row["layout"] for entry in entries})
    filters = board_filters(
        [entry.row["protocol"] for entry in entries], [int(e.row["n_agents"]) for e in entries]
    )
    filters.insert(2, filter_select("layout", "layout", [(value, value) for value in layouts]))
    return sortable_table(board_columns(), [board_row(entry, root) for entry in entries], filters)


def bibtex(citation: dict) -> str:
    """BibTeX entries for CITATION.cff: the software, then each reference (the dissertation)."""

    def authors(people: list[dict]) -> str:
        names = [
            person.get("name") or f"{person.get('family-names', '')}, {person.get('given-names', '')}"
            for person in people
        ]
        return " and ".join(
            f"{{{name}}}" if "name" in person else name for name, person in zip(names, people)
        )

    entries = [
        "@software{cabinbench,\n"
        f"  title = {{{citation['title']}}},\n"
        f"  author = {{{authors(citation.get('authors', []))}}},\n"
        f"  version = {{{citation.get('version', '')}}},\n"
        f"  license = {{{citation.get('license', '')}}},\n"
        f"  note = {{{citation.get('message', '')}}}\n"
        "}"
    ]
    for index, reference in enumerate(citation.get("references", [])):
        kind = "phdthesis" if reference.get("type") == "thesis" else "misc"
        family = reference["authors"][0].get("family-names", "ref")
        key = f"{safe_name(family).lower()}{reference.get('year', '')}"
        fields = [
            ("title", reference.get("title")),
            ("author", authors(reference.get("authors", []))),
            ("school", reference.get("institution", {}).get("name")),
            ("year", reference.get("year")),
            ("type", reference.get("thesis-type")),
        ]
        body = ",\n".join(f"  {name} = {{{value}}}" for name, value in fields if value)
        entries.append(f"@{kind}{{{key if index == 0 else f'{key}_{index}'},\n{body}\n}}")
    return "\n\n".join(entries) + "\n"


def cite_block(citation_path: Path) -> tuple[str, str]:
    """(the HTML block, the BibTeX text) for ``CITATION.cff``."""
    if not citation_path.is_file():
        raise UsageError(f"--site: no {citation_path} here; run from the repository root")
    text = citation_path.read_text(encoding="utf-8")
    bib = bibtex(yaml.safe_load(text))
    block = (
        '<h2 id="cite">Cite this</h2><p>If you use cabinbench or its leaderboard, cite it '
        '(<a href="cabinbench.bib">cabinbench.bib</a>, <a href="CITATION.cff">CITATION.cff</a>):</p>'
        f"<pre>{escape(bib)}</pre><details><summary>CITATION.cff</summary><pre>{escape(text)}</pre></details>"
    )
    return block, bib


def docstring(target: str) -> str:
    """The first paragraph of a ``module:Class``'s docstring (else its module's), read from the
    source without importing it (a learned baseline imports torch); empty when not installed."""
    module, _, name = target.partition(":")
    top = importlib.util.find_spec(module.split(".")[0])
    if top is None or not top.submodule_search_locations and "." in module:
        return ""
    base = Path(top.origin).parent if top.submodule_search_locations else Path(top.origin)
    parts = module.split(".")[1:]
    candidates = [base.joinpath(*parts).with_suffix(".py"), base.joinpath(*parts, "__init__.py"), base]
    source = next((path for path in candidates if path.is_file()), None)
    if source is None:
        return ""
    tree = ast.parse(source.read_text(encoding="utf-8"))
    classes = [node for node in tree.body if isinstance(node, ast.ClassDef) and node.name == name]
    text = (ast.get_docstring(classes[0]) if classes else None) or ast.get_docstring(tree) or ""
    return text.split("\n\n")[0]


def distinct(episodes: pd.DataFrame, column: str) -> list[str]:
    values = episodes[column] if column in episodes else []
    return sorted(
        {json.dumps(value, sort_keys=True) if not isinstance(value, str) else value for value in values}
    )


def baseline_page(baseline: str, entries: list[Entry], images: dict[str, str], command: str, nav: str) -> str:
    target = registered_baselines().get(baseline, baseline if ":" in baseline else "")
    episodes = pd.concat([entry.episodes for entry in entries], ignore_index=True)
    about = docstring(target) if target else ""
    body = [
        f"<h1>{escape(baseline)}</h1>",
        f"<p>{escape(about)}</p>"
        if about
        else '<p class="note">No description: the baseline is not installed here.</p>',
        "<table>",
        f"<tr><th>entry point</th><td><code>{escape(target or 'not installed here')}</code></td></tr>",
        *(
            f"<tr><th>{title}</th><td>{'<br>'.join(map(code, distinct(episodes, column)))}</td></tr>"
            for column, title in (
                ("baseline_config", "config"),
                ("env_config", "env config"),
                ("benchmark_version", "cabinbench version"),
                ("git_commit", "code commit"),
            )
        ),
        "</table>",
        "<h2>Rows</h2>",
        board_table(entries, "../"),
    ]
    if baseline in images:
        body += [
            "<h2>Training curves</h2>",
            f'<figure><img src="../{images[baseline]}" alt="training curves of {escape(baseline)}"></figure>',
        ]
    return page(baseline, "\n".join(body), "../", nav, command)


def replay_data(entry: Entry, layout, scale: int) -> dict | None:
    """The first episode's stored positions for the replay (None when the row has no trajectories:
    a submission)."""
    if entry.is_submission:
        return None
    first = entry.episodes.iloc[0]
    positions = stored_run(first["source"]).episodes[int(first["episode"])]["positions"]
    keep = np.unique(
        np.linspace(0, len(positions) - 1, min(REPLAY_FRAMES, len(positions))).round().astype(int)
    )
    robots = [np.round(positions[keep, robot], 2).ravel().tolist() for robot in range(positions.shape[1])]
    return {
        "origin": list(layout.origin),
        "scale": scale / RESOLUTION,
        "radius": layout.robot.radius,
        "frames": len(keep),
        "robots": robots,
    }


def layout_page(name: str, entries: list[Entry], figures: Path, out: Path, command: str, nav: str) -> str:
    layout = load_layout(available_layouts().get(name, name))
    world = World(layout)
    world.reset(np.random.default_rng(0))  # the start pose is fixed; the generator is unused
    picture = f"images/layout__{safe_name(name)}.png"
    scale = frame_scale(world)
    Image.fromarray(draw_frame(world, scale=scale)).save(out / picture)
    complexity = f"images/complexity__{safe_name(name)}.png"
    save_complexity_png(layout_complexity(layout), str(out / complexity), title=name)
    hashes = {hash_ for entry in entries for hash_ in entry.episodes["layout_hash"]}
    stale = (
        f'<p class="note">The records were made with layout file(s) {", ".join(sorted(hashes))}; the file '
        "shipped now "
        f"is {layout.content_hash}.</p>"
        if hashes != {layout.content_hash}
        else ""
    )
    body = [
        f"<h1>{escape(name)}</h1>",
        stale,
        figure_html(f"../{picture}", f"layout {name}", "the layout (start pose, cells, goals)"),
        figure_html(
            f"../{complexity}", f"complexity of {name}", "navigation complexity per robot-sized cell"
        ),
        "<h2>Rows</h2>",
        board_table(entries, "../"),
        "<h2>Trajectories</h2><p>The first episode of each row (lowest seed). Click a replay to play it.</p>",
    ]
    for index, entry in enumerate(entries):
        caption = (
            f"{entry.row['baseline']}, {entry.row['protocol']}, K={entry.row['n_agents']} ({entry.source})"
        )
        figure = figures / f"trajectory__{entry.setting}.png"
        if figure.exists():
            target = f"images/{figure.name}"
            shutil.copyfile(figure, out / target)
            body.append(figure_html(f"../{target}", "trajectory", caption))
        data = replay_data(entry, layout, scale)
        if data is not None:
            body.append(
                f'<figure><canvas data-replay="replay{index}" data-picture="../{picture}"></canvas>'
                f"<figcaption>replay: {escape(caption)}</figcaption></figure>"
                f'<script type="application/json" id="replay{index}">'
                f"{json.dumps(data, separators=(',', ':'))}</script>"
            )
    return page(name, "\n".join(body), "../", nav, command)


def index_page(suite: str, entries: list[Entry], cite: str, records: int, command: str, nav: str) -> str:
    own = [entry for entry in entries if not entry.is_submission]
    versions = sorted({str(version) for entry in own for version in entry.episodes["benchmark_version"]})
    layouts = sorted(
        {
            (entry.row["layout"], entry.row["complexity_normalized"], entry.row["complexity_total"])
            for entry in entries
        }
    )
    layout_rows = "".join(
        f'<tr><td><a href="{layout_page_name(name)}">{escape(name)}</a></td>'
        f'<td class="num">{normalized:.4f}</td>'
        f'<td class="num">{total:.2f}</td></tr>'
        for name, normalized, total in layouts
    )
    body = [
        f"<h1>cabinbench leaderboard: {escape(suite)}</h1>",
        f"<p>{len(entries)} rows from {records} episodes; "
        f"benchmark version {escape(', '.join(versions) or 'n/a')}. "
        "Cells are <code>mean ± half-width of the 95% percentile-bootstrap interval</code> over episodes "
        "(hover a cell for the exact bounds; a lone episode has no interval). IQM: interquartile mean. "
        "t90: mean over the episodes that reached 90% coverage [the fraction that did]. "
        "Distinct episodes: episodes with the same outcome count once (a deterministic baseline repeats "
        "one). Policy: a learned baseline's training seed, a row each and one over all seeds. "
        "Complexity: the layout's normalised navigation complexity (the study §4.1). "
        "Click a column title to sort by it. Entries marked as submissions were sent in (see the README); "
        '"verified (N)" means N of its episodes were replayed here and matched. '
        '<a href="leaderboard.csv">Download the table (CSV)</a>.</p>',
        board_table(entries, "")
        if entries
        else '<p class="note">No records outside a suite: see the suites\' boards (the links above).</p>',
        "<h2>Layouts</h2><table><thead><tr><th>layout</th><th>complexity (normalised)</th>"
        "<th>complexity (total)</th>"
        f"</tr></thead><tbody>{layout_rows}</tbody></table>",
        cite,
    ]
    return page(f"leaderboard: {suite}", "\n".join(body), "", nav, command)


def suite_columns() -> list[tuple[str, str]]:
    """(key, title) of every column of a suite's board, in order."""
    scores = [(metric, metric.replace("_", " ") + (" (s)" if metric == "time" else "")) for metric in SCORES]
    return [
        ("baseline", "baseline"),
        ("protocol", "protocol"),
        ("k", "K"),
        ("entry", "entry"),
        ("seeds", "training seeds"),
        ("layouts", "layouts"),
        ("episodes", "episodes"),
        ("distinct", "distinct episodes"),
        scores[0],
        ("coverage_iqm", "coverage IQM"),
        *scores[1:],
        ("success", "success [Wilson]"),
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
            finding_text = finding(complexity_rows(found, episodes))
    every = pd.concat([episodes for _, episodes in boards], ignore_index=True)
    protocols, teams = every["protocol"], every["n_agents"].astype(int)
    body = [
        f"<h1>cabinbench leaderboard: suite {escape(suite)}</h1>",
        f"<p>{len(rows)} rows from {len(every)} episodes on {every['layout'].nunique()} layouts. "
        "Scores: the mean over layouts (and training seeds) of per-layout means ± half-width of the "
        "stratified bootstrap 95% interval (layouts, training seeds and episodes resampled; hover a cell "
        "for the exact bounds); IQM over the per-(seed, layout) means; success with its Wilson interval "
        "over distinct episodes; t90 reached: the fraction of episodes that reached 90% coverage. "
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


def site_csv(entries: list[Entry]) -> str:
    if not entries:  # every record is in a suite: the classic table is empty
        return ""
    table = csv_table([entry.row for entry in entries])
    table.insert(table.columns.get_loc("n_agents") + 1, "entry", [entry.source for entry in entries])
    return table.to_csv(index=False, float_format="%.6g", lineterminator="\n")


def prepare(out: Path) -> None:
    """An empty ``out``: a folder this module wrote before is emptied, any other must be empty."""
    if out.exists() and not out.is_dir():
        raise UsageError(f"--site: {out} is a file; give a folder")
    if out.exists() and any(out.iterdir()):
        if not (out / MARKER).exists():
            raise UsageError(f"--site: {out} holds other files; give an empty folder or a site built before")
        shutil.rmtree(out)
    for folder in ("images", "layouts", "baselines"):
        (out / folder).mkdir(parents=True, exist_ok=True)
    (out / MARKER).write_text("written by python -m cabinbench.leaderboard --site; rebuilt on each build\n")


def build_site(
    out: Path,
    entries: list[Entry],
    suites: pd.DataFrame,
    figures: Path,
    training: Path,
    citation: Path,
    command: str,
) -> list[Path]:
    """Write the site into ``out``; return its pages. ``entries``: the classic rows and every
    submission's; ``suites``: our records run in a suite other than ``classic``."""
    prepare(out)
    for asset in ASSETS:
        (out / asset).write_bytes(files("cabinbench.leaderboard").joinpath("site_files", asset).read_bytes())
    classic = [entry for entry in entries if entry.suite == "classic"]
    in_suites = [entry for entry in entries if entry.suite != "classic"]
    names = sorted(
        (set(suites["suite"]) if not suites.empty else set()) | {entry.suite for entry in in_suites}
    )
    pages = {"classic": "index.html"} | {suite: suite_file(suite, "html") for suite in names}
    nav = "".join(f'<a href="{{root}}{target}">{escape(suite)}</a>' for suite, target in pages.items())
    cite, bib = cite_block(citation)
    shutil.copyfile(citation, out / "CITATION.cff")
    (out / "cabinbench.bib").write_text(bib, encoding="utf-8")
    (out / "leaderboard.csv").write_text(site_csv(classic), encoding="utf-8")
    written = [out / "index.html"]
    records = sum(len(entry.episodes) for entry in classic)
    written[-1].write_text(index_page("classic", classic, cite, records, command, nav), encoding="utf-8")
    baselines = sorted({entry.row["baseline"] for entry in classic})
    for suite in names:
        own = suites[suites["suite"] == suite] if not suites.empty else suites
        submitted = [entry for entry in in_suites if entry.suite == suite]
        written.append(out / pages[suite])
        text = suite_page(suite, own, submitted, figures, out, set(baselines), nav, command)
        written[-1].write_text(text, encoding="utf-8")
    for name in sorted({entry.row["layout"] for entry in classic}):
        rows = [entry for entry in classic if entry.row["layout"] == name]
        written.append(out / layout_page_name(name))
        written[-1].write_text(layout_page(name, rows, figures, out, command, nav), encoding="utf-8")
    curves = {}
    for baseline in baselines:
        figure = figures / f"training__{safe_name(baseline)}.png"
        if (training / baseline / "metrics.csv").exists() and figure.exists():
            curves[baseline] = f"images/{figure.name}"
            shutil.copyfile(figure, out / curves[baseline])
        rows = [entry for entry in classic if entry.row["baseline"] == baseline]
        written.append(out / baseline_page_name(baseline))
        written[-1].write_text(baseline_page(baseline, rows, curves, command, nav), encoding="utf-8")
    return written
