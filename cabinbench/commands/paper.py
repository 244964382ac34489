"""Build the benchmark paper: ``python -m cabinbench.paper [--results results] [--out paper/paper.md]``.

Fills ``paper/template.md``'s placeholders from generated material only: ``{{layouts_table}}``
from the built-in layout files (size, cells, areas, complexity; never a user's
``CABINBENCH_LAYOUT_PATH``), ``{{leaderboard_table}}``, ``{{ablation_table}}`` and
``{{uncovered_table}}`` from ``results/leaderboard.md``, ``ablation.md`` and ``uncovered.md``
(generated from the run records by ``python -m cabinbench.leaderboard``), ``{{figures}}``
from ``results/figures/``, and ``{{reproduction_table}}``, the study's claims against ours, from
the layouts, the records in ``results/runs`` and the training configurations
(:mod:`cabinbench.paper.reproduction`). Nothing in the paper's tables is typed by hand; the same inputs give a
byte-identical paper. A missing input is a user error: one line, exit status 2.

``--random-motion`` writes ``<results>/random_motion.md`` instead (the random-motion gap of §5.2.3,
tested: :mod:`cabinbench.paper.random_motion`) from the records of ``scripts/random_motion.sh``.
"""

from __future__ import annotations

import os
import re
from functools import cache
from pathlib import Path

from cabinbench.cli import ArgumentParser, checked_output, output_file, user_errors, warnings_as_lines
from cabinbench.errors import UsageError
from cabinbench.layouts.complexity import layout_summary
from cabinbench.layouts.load import builtin_layout_dir
from cabinbench.layouts.resolve import load_layout
from cabinbench.leaderboard.headline import HEADLINE_SUITES, headline_markdown, headline_rows
from cabinbench.leaderboard.predictors import predictor_finding
from cabinbench.leaderboard.suites import complexity_tests, suite_rows
from cabinbench.paper.random_motion import write_report
from cabinbench.paper.reproduction import reproduction_table
from cabinbench.paper.summary import abstract, compute_table, figure_caption, findings
from cabinbench.records import RecordWarning, read_records, with_current_complexity

DEFAULT_OUT = "paper/paper.md"


def layouts_table() -> str:
    lines = [
        "| layout | kind | size (m) | cells | goals | free m² | coverable m² | complexity (total) "
        "| complexity (normalized) |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for path in sorted(builtin_layout_dir().glob("*.yaml")):
        row = layout_summary(load_layout(path))
        lines.append(
            f"| `{row['name']}` | {row['kind']} | {row['size_m'][0]:.2f} × {row['size_m'][1]:.2f} | "
            f"{row['cells']} | {row['goals']} | {row['free_area_m2']:.2f} | {row['coverable_area_m2']:.2f} | "
            f"{row['complexity_total']:.4f} | {row['complexity_normalized']:.4f} |"
        )
    return "\n".join(lines)


def generated_table(path: Path) -> str:
    """A generated table file without its title (the paper has its own headings); a note if it is missing."""
    if not path.is_file():
        return f"(no `{path.name}` yet: run `python -m cabinbench.leaderboard`)"
    text = path.read_text(encoding="utf-8")
    return "\n".join(line for line in text.splitlines() if not line.startswith("# ")).strip()


def figures(results: Path, paper_dir: Path) -> str:
    """Every leaderboard figure with its caption, numbered."""
    entries = []
    for number, path in enumerate(sorted((results / "figures").glob("*.png")), start=1):
        relative = Path(os.path.relpath(path, paper_dir)).as_posix()
        entries.append(f"![{path.stem}]({relative})\n\n*Figure {number}. {figure_caption(path.stem)}*")
    return "\n\n".join(entries) if entries else "(no figures yet)"


def headline_inputs(results: Path) -> tuple[list[dict], str]:
    """The headline rows (runs and the other training seeds' runs) and the complexity finding on the
    test suite."""
    records = read_records(
        [folder for folder in (results / "runs", results / "ablation_runs") if folder.is_dir()]
    )
    rows = headline_rows(records, results / "training")
    test = records[records["suite"] == HEADLINE_SUITES[0]] if "suite" in records else records.iloc[0:0]
    finding = (
        predictor_finding(complexity_tests(suite_rows(test)[0], test)[0], HEADLINE_SUITES[0])
        if len(test)
        else ""
    )
    return rows, finding


def build(template: Path, results: Path, out: Path) -> str:
    """The paper: ``template`` with every placeholder filled; one nothing fills is a user error."""
    text = template.read_text(encoding="utf-8")
    headline = cache(lambda: headline_inputs(results))
    fillers = {
        "{{abstract}}": lambda: abstract(*headline()),
        "{{findings}}": lambda: "\n".join(f"- {sentence}" for sentence in findings(headline()[0])),
        "{{headline_table}}": lambda: headline_markdown(headline()[0]),
        "{{complexity_finding}}": lambda: headline()[1],
        "{{compute_table}}": lambda: compute_table(headline()[0]),
        "{{layouts_table}}": layouts_table,
        "{{leaderboard_table}}": lambda: generated_table(results / "leaderboard.md"),
        "{{ablation_table}}": lambda: generated_table(results / "ablation.md"),
        "{{uncovered_table}}": lambda: generated_table(results / "uncovered.md"),
        "{{figures}}": lambda: figures(results, out.parent),
        "{{reproduction_table}}": lambda: reproduction_table(
            with_current_complexity(read_records(results / "runs")), results
        ),
    }
    unknown = sorted(set(re.findall(r"\{\{[^{}]*\}\}", text)) - set(fillers))
    if unknown:
        raise UsageError(
            f"--template: {template} has the placeholder(s) {', '.join(unknown)}, which nothing fills; "
            f"use {', '.join(fillers)}"
        )
    for placeholder, fill in fillers.items():
        text = text.replace(placeholder, fill())
    return text


@user_errors
def main(argv: list[str] | None = None) -> int:
    parser = ArgumentParser(
        prog="python -m cabinbench.paper", description="Build paper/paper.md from the template and results/."
    )
    parser.add_argument("--template", default="paper/template.md")
    parser.add_argument("--results", default="results")
    # no string default: argparse would check it before an unknown option, and report the wrong mistake
    parser.add_argument("--out", type=output_file(".md"), help=f"the paper to write (default: {DEFAULT_OUT})")
    parser.add_argument(
        "--random-motion",
        action="store_true",
        help="write <results>/random_motion.md from <results>/random_motion/ instead of the paper",
    )
    args = parser.parse_args(argv)
    if args.random_motion:
        print(f"wrote {write_report(Path(args.results))}")
        return 0
    out = args.out or checked_output("--out", output_file(".md"), DEFAULT_OUT)
    results, template = Path(args.results), Path(args.template)
    if not (results / "leaderboard.md").is_file():
        raise UsageError(
            f"--results: {results / 'leaderboard.md'} is missing; "
            "run `python -m cabinbench.leaderboard` first"
        )
    if not template.is_file():
        raise UsageError(f"--template: no file {template}; give the paper's template (paper/template.md)")
    with warnings_as_lines(RecordWarning):
        text = build(template, results, out)
    out.write_text(text, encoding="utf-8")
    print(f"wrote {out}")
    return 0
