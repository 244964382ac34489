"""Regenerate the leaderboard from the per-episode records: ``python -m cabinbench.leaderboard``.

    python -m cabinbench.leaderboard [--runs results/runs] [--ablation-runs results/ablation_runs]
        [--training results/training] [--submissions results/submissions] [--out results]
    python -m cabinbench.leaderboard --site DIR [--runs ...] [--out results]
    python -m cabinbench.leaderboard --add FILE | --verify FILE [--episodes N] [--seed S]

Reads every ``*.jsonl`` in ``--runs`` and ``--ablation-runs`` (default: ``ablation_runs`` beside
``--runs``), and the ``.npz`` beside each (see :mod:`cabinbench.records`), and writes, from those
files only, one report per module:

- ``<out>/leaderboard.md`` and ``<out>/leaderboard.csv`` (:mod:`cabinbench.leaderboard.table`):
  the records outside any suite, a row per training seed of a learned baseline (the shipped
  policy's episodes come from ``--runs``, the other seeds' from ``--ablation-runs``);
- the teams section of ``leaderboard.md`` and ``<out>/teams.csv`` (:mod:`cabinbench.leaderboard.teams`):
  coverage, makespan, load balance and contacts of every baseline run with several robots, by K;
- the suites section of ``leaderboard.md`` and its ``figures/suite__*.png``, from the records
  that carry a ``suite`` (:mod:`cabinbench.leaderboard.suites`; nothing when there are none);
- ``<out>/uncovered.md`` and ``<out>/uncovered.csv`` (:mod:`cabinbench.leaderboard.uncovered`);
- ``<out>/figures/``, the training curves of the shipped policies in ``--training`` among them
  (:mod:`cabinbench.leaderboard.figures`); the uncovered table and these figures are drawn per
  shipped policy;
- ``<out>/learning_curves.csv``, ``figures/learning_curves.png`` and the learning curves section of
  ``leaderboard.md``: every kept training run's validation against env steps, all its seeds
  (:mod:`cabinbench.leaderboard.curves`);
- ``<out>/ablation.md``, ``<out>/ablation.csv`` and ``figures/ablation_coverage.png``
  (:mod:`cabinbench.leaderboard.ablation`). The shipped policies' episodes come from ``--runs``.

The submissions filed in ``--submissions`` (default: ``submissions`` beside ``--runs``) are rows
of ``leaderboard.md`` and ``.csv`` too, their baseline marked ``(submission, <status>)``.

``--site DIR`` writes the static site instead (:mod:`cabinbench.leaderboard.site`), the classic
table and a board per suite, its figures copied from ``<out>/figures``. ``--add FILE`` checks a
submission and files it in ``--submissions``; ``--verify FILE`` replays ``--episodes`` of its
episodes (:mod:`cabinbench.leaderboard.submissions`).

Exit status 2, with one line on stderr, when ``--runs`` holds no records or a bad one, or a
submission is refused; 1 when a verification finds a metric that differs.
"""

from __future__ import annotations

import sys
from dataclasses import dataclass
from importlib.resources import files
from pathlib import Path

import pandas as pd

from cabinbench.cli import (
    ArgumentParser,
    checked_output,
    non_negative_int,
    output_folder,
    positive_int,
    user_errors,
    warnings_as_lines,
)
from cabinbench.errors import UsageError
from cabinbench.leaderboard.ablation import ablation_csv, ablation_figure, ablation_markdown, ablation_rows
from cabinbench.leaderboard.curves import write_learning_curves
from cabinbench.leaderboard.figures import training_figures, write_figures
from cabinbench.leaderboard.gap import gap_section
from cabinbench.leaderboard.headline import headline_csv, headline_html, headline_rows, headline_section
from cabinbench.leaderboard.site import Entry, build_site
from cabinbench.leaderboard.submissions import add, filed, status, verify
from cabinbench.leaderboard.suites import (
    classic,
    suite_records,
    suites_csv,
    suites_section,
)
from cabinbench.leaderboard.table import (
    csv_table,
    document_header,
    group_rows,
    markdown,
    mixed_settings,
    summarize_row,
    table_rows,
)
from cabinbench.leaderboard.teams import team_rows, teams_csv, teams_section
from cabinbench.leaderboard.uncovered import uncovered_csv, uncovered_markdown, uncovered_rows
from cabinbench.records import RecordWarning, read_records, with_current_complexity


@dataclass
class Inputs:
    """What the tables and the site are built from: the records of ``--runs`` and of
    ``--ablation-runs`` (``every``: both), grouped into the classic table's rows, and the filed
    submissions."""

    records: pd.DataFrame
    every: pd.DataFrame
    ablation_runs: str
    groups: list
    own: list
    submitted: list[Entry]
    notes: list[str]


