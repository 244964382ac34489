"""The leaderboard site: rebuilt byte for byte from the same records, the committed copy current, and,
opened from file:// in a real headless Chromium, tables that hold the records' numbers, sorting and
filters that work, and no picture or link that fails to resolve."""

import csv
import os
import shutil
import subprocess
import tempfile
from html.parser import HTMLParser
from pathlib import Path
from urllib.parse import unquote, urlsplit

import pytest

from cabinbench.commands import leaderboard, run
from cabinbench.leaderboard.site import Entry, build_site
from cabinbench.leaderboard.site_board import board_columns
from cabinbench.leaderboard.site_suites import suite_columns
from cabinbench.leaderboard.table import group_rows, summarize_row
from cabinbench.records import read_records

ROOT = Path(__file__).resolve().parents[1]
CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
needs_chromium = pytest.mark.skipif(
    CHROMIUM is None, reason="no chromium binary (Debian: apt-get install chromium; .ci/run installs it)"
)
FLAGS = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
]
SETTINGS = [("random_bounce", "sequential"), ("boustrophedon", "sequential"), ("boustrophedon", "open")]
SUITE = "cabin-v1-test"
SUITE_BASELINES = ("random_bounce", "boustrophedon")


def build(runs, out, site) -> None:
    with pytest.MonkeyPatch.context() as patch:
        patch.chdir(ROOT)  # the site cites the repository's CITATION.cff
        assert leaderboard.main(["--runs", str(runs), "--out", str(out), "--site", str(site)]) == 0


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    """(the leaderboard's output folder, the site) of a few short runs on one layout, and two
    baselines' short runs on the first three layouts of a suite."""
    root = tmp_path_factory.mktemp("site")
    for baseline, protocol in SETTINGS:
        arguments = [
            "--baseline",
            baseline,
            "--layout",
            "a320_cell",
            "--protocol",
            protocol,
            "--episodes",
            "3",
        ]
        assert run.main([*arguments, "--max-steps", "150", "--out", str(root / "runs")]) == 0
    for baseline in SUITE_BASELINES:
        suite = ["--suite", SUITE, "--layouts", "3", "--max-steps", "40", "--episodes-per-layout", "2"]
        assert run.main(["--baseline", baseline, *suite, "--out", str(root / "runs")]) == 0
    assert leaderboard.main(["--runs", str(root / "runs"), "--out", str(root / "results")]) == 0
    build(root / "runs", root / "results", root / "site")
    return root / "results", root / "site"


def tree(folder: Path) -> dict[str, bytes]:
    return {
        str(path.relative_to(folder)): path.read_bytes()
        for path in sorted(folder.rglob("*"))
        if path.is_file()
    }


def test_the_site_is_rebuilt_byte_identically(built, tmp_path):
    results, site = built
    build(results.parent / "runs", results, tmp_path / "again")
    assert tree(tmp_path / "again") == tree(site)


def test_the_committed_site_is_what_the_records_give_now(tmp_path):
    build("results/runs", "results", tmp_path / "site")  # as make_results.sh names them: they are on the page
    built, committed = tree(tmp_path / "site"), tree(ROOT / "results" / "site")
    assert sorted(built) == sorted(committed)
    stale = [name for name in built if built[name] != committed[name]]
    assert not stale, (
        f"results/site is stale ({stale}): run python -m cabinbench.leaderboard --site results/site"
    )


