"""Evaluate a baseline on a layout: ``python -m cabinbench.run --baseline NAME --layout NAME``.

    python -m cabinbench.run --baseline NAME|pkg.mod:Class --layout NAME|FILE.yaml
        [--episodes N] [--seed S] [--agents K] [--protocol sequential|open]
        [--reward PRESET] [--max-steps N] [--config JSON] [--out DIR]
        [--render FILE.png|FILE.gif] [--json] [--workers N] [--executor local|ray [--address A]]

Plays N independent episodes (episode i is seeded with S + i), appends one record per finished
episode to ``DIR/<layout>__<baseline>__<protocol>__k<K>__seed<S>-<time>.jsonl`` (trajectories
in the sibling ``.npz``; format in :mod:`cabinbench.records`) and prints a table of per-metric
means with 95% bootstrap intervals, or with ``--json`` one JSON object with the same numbers and
the paths written. ``DIR`` defaults to the working folder ``runs/``: the committed
``results/runs`` are written by ``results/make_results.sh`` alone. ``--render`` draws the first
episode: a PNG of its final state (trajectory over the map, covered area shaded: the seed's
Fig. 5.11) or an animated GIF. ``--reward`` takes a preset of :mod:`cabinbench.rewards`.
Episodes run in this process, in ``--workers`` local processes, or with ``--executor ray`` as Ray
tasks on the cluster at ``--address`` (or a local Ray instance); the records are the same.

Exit status: 0 done; 1 some episodes failed because their worker died (one line each on stderr;
the others are recorded); 2 a user mistake, in one line on stderr, before any episode is played
(unknown baseline or layout: the valid names are given; settings the baseline does not take;
more robots than the layout's start cell holds; a file or folder that cannot be written; Ray not
installed, or no cluster at ``--address``); 130
interrupted by Ctrl-C (finished episodes are kept, and the message counts them on disk and says
where).
"""

from __future__ import annotations

import contextlib
import inspect
import json
import math
import sys
from pathlib import Path

from PIL import Image
from tqdm import tqdm

from .agents import Baseline, baseline_class, load_baseline
from .cli import (
    EXIT_INTERRUPTED,
    ArgumentParser,
    UsageError,
    json_object,
    non_negative_int,
    output_file,
    output_folder,
    positive_int,
    user_errors,
)
from .episodes import EpisodeJob, EpisodeResult, run_jobs
from .executors import EXECUTOR_NAMES, Executor, JobFailure, executors
from .layout import load_layout
from .metrics import METRICS, TEAM_METRICS
from .records import RunWriter, run_header, run_path
from .rewards import REWARD_PRESETS
from .stats import Summary, summarize
from .world import PROTOCOLS, start_poses

GIF_FRAMES = 100  # frames spread over the step limit; the GIF stops early if the episode does
GIF_FRAME_MS = 80
DEFAULT_OUT = "runs"  # a working folder: results/runs is written by results/make_results.sh only


def parse_args(argv: list[str] | None):
    parser = ArgumentParser(
        prog="python -m cabinbench.run",
        description="Evaluate a baseline on a layout; record every episode and summarise the metrics.",
    )
    parser.add_argument(
        "--baseline",
        required=True,
        help="a registered baseline (entry-point group cabinbench.baselines), or package.module:Class",
    )
    parser.add_argument(
        "--layout", required=True, help="a layout name (python -m cabinbench.layouts) or a YAML file"
    )
    parser.add_argument("--episodes", type=positive_int, default=5, help="episodes to play (default 5)")
    parser.add_argument(
        "--seed", type=non_negative_int, default=0, help="base seed; episode i uses seed + i (default 0)"
    )
    parser.add_argument("--agents", type=positive_int, default=1, help="robots in the team, K (default 1)")
    parser.add_argument(
        "--protocol", choices=PROTOCOLS, default="sequential", help="cell by cell, or the whole layout open"
    )
    parser.add_argument(
        "--reward",
        choices=list(REWARD_PRESETS),
        default="paper",
        help="reward preset (learned baselines see it)",
    )
    parser.add_argument(
        "--max-steps", type=positive_int, default=None, help="step limit per episode (default: the layout's)"
    )
    parser.add_argument(
        "--config", type=json_object, default={}, metavar="JSON", help="baseline settings as a JSON object"
    )
    parser.add_argument(
        "--out",
        type=output_folder,
        default=DEFAULT_OUT,
        help=f"folder for the records, created if need be (default {DEFAULT_OUT}/, a working folder)",
    )
    parser.add_argument(
        "--render",
        metavar="FILE",
        type=output_file(".png", ".gif"),
        help="draw the first episode to FILE.png or animate it to FILE.gif",
    )
    parser.add_argument("--json", action="store_true", help="print one JSON object instead of the table")
    parser.add_argument(
        "--workers", type=positive_int, default=1, help="episodes played in parallel by a local process pool"
    )
    parser.add_argument(
        "--executor",
        choices=EXECUTOR_NAMES,
        default="local",
        help="local: this process or --workers processes; ray: Ray tasks (pip install 'cabinbench[ray]')",
    )
    parser.add_argument(
        "--address",
        help="with --executor ray: the cluster to run on ('auto' or HOST:PORT; default a local Ray instance)",
    )
    return parser.parse_args(argv)