def parse_args(argv: list[str] | None):
    parser = ArgumentParser(
        prog="python -m cabinbench.leaderboard",
        description="Regenerate the leaderboard tables and figures from the per-episode records.",
    )
    parser.add_argument("--runs", default="results/runs", help="folder of run records (default results/runs)")
    parser.add_argument(
        "--training",
        default="results/training",
        help="folder of shipped training records (default results/training)",
    )
    parser.add_argument(
        "--ablation-runs",
        help="folder of run records of further training runs' policies "
        "(default: ablation_runs beside --runs)",
    )
    # no type: with --site it is read, not written; the tables check it (checked_output)
    parser.add_argument(
        "--out",
        default="results",
        help="folder for leaderboard.{md,csv}, uncovered.{md,csv}, ablation.{md,csv} and figures/ "
        "(default results; with --site, where the figures are read from)",
    )
    parser.add_argument(
        "--submissions",
        help="folder of filed submissions (default: submissions beside --runs)",
    )
    action = parser.add_mutually_exclusive_group()
    action.add_argument("--site", type=output_folder, metavar="DIR", help="write the static site into DIR")
    action.add_argument("--add", metavar="FILE", help="check a submission and file it in --submissions")
    action.add_argument("--verify", metavar="FILE", help="replay a submission's episodes and compare")
    parser.add_argument(
        "--episodes",
        type=positive_int,
        help="with --verify: replay only this many, chosen at random (a partial replay verifies nothing; "
        "default: every episode)",
    )
    parser.add_argument(
        "--seed", type=non_negative_int, default=0, help="seed of --verify's choice of episodes (default 0)"
    )
    return parser.parse_args(argv)


def records_in(folder: str) -> pd.DataFrame:
    """The usable records of a folder (empty when it does not exist; a bad one is skipped with a
    warning), with each layout's complexity as it is now
    (:func:`~cabinbench.records.with_current_complexity`)."""
    if not Path(folder).is_dir():
        return pd.DataFrame()
    return with_current_complexity(read_records(folder))


def submission_entries(folder: Path) -> list[Entry]:
    """The rows of every filed submission, marked with its status."""
    entries = []
    for path, body in filed(folder):
        records = pd.DataFrame(body["records"]).assign(source=str(path))
        for key, episodes in group_rows(records):
            entries.append(Entry(summarize_row(key, episodes), episodes, f"submission, {status(path, body)}"))
    return entries


def submissions_folder(args) -> Path:
    return Path(args.submissions or Path(args.runs).parent / "submissions")


def submission_command(args) -> int:
    """``--add`` or ``--verify``."""
    if args.add:
        target = add(Path(args.add), submissions_folder(args))
        print(f"filed {args.add} as {target}; regenerate the leaderboard and the site to show it")
        return 0
    played, mismatches, total = verify(Path(args.verify), args.episodes, args.seed, submissions_folder(args))
    for line in mismatches:
        print(f"differs: {line}")
    if mismatches:
        verdict = "unverified: the replay differs"
    elif len(played) < total:
        verdict = (
            f"{len(played)} of {total} replayed, all matched; not verified: replay every episode "
            "(without --episodes) to verify"
        )
    else:
        verdict = f"verified: all {total} episodes replayed and matched"
    print(f"{verdict}; replayed {', '.join(played)}")
    return 1 if mismatches else 0


def read_inputs(args) -> Inputs:
    """The records and submissions the leaderboard is built from (a user error when there are none)."""
    if not Path(args.runs).is_dir():
        raise UsageError(f"--runs: no folder {args.runs}; give the folder of a run's records")
    records = records_in(args.runs)
    if records.empty:
        raise UsageError(f"--runs: no records in {args.runs}; run `python -m cabinbench.run ...` first")
    ablation_runs = Path(args.ablation_runs or Path(args.runs).parent / "ablation_runs").as_posix()
    further = records_in(ablation_runs)
    every = pd.concat([records, further], ignore_index=True) if not further.empty else records
    groups = group_rows(classic(records))
    notes = [note for key, episodes in groups for note in mixed_settings(key, episodes)]
    for note in notes:
        print(f"warning: {note}", file=sys.stderr)
    return Inputs(
        records,
        every,
        ablation_runs,
        groups,
        table_rows(classic(every), Path(args.training)),
        submission_entries(submissions_folder(args)),
        notes,
    )


def citation_file() -> Path:
    """``CITATION.cff`` of the working folder, else the copy the package ships (the repository's, which
    a test keeps identical), so that an installed cabinbench builds the site from any folder."""
    here = Path.cwd() / "CITATION.cff"
    return (
        here
        if here.is_file()
        else Path(str(files("cabinbench.leaderboard").joinpath("site_files", "CITATION.cff")))
    )