class Page(HTMLParser):
    """The rows of a page's board (attributes, cell texts, sort values) and every address it names."""

    def __init__(self):
        super().__init__()
        self.rows, self.addresses, self.broken, self.cell = [], [], 0, None

    def handle_starttag(self, tag, attributes):
        attributes = dict(attributes)
        if tag == "tr" and "data-protocol" in attributes:
            self.rows.append({"attributes": attributes, "cells": [], "sort": []})
        elif tag == "td" and self.rows and self.cell is None:
            self.cell = ""
            self.rows[-1]["sort"].append(attributes.get("data-sort"))
        for name in ("src", "href", "data-picture"):
            if attributes.get(name):
                self.addresses.append(attributes[name])
        if tag == "img" and "broken" in (attributes.get("class") or ""):
            self.broken += 1

    def handle_data(self, data):
        if self.cell is not None:
            self.cell += data

    def handle_endtag(self, tag):
        if tag == "td" and self.cell is not None:
            self.rows[-1]["cells"].append(self.cell.strip())
            self.cell = None

    @property
    def shown(self) -> list[dict]:
        return [row for row in self.rows if "hidden" not in row["attributes"]]


def chromium(*arguments: str) -> subprocess.CompletedProcess:
    with tempfile.TemporaryDirectory() as profile:
        return subprocess.run(
            [CHROMIUM, *FLAGS, f"--user-data-dir={profile}", *arguments],
            capture_output=True,
            text=True,
            timeout=120,
            env={**os.environ, "HOME": profile},
        )


def rendered(path: Path, fragment: str = "") -> Page:
    """The DOM of a page after Chromium loaded it from file:// and ran its script."""
    completed = chromium("--virtual-time-budget=3000", "--dump-dom", path.as_uri() + fragment)
    assert completed.returncode == 0 and "<table" in completed.stdout or "<main>" in completed.stdout, (
        completed.stderr[-2000:]
    )
    page = Page()
    page.feed(completed.stdout)
    return page


def column(page: Page, title: str, rows: list[dict] | None = None, columns=board_columns) -> list:
    index = [key for key, _ in columns()].index(title)
    return [row["sort"][index] for row in (page.shown if rows is None else rows)]


@needs_chromium
def test_the_index_shows_the_records_numbers(built):
    results, site = built
    page = rendered(site / "index.html")
    with open(results / "leaderboard.csv", newline="") as file:
        table = [line for line in csv.DictReader(file) if not line["suite"]]  # the suites' rows follow
    assert len(page.shown) == len(table) == len(SETTINGS)
    for row, line in zip(page.shown, table):
        assert (row["attributes"]["data-protocol"], row["cells"][2]) == (line["protocol"], line["baseline"])
        assert row["cells"][7] == line["episodes"]
        assert row["cells"][9].startswith(f"{float(line['coverage_mean']):.3f}")
        assert float(column(page, "coverage", [row])[0]) == pytest.approx(float(line["coverage_mean"]), 1e-5)


@needs_chromium
def test_sorting_reorders_the_rows_and_filters_hide_rows(built):
    _, site = built
    index = site / "index.html"
    ascending = [float(value) for value in column(rendered(index, "#sort=coverage&dir=asc"), "coverage")]
    descending = [float(value) for value in column(rendered(index, "#sort=coverage&dir=desc"), "coverage")]
    assert ascending == sorted(ascending) and descending == sorted(descending, reverse=True)
    assert ascending != descending  # the settings differ in coverage: sorting moved rows
    baselines = [row["cells"][2] for row in rendered(index, "#sort=baseline&dir=desc").shown]
    assert baselines == sorted(baselines, reverse=True)
    page = rendered(index, "#protocol=open")
    assert [row["attributes"]["data-protocol"] for row in page.shown] == ["open"]
    assert len(page.rows) == len(SETTINGS)  # hidden, not removed
    assert rendered(index, "#entry=submission").shown == []


