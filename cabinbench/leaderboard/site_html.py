"""The HTML pieces every page of the leaderboard site shares: the page template
(``site_files/page.html``), cells, figures, filters and the sortable table ``site.js`` works on."""

from __future__ import annotations

import hashlib
import html
from importlib.resources import files
from string import Template

import numpy as np

from cabinbench.leaderboard.table import markdown_cell
from cabinbench.records import safe_name


def escape(value) -> str:
    return html.escape(str(value), quote=True)


def page(title: str, body: str, root: str, nav: str, command: str) -> str:
    template = Template(
        files("cabinbench.leaderboard").joinpath("site_files", "page.html").read_text(encoding="utf-8")
    )
    return template.substitute(
        title=escape(title), body=body, root=root, nav=nav.replace("{root}", root), command=escape(command)
    )


def file_stem(name: str) -> str:
    """``name`` in a file name of the site: itself where it is one, else its safe form and a short hash of
    it, so that names differing only in the characters replaced (``my/cabin``, ``my-cabin``, ``my:cabin``)
    keep pages of their own."""
    safe = safe_name(name)
    if safe == name:
        return name
    return f"{safe}-{hashlib.sha256(name.encode('utf-8', 'surrogatepass')).hexdigest()[:8]}"


def layout_page_name(layout: str) -> str:
    return f"layouts/{file_stem(layout)}.html"


def baseline_page_name(baseline: str) -> str:
    return f"baselines/{file_stem(baseline)}.html"


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
