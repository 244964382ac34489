"""What ``cabinbench run`` prints when its episodes are done: a table of each metric's mean with its
95% interval over the distinct episodes (a suite run: the mean over layouts of per-layout means,
stratified bootstrap), the median wall time over every episode, and the files written; or with
``--json`` one JSON object with the same numbers and paths."""

from __future__ import annotations

import json
import math
import statistics
from pathlib import Path

from cabinbench.episodes import EpisodeResult
from cabinbench.metrics import METRICS, TEAM_METRICS
from cabinbench.records import RunWriter
from cabinbench.stats import Summary, distinct_episodes, summarize, summarize_cells

WALL_TIME = "wall_time"  # real seconds: summarised by their median over every episode, not as an outcome


def summary_metrics(record: dict) -> list[str]:
    """The metrics of a record that have one number per episode (not ``path_lengths``) and describe
    its outcome (not :data:`WALL_TIME`)."""
    names = [
        name for name in (*METRICS, *TEAM_METRICS) if name in record and name not in ("n_agents", WALL_TIME)
    ]
    return [name for name in names if record[name] is None or isinstance(record[name], (bool, int, float))]


def summarize_run(records: list[dict], layouts: list[str] | None = None) -> dict[str, Summary]:
    """Each metric's summary over the run's distinct episodes (a deterministic baseline from a
    fixed start repeats one episode: one unit, no interval). With ``layouts`` (each record's, a
    suite run) the mean over layouts of per-layout means, with the stratified bootstrap interval
    (layouts, and episodes within each, resampled), as the leaderboard's suites section gives it."""
    import pandas as pd

    frame = pd.DataFrame(records)
    if layouts is not None:
        frame["layout"] = layouts
    distinct = distinct_episodes(frame, within=("layout",) if layouts is not None else ())
    if layouts is None:
        rows = distinct.to_dict("records")
        return {name: summarize(name, [row[name] for row in rows]) for name in summary_metrics(records[0])}
    layouts = dict(list(distinct.groupby("layout", sort=True)))
    return {
        name: summarize_cells(
            name, {("run", layout): cell[name].tolist() for layout, cell in layouts.items()}
        )
        for name in summary_metrics(records[0])
    }


def wall_time(records: list[dict]) -> dict:
    """The median of every episode's :data:`WALL_TIME` (repeats of one outcome too: each is a timing
    of its own; the median, as the first episode's includes compiling the simulation's kernels)."""
    return {"median": statistics.median(record[WALL_TIME] for record in records), "n": len(records)}


def format_table(summaries: dict[str, Summary], title: str, seconds: dict) -> str:
    def number(value: float) -> str:
        return "n/a" if math.isnan(value) else f"{value:.4g}"

    lines = [title, f"{'metric':<18} {'mean':>10}   {'95% CI':<24} note", "-" * 64]
    for name, summary in summaries.items():
        interval = f"[{number(summary.low)}, {number(summary.high)}]"
        if summary.reached is not None:
            note = f"reached in {summary.n} distinct episodes ({summary.reached:.0%})"
        else:
            note = "one distinct episode: no interval" if summary.n == 1 else ""
        lines.append(f"{name:<18} {number(summary.mean):>10}   {interval:<24} {note}".rstrip())
    note = f"median of {seconds['n']} episodes, seconds (the first includes compilation)"
    lines.append(f"{WALL_TIME:<18} {number(seconds['median']):>10}   {'':<24} {note}")
    return "\n".join(lines)


def format_planned(planned: dict, summaries: dict[str, Summary]) -> str:
    """A path's planned figures (its static footprint sweep) beside the executed means."""
    rows = [
        ("coverage", planned["planned_coverage"], summaries["coverage"].mean),
        ("length (m)", planned["planned_length"], summaries["path_length"].mean),
        ("turning (rad)", planned["planned_turning"], summaries["rotation"].mean),
    ]
    lines = ["", f"{'plan (footprint sweep)':<30} {'planned':>10} {'executed':>10}"]
    lines += [f"{label:<30} {plan:>10.4g} {done:>10.4g}" for label, plan, done in rows]
    lines.append(f"{'turns':<30} {planned['planned_turns']:>10d}")
    lines.append(f"{'off the floor (m)':<30} {planned['planned_off_floor_length']:>10.4g}")
    lines.append(f"{'where the robot cannot be (m)':<30} {planned['planned_unreachable_length']:>10.4g}")
    return "\n".join(lines)


def report(
    args, name: str, finished: list[EpisodeResult], writers: list[RunWriter], planned: dict[str, dict]
) -> None:
    """The summary on stdout: a table, or with ``--json`` one JSON object (with ``--suite``,
    ``records`` and ``trajectories`` list one file per layout); a path's ``planned`` figures beside."""
    order = {job_layout: index for index, job_layout in enumerate(w.header["layout"] for w in writers)}
    finished = sorted(
        finished, key=lambda result: (order.get(result.record.get("layout"), 0), result.job.episode)
    )
    records = [result.record for result in finished]
    summaries = summarize_run(records, [result.job.layout for result in finished] if args.suite else None)
    render = str(args.render) if args.render else None
    paths = [str(writer.path) for writer in writers]
    trajectories = [str(writer.trajectory_path) for writer in writers]
    if args.json:
        print(
            json.dumps(
                {
                    "baseline": args.baseline,
                    "layout": None if args.suite else name,
                    "suite": args.suite and name,
                    "layouts": len(writers),
                    "protocol": args.protocol,
                    "n_agents": args.agents,
                    "episodes": len(records),
                    "records": paths if args.suite else paths[0],
                    "trajectories": trajectories if args.suite else trajectories[0],
                    "render": render,
                    "planned": (planned if args.suite else planned.get(name)) or None,
                    "metrics": {metric: summary.as_dict() for metric, summary in summaries.items()}
                    | {WALL_TIME: wall_time(records)},
                }
            )
        )
        return
    where = f"suite {name}, {len(writers)} layouts" if args.suite else name
    seeds = [result.job.episode_seed for result in finished]
    title = (
        f"{args.baseline} on {where} ({args.protocol}, K={args.agents}): {len(records)} episodes, "
        f"seeds {min(seeds)}..{max(seeds)}"
        + ("; mean over layouts of per-layout means, stratified bootstrap" if args.suite else "")
    )
    print(format_table(summaries, title, wall_time(records)))
    if planned and not args.suite:
        print(format_planned(planned[name], summaries))
    if args.suite:
        print(f"\nrecords: {len(paths)} files in {Path(paths[0]).parent} (trajectories beside them, .npz)")
    else:
        print(f"\nrecords: {paths[0]}\ntrajectories: {trajectories[0]}")
    if render:
        print(f"render: {render}")