@needs_chromium
def test_every_picture_and_link_of_every_page_resolves(built, tmp_path):
    _, site = built
    pages = sorted(site.rglob("*.html"))
    assert {path.relative_to(site).as_posix() for path in pages} >= {
        "index.html",
        "layouts/a320_cell.html",
        "baselines/random_bounce.html",
        "baselines/boustrophedon.html",
        f"suite__{SUITE}.html",
    }
    assert not list((site / "layouts").glob(f"{SUITE}*")), "a suite's layouts have no pages"
    for path in pages:
        page = rendered(path)
        assert page.broken == 0, f"{path}: a picture did not load"
        for address in page.addresses:
            parts = urlsplit(address)
            assert not parts.scheme and not parts.netloc, f"{path}: {address} is not a file of the site"
            if parts.path:
                assert (path.parent / unquote(parts.path)).resolve().is_file(), (
                    f"{path}: {address} is missing"
                )
    screenshot = tmp_path / "index.png"
    completed = chromium(
        "--window-size=1400,900", f"--screenshot={screenshot}", (site / "index.html").as_uri()
    )
    assert completed.returncode == 0 and screenshot.stat().st_size > 10_000, completed.stderr[-2000:]


CLICKS = """<script>
// Clicks as a user makes them, after the site's script: the coverage title twice, then the protocol filter.
const order = () => Array.from(document.querySelectorAll("table.board tbody tr"))
  .filter((row) => !row.hidden).map((row) => row.dataset.protocol + ":" + row.cells[2].textContent).join(",");
const later = (step) => new Promise((done) => setTimeout(() => { step(); done(); }, 50));
(async () => {
  const title = document.querySelector('th[data-key="coverage"]');
  await later(() => title.click());
  await later(() => { document.body.dataset.first = order(); title.click(); });
  await later(() => {
    document.body.dataset.second = order();
    const select = document.querySelector('select[data-filter="protocol"]');
    select.value = "open";
    select.dispatchEvent(new Event("change"));
  });
  await later(() => { document.body.dataset.filtered = order(); });
})();
</script>
</body>"""


class Body(HTMLParser):
    def handle_starttag(self, tag, attributes):
        if tag == "body":
            self.attributes = dict(attributes)


@needs_chromium
def test_clicking_a_column_title_sorts_and_choosing_a_filter_filters(built, tmp_path):
    """The site's own script driven by clicks in the browser (a copy of the index, a few clicks added)."""
    _, site = built
    copy = tmp_path / "site"
    shutil.copytree(site, copy)
    clicked = copy / "clicked.html"
    clicked.write_text((copy / "index.html").read_text().replace("</body>", CLICKS))
    completed = chromium("--virtual-time-budget=5000", "--dump-dom", clicked.as_uri())
    body = Body()
    body.feed(completed.stdout)
    coverage = {row: float(value) for row, value in zip(*order_and_coverage(rendered(copy / "index.html")))}
    first, second = body.attributes["data-first"].split(","), body.attributes["data-second"].split(",")
    assert [coverage[row] for row in first] == sorted(coverage.values())
    assert [coverage[row] for row in second] == sorted(coverage.values(), reverse=True)
    assert body.attributes["data-filtered"] == "open:boustrophedon"


def order_and_coverage(page: Page) -> tuple[list[str], list]:
    rows = [f"{row['attributes']['data-protocol']}:{row['cells'][2]}" for row in page.shown]
    return rows, column(page, "coverage")


def suite_markdown_row(results: Path, baseline: str) -> list[str]:
    """The cells of a baseline's row in the suites section of ``leaderboard.md``."""
    board = (results / "leaderboard.md").read_text()
    part = board[board.index(f"#### Suite `{SUITE}`") :]
    line = next(line for line in part.splitlines() if line.startswith(f"| {baseline} | sequential | 1 |"))
    return [cell.strip() for cell in line.strip("|").split("|")]


