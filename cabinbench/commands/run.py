"""Evaluate a baseline on a layout: ``python -m cabinbench.run --baseline NAME --layout NAME``.

    python -m cabinbench.run --baseline NAME|pkg.mod:Class (--layout NAME|FILE.yaml [--episodes N]
        | --suite SUITE [--layouts K] [--episodes-per-layout N]) [--start random|fixed]
        [--seed S] [--agents K] [--protocol sequential|open]
        [--reward PRESET] [--max-steps N] [--config JSON] [--out DIR]
        [--render FILE.png|FILE.gif] [--json] [--workers N] [--executor local|ray [--address A]]
        [--submission FILE.json]

Plays N independent episodes (episode i is seeded with S + i), appends one record per finished
episode to ``DIR/<layout>__<baseline>__<protocol>__k<K>__seed<S>-<time>.jsonl`` (trajectories
in the sibling ``.npz``; format in :mod:`cabinbench.records`) and prints a table of per-metric
means with 95% bootstrap intervals, or with ``--json`` one JSON object with the same numbers and
the paths written. ``--suite`` plays the protocol of :mod:`cabinbench.suites`: N episodes on
each of the suite's first K layouts (default all), each layout's records in a file of its own,
with the field ``suite`` set; the layout at position p plays the seeds from ``S + p * N`` on.
Its episodes start from a pose drawn from the episode's seed (``--start random``, the default
for generated suites; ``classic`` and ``--layout`` keep the layout's own start, ``--start
fixed``), and the step limit is each layout's (scaled with its coverable area), recorded in
``env_config``. ``DIR`` defaults to the working folder ``runs/``: the committed
``results/runs`` are written by ``scripts/make_results.sh`` alone. ``--render`` draws the first
episode: a PNG of its final state (trajectory over the map, covered area shaded: the study's
Fig. 5.11) or an animated GIF. ``--reward`` takes a preset of :mod:`cabinbench.sim.rewards`.
``--submission FILE`` (with ``--suite``) also writes the run's records as one submission file for
the leaderboard (:mod:`cabinbench.leaderboard.submissions`).
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
import sys
from pathlib import Path

from PIL import Image
from tqdm import tqdm

from cabinbench.agents import Baseline, baseline_class, load_baseline
from cabinbench.cli import (
    ArgumentParser,
    json_object,
    non_negative_int,
    output_file,
    output_folder,
    positive_int,
    user_errors,
)
from cabinbench.commands.run_report import report
from cabinbench.episodes import EpisodeJob, EpisodeResult, run_jobs
from cabinbench.errors import EXIT_INTERRUPTED, UsageError
from cabinbench.executors import EXECUTOR_NAMES, executors
from cabinbench.executors.base import Executor, JobFailure
from cabinbench.layouts.model import Layout
from cabinbench.layouts.resolve import load_layout
from cabinbench.layouts.suites import get_suite
from cabinbench.leaderboard.submissions import write_submission
from cabinbench.records import RunWriter, run_header, run_path
from cabinbench.sim.rewards import REWARD_PRESETS
from cabinbench.sim.world import PROTOCOLS, start_poses

GIF_FRAMES = 100  # frames spread over the step limit; the GIF stops early if the episode does
GIF_FRAME_MS = 80
DEFAULT_OUT = "runs"  # a working folder: results/runs is written by scripts/make_results.sh only


def add_output_arguments(parser: ArgumentParser) -> None:
    """What a run writes besides its summary: records, a render, an exported plan (each path checked
    by its argument type before any episode runs)."""
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
    parser.add_argument(
        "--export-path",
        metavar="FILE",
        type=output_file(".csv", ".yaml", ".geojson"),
        help="with --layout: write the planner's plan of the first episode as CSV, nav_msgs/Path YAML or "
        "GeoJSON (run it back with --baseline path)",
    )


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
    where = parser.add_mutually_exclusive_group(required=True)
    where.add_argument("--layout", help="a layout name (python -m cabinbench.layouts) or a YAML file")
    where.add_argument("--suite", help="every layout of a suite (python -m cabinbench.suites)")
    parser.add_argument("--episodes", type=positive_int, help="with --layout: episodes to play (default 5)")
    parser.add_argument("--layouts", type=positive_int, help="with --suite: only its first K layouts")
    parser.add_argument(
        "--episodes-per-layout", type=positive_int, help="with --suite: episodes on each layout (default 1)"
    )
    parser.add_argument(
        "--start",
        choices=("random", "fixed"),
        help="a start pose drawn from each episode's seed, or the layout's own (default: random for "
        "generated suites, fixed otherwise)",
    )
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
    add_output_arguments(parser)
    parser.add_argument("--json", action="store_true", help="print one JSON object instead of the table")
    parser.add_argument(
        "--workers", type=positive_int, default=1, help="episodes played in parallel by a local process pool"
    )
    parser.add_argument(
        "--submission",
        metavar="FILE",
        type=output_file(".json"),
        help="with --suite: write the records as a submission (python -m cabinbench.leaderboard --add FILE)",
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


def planned_sweeps(baseline, layouts: dict[str, Layout], n_agents: int) -> dict[str, dict]:
    """A baseline that follows a given plan (``path``) reports, per layout, the plan's static
    footprint sweep (``planned_*``), which every record of that layout carries beside what was
    executed; asking for it also checks the plan against every layout and the team before any file
    is written. Empty for any other baseline."""
    if not callable(getattr(baseline, "planned", None)):
        return {}
    return {name: baseline.planned(layout, n_agents) for name, layout in layouts.items()}


def export_plan(args, suite: str | None, layouts: dict[str, Layout], random_start: bool) -> None:
    """``--export-path``: the planner's plan of the run's first episode, in the file's format."""
    if suite:
        raise UsageError("--export-path goes with --layout: it writes one layout's plan")
    layout = next(iter(layouts.values()))
    written = baseline_class("path").export_plan(
        args.baseline,
        layout,
        args.export_path,
        args.agents,
        args.seed,
        args.protocol,
        random_start,
        args.config,
    )
    print(f"plan: {written}", file=sys.stderr if args.json else sys.stdout)