def write_site(args, inputs: Inputs, citation: Path) -> int:
    out = Path(args.out)
    command = f"python -m cabinbench.leaderboard --runs {args.runs} --out {out} --site DIR"
    entries = [Entry(row, episodes) for row, episodes in inputs.own] + inputs.submitted
    suites = suite_records(inputs.every)
    headline = headline_html(headline_rows(inputs.every, Path(args.training)))
    pages = build_site(
        args.site, entries, suites, out / "figures", Path(args.training), citation, command, headline
    )
    print(f"{len(entries)} rows, {len(pages)} pages: {args.site / 'index.html'}")
    return 0


def write_tables(args, inputs: Inputs, out: Path) -> int:
    """leaderboard.{md,csv}, teams.csv, uncovered.{md,csv}, learning_curves.csv and the figures."""
    table = [row for row, _ in inputs.own] + [
        {**entry.row, "baseline": f"{entry.row['baseline']} ({entry.source})"} for entry in inputs.submitted
    ]
    out.mkdir(parents=True, exist_ok=True)
    command = f"python -m cabinbench.leaderboard --runs {args.runs} --out {out}"
    sources = (
        f"`{args.runs}` (shipped policies) and `{inputs.ablation_runs}` (the other training seeds' policies)"
    )
    headline = headline_rows(inputs.every, Path(args.training))
    header = document_header(classic(inputs.every), sources, command)
    teams = team_rows(inputs.own)
    suite_text, suite_figures = suites_section(suite_records(inputs.every), out)
    suite_text += "\n".join(["", *gap_section(suite_records(inputs.every), Path(args.training))])
    curves_text, curves_figures = write_learning_curves(Path(args.training), out)
    (out / "leaderboard.md").write_text(
        header
        + headline_section(headline)
        + "\n"
        + curves_text
        + markdown(table, inputs.notes)
        + teams_section(teams)
        + suite_text,
        encoding="utf-8",
    )
    every_row = pd.concat([csv_table(table), suites_csv(suite_records(inputs.every))], ignore_index=True)
    every_row.to_csv(out / "leaderboard.csv", index=False, float_format="%.6g", lineterminator="\n")
    headline_csv(headline).to_csv(out / "headline.csv", index=False, float_format="%.6g", lineterminator="\n")
    if teams:
        teams_csv(teams).to_csv(out / "teams.csv", index=False, float_format="%.6g", lineterminator="\n")
    uncovered, uncovered_notes = uncovered_rows(inputs.groups)
    for note in uncovered_notes:
        print(f"warning: {note}", file=sys.stderr)
    (out / "uncovered.md").write_text(
        uncovered_markdown(uncovered, args.runs, command, uncovered_notes), encoding="utf-8"
    )
    uncovered_csv(uncovered).to_csv(
        out / "uncovered.csv", index=False, float_format="%.6g", lineterminator="\n"
    )
    rows = [summarize_row(key, episodes) for key, episodes in inputs.groups]
    figures = (
        (write_figures(inputs.groups, rows, out / "figures") if inputs.groups else [])  # none: all in suites
        + training_figures(Path(args.training), out / "figures")
        + suite_figures
        + curves_figures
    )
    print(
        f"{len(table)} rows from {len(inputs.every)} episodes: {out / 'leaderboard.md'}, "
        f"{out / 'leaderboard.csv'}, {len(figures)} figures in {out / 'figures'}"
    )
    write_ablation(args, inputs, out, command)
    return 0


def write_ablation(args, inputs: Inputs, out: Path, command: str) -> None:
    """ablation.{md,csv} and its figure, when some learned baseline has several training runs' records."""
    learned = ablation_rows(classic(inputs.every), Path(args.training))
    if not learned:
        return
    sources = f"`{args.runs}` (shipped policies) and `{inputs.ablation_runs}` (the others)"
    (out / "ablation.md").write_text(
        ablation_markdown(learned, sources, f"{command} --ablation-runs {inputs.ablation_runs}"),
        encoding="utf-8",
    )
    ablation_csv(learned).to_csv(out / "ablation.csv", index=False, float_format="%.6g", lineterminator="\n")
    ablation_figure(learned, out / "figures" / "ablation_coverage.png")
    print(
        f"{len(learned)} ablation rows: {out / 'ablation.md'}, {out / 'ablation.csv'}, "
        f"{out / 'figures' / 'ablation_coverage.png'}"
    )


@user_errors
def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    if args.add or args.verify:
        return submission_command(args)
    if args.episodes is not None:
        raise UsageError("--episodes goes with --verify")
    # what is written is checked before the records are read
    citation = citation_file() if args.site else None
    out = None if args.site else checked_output("--out", output_folder, args.out)
    with warnings_as_lines(RecordWarning):
        inputs = read_inputs(args)
    if args.site:
        return write_site(args, inputs, citation)
    return write_tables(args, inputs, out)
