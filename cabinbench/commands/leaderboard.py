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
from pathlib import Path

import pandas as pd

from cabinbench.cli import ArgumentParser, non_negative_int, output_folder, positive_int, user_errors
from cabinbench.errors import UsageError
from cabinbench.leaderboard.ablation import ablation_csv, ablation_figure, ablation_markdown, ablation_rows
from cabinbench.leaderboard.figures import training_figures, write_figures
from cabinbench.leaderboard.site import Entry, build_site
from cabinbench.leaderboard.submissions import add, filed, status, verify
from cabinbench.leaderboard.suites import classic, suite_records, suites_section
from cabinbench.leaderboard.table import (
    csv_table,
    group_rows,
    markdown,
    mixed_settings,
    summarize_row,
    table_rows,
)
from cabinbench.leaderboard.teams import team_rows, teams_csv, teams_section
from cabinbench.leaderboard.uncovered import uncovered_csv, uncovered_markdown, uncovered_rows
from cabinbench.records import read_records, with_current_complexity


def records_in(folder: str, option: str) -> pd.DataFrame:
    """The records of a folder (empty when it does not exist), with each layout's complexity as it is
    now (:func:`~cabinbench.records.with_current_complexity`); a bad record is a user error."""
    if not Path(folder).is_dir():
        return pd.DataFrame()
    try:
        return with_current_complexity(read_records(folder))
    except ValueError as error:
        raise UsageError(f"{option}: {error}; fix or remove that file") from None


def submission_entries(folder: Path) -> list[Entry]:
    """The rows of every filed submission, marked with its status."""
    entries = []
    for path, body in filed(folder):
        records = pd.DataFrame(body["records"]).assign(source=str(path))
        for key, episodes in group_rows(records):
            entries.append(Entry(summarize_row(key, episodes), episodes, f"submission, {status(path, body)}"))
    return entries


def submission_command(args) -> int:
    """``--add`` or ``--verify``."""
    folder = Path(args.submissions or Path(args.runs).parent / "submissions")
    if args.add:
        target = add(Path(args.add), folder)
        print(f"filed {args.add} as {target}; regenerate the leaderboard and the site to show it")
        return 0
    played, mismatches = verify(Path(args.verify), args.episodes, args.seed, folder)
    for line in mismatches:
        print(f"differs: {line}")
    verdict = "unverified: the replay differs" if mismatches else f"verified ({len(played)})"
    print(f"{verdict}; replayed {', '.join(played)}")
    return 1 if mismatches else 0


@user_errors
def main(argv: list[str] | None = None) -> int:
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
    parser.add_argument(
        "--out",
        type=output_folder,
        default="results",
        help="folder for leaderboard.{md,csv}, uncovered.{md,csv}, ablation.{md,csv} and figures/ "
        "(default results)",
    )
    parser.add_argument(
        "--submissions",
        help="folder of filed submissions (default: submissions beside --runs)",
    )
    action = parser.add_mutually_exclusive_group()
    action.add_argument("--site", type=output_folder, metavar="DIR", help="write the static site into DIR")
    action.add_argument("--add", metavar="FILE", help="check a submission and file it in --submissions")
    action.add_argument("--verify", metavar="FILE", help="replay episodes of a submission and compare")
    parser.add_argument(
        "--episodes", type=positive_int, default=3, help="episodes --verify replays (default 3)"
    )
    parser.add_argument(
        "--seed", type=non_negative_int, default=0, help="seed of --verify's choice of episodes (default 0)"
    )
    args = parser.parse_args(argv)
    if args.add or args.verify:
        return submission_command(args)
    if not Path(args.runs).is_dir():
        raise UsageError(f"--runs: no folder {args.runs}; give the folder of a run's records")
    records = records_in(args.runs, "--runs")
    if records.empty:
        raise UsageError(f"--runs: no records in {args.runs}; run `python -m cabinbench.run ...` first")
    ablation_runs = Path(args.ablation_runs or Path(args.runs).parent / "ablation_runs").as_posix()
    further = records_in(ablation_runs, "--ablation-runs")
    every = pd.concat([records, further], ignore_index=True) if not further.empty else records
    training = Path(args.training)
    groups = group_rows(classic(records))
    rows = [summarize_row(key, episodes) for key, episodes in groups]
    notes = [note for key, episodes in groups for note in mixed_settings(key, episodes)]
    for note in notes:
        print(f"warning: {note}", file=sys.stderr)
    submitted = submission_entries(Path(args.submissions or Path(args.runs).parent / "submissions"))
    own = table_rows(classic(every), training)
    out = args.out
    if args.site:
        command = f"python -m cabinbench.leaderboard --runs {args.runs} --out {out} --site DIR"
        entries = [Entry(row, episodes) for row, episodes in own] + submitted
        suites = suite_records(every)
        if not suites.empty:  # the classic suite's records are the index's rows
            suites = suites[suites["suite"] != "classic"]
        pages = build_site(
            args.site, entries, suites, out / "figures", Path(args.training), Path("CITATION.cff"), command
        )
        print(f"{len(entries)} rows, {len(pages)} pages: {args.site / 'index.html'}")
        return 0
    table = [row for row, _ in own] + [
        {**entry.row, "baseline": f"{entry.row['baseline']} ({entry.source})"} for entry in submitted
    ]

    out.mkdir(parents=True, exist_ok=True)
    command = f"python -m cabinbench.leaderboard --runs {args.runs} --out {out}"
    sources = f"`{args.runs}` (shipped policies) and `{ablation_runs}` (the other training seeds' policies)"
    text = markdown(table, classic(every), sources, command, notes)
    teams = team_rows(own)
    suite_text, suite_figures = suites_section(suite_records(every), out)
    (out / "leaderboard.md").write_text(text + teams_section(teams) + suite_text, encoding="utf-8")
    csv_table(table).to_csv(out / "leaderboard.csv", index=False, float_format="%.6g", lineterminator="\n")
    if teams:
        teams_csv(teams).to_csv(out / "teams.csv", index=False, float_format="%.6g", lineterminator="\n")
    uncovered, uncovered_notes = uncovered_rows(groups)
    for note in uncovered_notes:
        print(f"warning: {note}", file=sys.stderr)
    (out / "uncovered.md").write_text(
        uncovered_markdown(uncovered, args.runs, command, uncovered_notes), encoding="utf-8"
    )
    uncovered_csv(uncovered).to_csv(
        out / "uncovered.csv", index=False, float_format="%.6g", lineterminator="\n"
    )
    figures = (
        (write_figures(groups, rows, out / "figures") if groups else [])  # none when every run is in a suite
        + training_figures(training, out / "figures")
        + suite_figures
    )
    print(
        f"{len(table)} rows from {len(every)} episodes: {out / 'leaderboard.md'}, "
        f"{out / 'leaderboard.csv'}, {len(figures)} figures in {out / 'figures'}"
    )
    learned = ablation_rows(classic(every), training)
    if learned:
        sources = f"`{args.runs}` (shipped policies) and `{ablation_runs}` (the others)"
        (out / "ablation.md").write_text(
            ablation_markdown(learned, sources, f"{command} --ablation-runs {ablation_runs}"),
            encoding="utf-8",
        )
        ablation_csv(learned).to_csv(
            out / "ablation.csv", index=False, float_format="%.6g", lineterminator="\n"
        )
        ablation_figure(learned, out / "figures" / "ablation_coverage.png")
        print(
            f"{len(learned)} ablation rows: {out / 'ablation.md'}, {out / 'ablation.csv'}, "
            f"{out / 'figures' / 'ablation_coverage.png'}"
        )
    return 0