def collect(
    results, writers: dict[str, RunWriter], total: int, planned: dict[str, dict]
) -> tuple[list[EpisodeResult], list[JobFailure]]:
    """Write each finished episode as it comes, to its layout's writer (with its layout's ``planned``
    figures); return them, and the jobs whose worker died."""
    finished, failed = [], []
    try:
        with tqdm(total=total, unit="episode", file=sys.stderr, dynamic_ncols=True) as progress:
            for result in results:
                progress.update()
                if isinstance(result, JobFailure):
                    failed.append(result)
                    continue
                record = result.record | planned.get(result.job.layout, {})
                writers[result.job.layout].write(result.job.episode, record, result.trajectory)
                finished.append(result)
                progress.set_postfix(coverage=f"{result.record['coverage']:.3f}")
    finally:
        if hasattr(results, "close"):
            results.close()  # stops the worker pool now rather than at garbage collection
    return finished, failed


def save_render(frames: list, path: str) -> None:
    """The last frame as a PNG, or all frames as a looping GIF that rests on the final state."""
    images = [Image.fromarray(frame) for frame in frames]
    if Path(path).suffix.lower() == ".png":
        images[-1].save(path)
        return
    durations = [GIF_FRAME_MS] * (len(images) - 1) + [2000]
    images[0].save(path, save_all=True, append_images=images[1:], duration=durations, loop=0)


def plan(args) -> tuple[str | None, list[str], int, bool]:
    """(suite, layout names, episodes per layout, random start) of the run the arguments ask for."""
    if args.suite is None:
        for name in ("layouts", "episodes_per_layout"):
            if getattr(args, name) is not None:
                raise UsageError(
                    f"--{name.replace('_', '-')} goes with --suite; with --layout use --episodes"
                )
        return None, [args.layout], args.episodes or 5, args.start == "random"
    if args.episodes is not None:
        raise UsageError("--episodes goes with --layout; with --suite use --episodes-per-layout")
    suite = get_suite(args.suite)
    if args.layouts is not None and args.layouts > len(suite):
        raise UsageError(
            f"--layouts {args.layouts}: suite {suite.name} has {len(suite)} layouts; "
            f"give at most {len(suite)}"
        )
    protocol_start = "random" if suite.random_start else "fixed"
    if args.submission:  # what a submission must follow: refused now, not at --add after the run
        for given, option in (
            (args.layouts is not None and args.layouts < len(suite), "--layouts"),
            (args.max_steps is not None, "--max-steps"),
            (args.start not in (None, protocol_start), "--start"),
        ):
            if given:
                raise UsageError(
                    f"{option}: a submission follows the suite's protocol (every layout, each with its own "
                    f"step limit, a {protocol_start} start); drop {option}"
                )
    return (
        suite.name,
        list(suite.layout_names[: args.layouts]),
        args.episodes_per_layout or 1,
        (args.start or protocol_start) == "random",
    )


def prepare(args) -> tuple[str | None, dict[str, Layout], int, bool, Baseline]:
    """(suite, its layouts by name, episodes per layout, random start, the baseline) of the run the
    arguments ask for, every one checked: a user mistake is refused here, before any file is written."""
    suite, names, episodes, random_start = plan(args)
    if args.submission and not suite:
        raise UsageError("--submission goes with --suite: a submission covers every layout of a suite")
    layouts = {name: load_layout(name) for name in names}  # every layout checked before any episode
    for layout in layouts.values():
        try:
            layout.name.encode("utf-8")
        except UnicodeEncodeError:  # a file name in another encoding: its records could not be reported
            raise UsageError(
                f"--layout: the name {layout.name!r} (its file's name) is not UTF-8 text; rename the file"
            ) from None
        try:
            start_poses(layout, args.agents)  # a team too large for the start cell: refuse before writing
        except ValueError as error:
            raise UsageError(f"--agents: {error}") from None
    check_settings(args.baseline, args.config)
    try:
        baseline = load_baseline(args.baseline, **args.config)
    except ValueError as error:  # a file the class cannot use (a BaselineError is a user error already)
        raise UsageError(f"--baseline {args.baseline}: {error}") from None
    return suite, layouts, episodes, random_start, baseline