def make_executor(args) -> Executor:
    """The executor of ``--executor``, started (a user error if it cannot be)."""
    if args.executor == "local":
        if args.address is not None:
            raise UsageError("--address: only --executor ray runs on a cluster")
        return executors()["local"](args.workers)
    if args.workers != 1:
        raise UsageError(
            "--workers: the local executor's; Ray runs as many episodes at once as the cluster has CPUs"
        )
    # The working folder goes with the jobs: layout files and plugin baselines named relative to it resolve.
    return executors()["ray"](address=args.address, working_dir=str(Path.cwd()))


def baseline_settings(cls: type) -> set[str] | None:
    """The settings (constructor keywords) a baseline class takes, or None when it takes any. A
    constructor's ``**config`` passes the rest on to the next class's; :class:`Baseline`'s only
    records the settings of its subclasses and takes none of its own."""
    names: set[str] = set()
    for klass in cls.__mro__:
        if "__init__" not in vars(klass):
            continue
        if klass in (Baseline, object):
            return names
        parameters = list(inspect.signature(klass.__init__).parameters.values())[1:]  # after self
        names |= {p.name for p in parameters if p.kind in (p.POSITIONAL_OR_KEYWORD, p.KEYWORD_ONLY)}
        if not any(p.kind is p.VAR_KEYWORD for p in parameters):
            return names
    return None


def check_settings(spec: str, config: dict) -> None:
    """Refuse settings the baseline does not take (one that forwards them would silently ignore them)."""
    settings = baseline_settings(baseline_class(spec))
    unknown = sorted(set(config) - settings) if settings is not None else []
    if unknown:
        takes = ", ".join(sorted(settings)) if settings else "no settings"
        raise UsageError(f"--config: baseline {spec!r} does not take {', '.join(unknown)}; it takes {takes}")


def collect(results, writer: RunWriter, total: int) -> tuple[list[EpisodeResult], list[JobFailure]]:
    """Write each finished episode as it comes; return them, and the jobs whose worker died."""
    finished, failed = [], []
    try:
        with tqdm(total=total, unit="episode", file=sys.stderr, dynamic_ncols=True) as progress:
            for result in results:
                progress.update()
                if isinstance(result, JobFailure):
                    failed.append(result)
                    continue
                writer.write(result.job.episode, result.record, result.trajectory)
                finished.append(result)
                progress.set_postfix(coverage=f"{result.record['coverage']:.3f}")
    finally:
        if hasattr(results, "close"):
            results.close()  # stops the worker pool now rather than at garbage collection
    return finished, failed


def summary_metrics(record: dict) -> list[str]:
    """The metrics of a record that have one number per episode (not ``path_lengths``)."""
    names = [name for name in (*METRICS, *TEAM_METRICS) if name in record and name != "n_agents"]
    return [name for name in names if record[name] is None or isinstance(record[name], (bool, int, float))]


def summarize_run(records: list[dict]) -> dict[str, Summary]:
    return {
        name: summarize(name, [record[name] for record in records]) for name in summary_metrics(records[0])
    }


def format_table(summaries: dict[str, Summary], title: str) -> str:
    def number(value: float) -> str:
        return "n/a" if math.isnan(value) else f"{value:.4g}"

    lines = [title, f"{'metric':<18} {'mean':>10}   {'95% CI':<24} note", "-" * 64]
    for name, summary in summaries.items():
        interval = f"[{number(summary.low)}, {number(summary.high)}]"
        note = (
            f"reached in {summary.n} episodes ({summary.reached:.0%})" if summary.reached is not None else ""
        )
        lines.append(f"{name:<18} {number(summary.mean):>10}   {interval:<24} {note}".rstrip())
    return "\n".join(lines)