@needs_chromium
def test_the_suite_page_shows_the_suite_statistics(built):
    """One row per (baseline, protocol, K) of the suite's records, with the numbers of the suites
    section of leaderboard.md, the suite's complexity, figures and finding; the index links to it."""
    results, site = built
    records = read_records(results.parent / "runs")
    records = records[records["suite"] == SUITE]
    page = rendered(site / f"suite__{SUITE}.html")
    assert sorted(row["cells"][0] for row in page.shown) == sorted(SUITE_BASELINES)
    for row in page.shown:
        baseline = row["cells"][0]
        episodes = records[records["baseline"] == baseline]
        # baseline, protocol, K, entry, seeds, layouts, episodes
        assert row["cells"][1:7] == ["sequential", "1", "cabinbench", "1", "3", str(len(episodes))]
        expected = episodes.groupby("layout")["coverage"].mean().mean()  # the mean of per-layout means
        coverage = column(page, "coverage", [row], suite_columns)[0]
        assert float(coverage) == pytest.approx(expected, 1e-9)
        markdown = suite_markdown_row(results, baseline)  # seeds, layouts, ..., t90 reached
        assert row["cells"][4:] == markdown[3:]
    with open(site / f"suite__{SUITE}.csv", newline="") as file:
        table = {line["baseline"]: line for line in csv.DictReader(file)}
    for row in page.shown:
        line = table[row["cells"][0]]
        assert (line["layouts"], line["episodes"]) == (row["cells"][5], row["cells"][6])
        coverage = float(column(page, "coverage", [row], suite_columns)[0])
        assert float(line["coverage_mean"]) == pytest.approx(coverage, 1e-5)
    text = (site / f"suite__{SUITE}.html").read_text()
    assert "too few layouts" in text  # three layouts: no test of complexity
    assert "on the 3 layouts run" in text and "layouts of the suite (its manifest)" in text
    for kind in ("profiles", "improvement", "complexity"):
        assert f'src="images/suite__{SUITE}__{kind}.png"' in text
    assert f'href="suite__{SUITE}.html"' in (site / "index.html").read_text()
    assert not any(SUITE in row["cells"][0] for row in rendered(site / "index.html").rows)


@needs_chromium
def test_the_suite_page_sorts_and_filters(built):
    _, site = built
    suite = site / f"suite__{SUITE}.html"
    for key in ("coverage", "path_efficiency"):
        ascending = [
            float(value)
            for value in column(rendered(suite, f"#sort={key}&dir=asc"), key, None, suite_columns)
        ]
        descending = [
            float(value)
            for value in column(rendered(suite, f"#sort={key}&dir=desc"), key, None, suite_columns)
        ]
        assert ascending == sorted(ascending) and descending == ascending[::-1]
    baselines = [row["cells"][0] for row in rendered(suite, "#sort=baseline&dir=desc").shown]
    assert baselines == sorted(SUITE_BASELINES, reverse=True)
    assert rendered(suite, "#protocol=open").shown == []
    assert len(rendered(suite, "#k=1").shown) == len(SUITE_BASELINES)


@needs_chromium
def test_a_suite_submission_is_a_row_of_the_suite_board(built, tmp_path):
    """A submission's suite records (as ``leaderboard`` makes its entries: per layout, marked) become
    rows of the suite's board beside ours, scored the same way; they get no layout pages."""
    results, _ = built
    records = leaderboard.records_in(str(results.parent / "runs"))
    ours = records[records["suite"] == SUITE]
    submitted = [
        Entry(summarize_row(key, episodes), episodes.assign(source="sent.json"), "submission, unverified")
        for key, episodes in group_rows(ours)
    ]
    site = tmp_path / "site"
    with pytest.MonkeyPatch.context() as patch:
        patch.chdir(ROOT)
        build_site(site, submitted, ours, results / "figures", results, Path("CITATION.cff"), "test")
    page = rendered(site / f"suite__{SUITE}.html")
    assert [row["cells"][3] for row in page.rows] == ["cabinbench"] * 2 + ["submission, unverified"] * 2
    assert page.rows[0]["cells"][4:] == page.rows[2]["cells"][4:]  # the same records, the same numbers
    shown = rendered(site / f"suite__{SUITE}.html", "#entry=submission").shown
    assert [row["attributes"]["class"] for row in shown] == ["submission"] * 2
    assert not list((site / "layouts").glob("*"))
    assert "No records outside a suite" in (site / "index.html").read_text()