def episode_jobs(
    args, suite: str | None, layouts: dict[str, Layout], episodes: int, random_start: bool, baseline
) -> tuple[list[EpisodeJob], dict[str, RunWriter]]:
    """Every episode of the run, and a writer per layout (its records file claimed, empty)."""
    writers: dict[str, RunWriter] = {}
    jobs: list[EpisodeJob] = []
    for position, (name, layout) in enumerate(layouts.items()):
        seed = args.seed + position * episodes  # every episode of a suite run has a seed of its own
        max_steps = args.max_steps or layout.max_steps
        env_config = {**baseline.env_options, "reward": args.reward, "max_steps": max_steps}
        if random_start:
            env_config["random_start"] = True
        header = run_header(
            layout,
            args.baseline,
            getattr(baseline, "config", args.config),
            args.protocol,
            args.agents,
            seed,
            env_config,
            suite,
        )
        frame_every = None  # frames of the first episode: a PNG needs only the last, a GIF about GIF_FRAMES
        if args.render and not jobs:
            frame_every = (
                max(1, max_steps // GIF_FRAMES) if args.render.suffix.lower() == ".gif" else max_steps
            )
        jobs += [
            EpisodeJob(
                args.baseline,
                name,
                seed,
                episode,
                args.protocol,
                args.agents,
                env_config,
                args.config,
                frame_every if episode == 0 else None,
            )
            for episode in range(episodes)
        ]
        writers[name] = RunWriter(run_path(args.out, header), header, layout)
    return jobs, writers


def write_outputs(
    args, suite: str | None, finished, failed, jobs, writers: dict[str, RunWriter], planned: dict[str, dict]
) -> None:
    """The render of the first episode, the summary, and (when no episode failed) the submission."""
    first = next((result for result in finished if result.job == jobs[0]), None)
    if args.render and first is not None:  # the first episode's worker may have died
        save_render(first.trajectory["frames"], args.render)
    if finished:
        name = suite or next(iter(writers.values())).header["layout"]
        report(args, name, finished, list(writers.values()), planned)
    if args.submission and not failed:
        records = [
            json.loads(line)
            for writer in writers.values()
            for line in writer.path.read_text(encoding="utf-8").splitlines()
        ]
        write_submission(args.submission, records, args.baseline, get_suite(suite))
        print(f"submission: {args.submission}", file=sys.stderr if args.json else sys.stdout)


def say_interrupted(writers: dict[str, RunWriter]) -> None:
    """Ctrl-C: how many finished episodes are on disk, and where."""
    kept = [writer for writer in writers.values() if writer.episodes_written()]
    count = sum(writer.episodes_written() for writer in kept)
    where = ", ".join(str(writer.path) for writer in kept[:3]) + (" ..." if len(kept) > 3 else "")
    print(
        f"interrupted: {count} finished episode(s) kept; {where or 'nothing was written'}"
        + (" (trajectories beside them, .npz)" if kept else ""),
        file=sys.stderr,
    )


def say_failed(failed: list[JobFailure]) -> None:
    """One line per episode whose worker died, with the command that plays it again."""
    for failure in sorted(failed, key=lambda failure: (failure.job.layout, failure.job.episode)):
        job = failure.job
        print(
            f"error: episode {job.episode} of {job.layout} (seed {job.episode_seed}) failed: "
            f"{failure.message}; play it again with --layout {job.layout} --seed {job.episode_seed} "
            "--episodes 1",
            file=sys.stderr,
        )


@user_errors
def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    suite, layouts, episodes, random_start, baseline = prepare(args)
    planned = planned_sweeps(baseline, layouts, args.agents)
    if args.export_path:
        export_plan(args, suite, layouts, random_start)
    executor = make_executor(args)  # a missing Ray or cluster is refused before any file is written
    jobs, writers = episode_jobs(args, suite, layouts, episodes, random_start, baseline)
    try:
        # What workers and Ray print is a diagnostic (stderr): stdout holds the summary (--json: one object).
        # The executor closes first: Ray's notices (a worker died) may arrive until it has shut down.
        with contextlib.redirect_stdout(sys.stderr), executor:
            finished, failed = collect(run_jobs(jobs, executor), writers, len(jobs), planned)
        write_outputs(args, suite, finished, failed, jobs, writers, planned)
    except KeyboardInterrupt:
        say_interrupted(writers)
        return EXIT_INTERRUPTED
    finally:
        for writer in writers.values():
            writer.remove_if_empty()  # a run stopped before its first episode leaves no file
    say_failed(failed)
    return 1 if failed else 0