def save_render(frames: list, path: str) -> None:
    """The last frame as a PNG, or all frames as a looping GIF that rests on the final state."""
    images = [Image.fromarray(frame) for frame in frames]
    if Path(path).suffix.lower() == ".png":
        images[-1].save(path)
        return
    durations = [GIF_FRAME_MS] * (len(images) - 1) + [2000]
    images[0].save(path, save_all=True, append_images=images[1:], duration=durations, loop=0)


@user_errors
def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    layout = load_layout(args.layout)
    try:
        start_poses(
            layout, args.agents
        )  # a team too large for the start cell: refuse before writing anything
    except ValueError as error:
        raise UsageError(f"--agents: {error}") from None
    check_settings(args.baseline, args.config)
    try:
        baseline = load_baseline(args.baseline, **args.config)
    except ValueError as error:  # a file the class cannot use (a BaselineError is a user error already)
        raise UsageError(f"--baseline {args.baseline}: {error}") from None

    max_steps = args.max_steps or layout.max_steps
    env_config = {**baseline.env_options, "reward": args.reward, "max_steps": max_steps}
    header = run_header(
        layout,
        args.baseline,
        getattr(baseline, "config", args.config),
        args.protocol,
        args.agents,
        args.seed,
        env_config,
    )
    frame_every = None  # frames of the first episode: a PNG needs only the last, a GIF about GIF_FRAMES
    if args.render:
        frame_every = max(1, max_steps // GIF_FRAMES) if args.render.suffix.lower() == ".gif" else max_steps
    jobs = [
        EpisodeJob(
            args.baseline,
            args.layout,
            args.seed,
            episode,
            args.protocol,
            args.agents,
            env_config,
            args.config,
            frame_every if episode == 0 else None,
        )
        for episode in range(args.episodes)
    ]
    executor = make_executor(args)
    writer = RunWriter(run_path(args.out, header), header, layout)
    try:
        # What workers and Ray print is a diagnostic (stderr): stdout holds the summary (--json: one object).
        # The executor closes first: Ray's notices (a worker died) may arrive until it has shut down.
        with contextlib.redirect_stdout(sys.stderr), executor:
            finished, failed = collect(run_jobs(jobs, executor), writer, len(jobs))
        first = next((result for result in finished if result.job.episode == 0), None)
        if args.render and first is not None:  # the first episode's worker may have died
            save_render(first.trajectory["frames"], args.render)
        if finished:
            report(args, layout.name, finished, writer)
    except KeyboardInterrupt:
        kept = writer.episodes_written()
        where = f"{writer.path} (trajectories: {writer.trajectory_path})" if kept else "nothing was written"
        print(f"interrupted: {kept} finished episode(s) kept; {where}", file=sys.stderr)
        return EXIT_INTERRUPTED
    finally:
        writer.remove_if_empty()  # a run stopped before its first episode leaves no file
    for failure in sorted(failed, key=lambda failure: failure.job.episode):
        job = failure.job
        print(
            f"error: episode {job.episode} (seed {job.episode_seed}) failed: {failure.message}; "
            f"play it again with --seed {job.episode_seed} --episodes 1",
            file=sys.stderr,
        )
    return 1 if failed else 0


def report(args, layout_name: str, finished: list[EpisodeResult], writer: RunWriter) -> None:
    """The summary on stdout: a table, or with ``--json`` one JSON object."""
    records = [result.record for result in sorted(finished, key=lambda result: result.job.episode)]
    summaries = summarize_run(records)
    render = str(args.render) if args.render else None
    if args.json:
        print(
            json.dumps(
                {
                    "baseline": args.baseline,
                    "layout": layout_name,
                    "protocol": args.protocol,
                    "n_agents": args.agents,
                    "episodes": len(records),
                    "records": str(writer.path),
                    "trajectories": str(writer.trajectory_path),
                    "render": render,
                    "metrics": {name: summary.as_dict() for name, summary in summaries.items()},
                }
            )
        )
        return
    title = (
        f"{args.baseline} on {layout_name} ({args.protocol}, K={args.agents}): {len(records)} episodes, "
        f"seeds {args.seed}..{args.seed + len(records) - 1}"
    )
    print(format_table(summaries, title))
    print(f"\nrecords: {writer.path}\ntrajectories: {writer.trajectory_path}")
    if render:
        print(f"render: {render}")


if __name__ == "__main__":
    raise SystemExit(main())
