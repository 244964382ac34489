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
  figure (copied from the leaderboard's ``figures/``) and a replay of the stored trajectory (a layout
  whose file is not found here: the rows and a note saying how to find it);
- ``baselines/<baseline>.html``: what it is (its docstring, read without importing it), its
  entry point, configs, the versions and commits its records came from, its training curves.

Submissions (:mod:`cabinbench.leaderboard.submissions`) are rows like the others, marked with their status.
Images live once, in ``images/``. A name that a file name cannot hold (``my/cabin``, ``pkg.mod:Class``)
is written as its safe form and a short hash of it (``site_html.file_stem``): every name keeps its page.
This module writes the site; the pages are made by
:mod:`~cabinbench.leaderboard.site_pages` (index, layouts, baselines) and
:mod:`~cabinbench.leaderboard.site_suites` (suites), from the board rows of
:mod:`~cabinbench.leaderboard.site_board`, the HTML pieces of :mod:`~cabinbench.leaderboard.site_html`
and the "cite this" block of :mod:`~cabinbench.leaderboard.site_cite`.
"""

from __future__ import annotations

import shutil
from importlib.resources import files
from pathlib import Path

import pandas as pd

from cabinbench.errors import UsageError
from cabinbench.leaderboard.curves import CURVES_CAPTION, CURVES_FIGURE
from cabinbench.leaderboard.site_board import Entry
from cabinbench.leaderboard.site_cite import cite_block
from cabinbench.leaderboard.site_html import baseline_page_name, escape, figure_html, layout_page_name
from cabinbench.leaderboard.site_pages import baseline_page, index_page, layout_page
from cabinbench.leaderboard.site_suites import suite_file, suite_page
from cabinbench.leaderboard.table import csv_table
from cabinbench.records import safe_name

MARKER = ".cabinbench-site"  # a folder holding it was written by this module and may be rebuilt
ASSETS = ("style.css", "site.js")


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
    headline: str = "",
) -> list[Path]:
    """Write the site into ``out``; return its pages. ``entries``: the classic rows and every
    submission's; ``suites``: our records run in a suite other than ``classic``; ``headline``: the
    headline table's HTML, the first thing the site shows."""
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
    learning_curves = figures / CURVES_FIGURE
    if learning_curves.is_file():  # the learned baselines' learning curves, under the headline table
        shutil.copyfile(learning_curves, out / "images" / CURVES_FIGURE)
        headline += "<h2>Learning curves</h2>" + figure_html(
            f"images/{CURVES_FIGURE}", "learning curves", CURVES_CAPTION
        )
    written = [out / "index.html"]
    records = sum(len(entry.episodes) for entry in classic)
    written[-1].write_text(
        index_page("classic", classic, cite, records, command, nav, headline), encoding="utf-8"
    )
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
