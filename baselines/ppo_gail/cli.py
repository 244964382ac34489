"""The trainer of the ppo_gail baselines, run by ``python -m cabinbench.train --baseline ppo_gail ...``.

    python -m cabinbench.train --baseline ppo_gail|ppo|ppo_icm|ppo_gail_only [...]
    python -m cabinbench.train --baseline ppo_gail_study --stage cleaning|tracking
    python -m cabinbench.train --baseline ppo_lstm [--rnn-hidden-dim N]
    python -m cabinbench.train --baseline bc|dagger [--episodes-per-iteration N] [--beta-decay P] [--epochs N]
    python -m cabinbench.train --baseline ppo_gail_team [--agents K] [--[no-]centralised-critic]
        [--team-weight W] [--init-policy FILE|NAME]
        [--layout NAME ... | --suite NAME [--demo-layouts N]] [--iterations N] [--num-envs N]
        [--steps-per-env N] [--seed S]
        [--reward paper|coverage] [--[no-]terminate-on-bound] [--max-steps N] [--algorithm JSON]
        [--min-action-std X] [--coverage-patch N] [--coverage-patch-cell M] [--[no-]random-start]
        [--threads N] [--workers N] [--save-interval N] [--validation-episodes N] [--validation-interval N]
        [--export last|best]
        [--demonstrations FILE.npz ...] [--demo-episodes N] [--demo-action-noise STD]
        [--run-dir DIR] [--resume] [--export-latest] [--ship [--ship-dir DIR]] [--keep] [--no-progress]
        [--seeds S ... [--executor local|ray [--address A]]]

``ppo_gail_study`` is two networks trained apart, each with ``--stage``: options not given take the study's
configuration (``cabinbench.baselines.ppo_gail.study``), the run lives in
``runs/train/ppo_gail_study_<stage>__seed<S>`` and ``--ship`` installs ``ppo_gail_study_<stage>.pt`` with its
``.config.json`` and ``.training.json`` (the training summary: iterations and steps reached of those
planned, time, final metrics) beside it, and keeps the run's records in
``results/training/ppo_gail_study_<stage>/`` as every baseline's. ``--export-latest`` trains nothing: it
exports the run's latest checkpoint as its ``policy.pt`` (its training summary says how many of the planned
iterations it had), for ``--ship``.

``ppo_gail_team`` is one policy shared by every robot of a team, trained in the batched team env
(``cabinbench.baselines.ppo_gail.team_training``, whose ``TeamTrainConfig`` gives its defaults:
``full_cabin``, K = 2, a centralised critic, the actor started from the shipped ``ppo_gail``); its records are
kept as an ablation's are.

Otherwise options not given take the defaults of ``cabinbench.baselines.ppo_gail.training.TrainConfig`` (the
shipped policies' configuration; with ``--layout`` repeated, one policy trains on all of them, by default
``a320_cell`` and ``a320_tracking_cell``). With ``--suite NAME`` (e.g. ``cabin-v1-train``) it trains on the
suite instead, through ``CabinBench/Suite-v0``: every env draws a new layout of the suite at each reset; the
expert demonstrates on ``--demo-layouts`` of its layouts, and the policy ships as ``<baseline>_suite``
(``ppo_gail_suite``). The run lives in ``--run-dir`` (default ``runs/train/<baseline>__seed<S>``): config,
demonstrations, checkpoints, ``metrics.csv``, ``curves.png``, the exported ``policy.pt`` and its ONNX twin
``policy.onnx`` for the ``onnx`` baseline (``ppo_lstm``'s with its memory's state as an input and an output).
``--resume`` continues an interrupted run from its latest checkpoint, with the saved config (``--iterations``
may raise the total); a finished run it takes as it is, checkpoints or none. At the end the policy of every
``--validation-interval``-th checkpoint and of the last plays one episode on each of ``--validation-episodes``
layouts of cabin-v1-val from a random start (``validation.csv`` in the run directory, with the headline
clean_score); ``--export best`` exports the checkpoint that did best there instead of the last (see
``TrainConfig.export`` for why the last is the default). ``--ship`` copies the exported policy to
``<ship-dir>/<baseline>.pt`` and its twin to ``<baseline>.onnx`` (``--ship-dir``, default the repository's
``baselines/ppo_gail/checkpoints``: run it from the repository root), where ``python -m cabinbench.run
--baseline <baseline>`` finds it, and the run's ``config.json``, ``metrics.csv`` and ``validation.csv`` to
``results/training/<baseline>/``, from which ``python -m cabinbench.leaderboard`` draws the committed training
curves. ``--keep`` copies the policy, its twin, ``config.json``, ``metrics.csv`` and ``validation.csv`` to
``results/training/<baseline>/seed<S>/``: a further training run of the same command, which
``scripts/make_results.sh`` scores into ``results/ablation.md``.

``--seeds S ...`` trains one run per seed at once, each exactly as ``--seed S`` would, in its own run
directory ``<name>__seed<S>`` in the folder ``--run-dir`` (default ``runs/train``), one CPU each
(``--workers``): in local processes, or with ``--executor ray`` as Ray tasks on the cluster at ``--address``
(or a local Ray instance; on several nodes the run directories must be on a shared filesystem). With several
``--baseline`` names the sweep trains every seed of each (``scripts/train_policies.sh``: 4 x 3 runs).
An interrupted sweep continues with the same command and ``--resume``: each unfinished seed resumes from its
latest checkpoint, a finished one is taken as it is (it needs no checkpoint).

``ppo_lstm`` is PPO with an LSTM memory on lidar and velocity (``RecurrentTrainConfig``); ``bc`` and
``dagger`` imitate the boustrophedon expert (``cabinbench.baselines.imitation``), choose their checkpoint on
cabin-v1-val and take the options of ``ImitationConfig`` (the rsl-rl ones are refused).

A run directory is locked while a process trains in it: a second ``train`` there is refused, changing
nothing. The options are generated from ``TrainConfig``'s fields (``options.option``) and ``TrainCommand``'s;
what differs between baselines is their ``trainers.Trainer``.

Exit status: 0 done (every seed); 1 a seed's worker died; 2 bad arguments (an unknown baseline: the valid
ones are printed) or a run directory that cannot be used as asked (one being trained by another process);
130 interrupted by Ctrl-C (finished checkpoints are kept; resume with ``--resume``).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from dataclasses import dataclass, fields
from pathlib import Path

from cabinbench.baselines.onnx.export import export_twin
from cabinbench.baselines.ppo_gail.options import add_options, flag, option, option_fields
from cabinbench.baselines.ppo_gail.runner_config import algorithm_defaults
from cabinbench.baselines.ppo_gail.study import STAGES
from cabinbench.baselines.ppo_gail.trainers import TRAINERS, Trainer, keep
from cabinbench.baselines.ppo_gail.training.config import CONFIG_FILE, TrainConfig, default_run_dir

from cabinbench.cli import ArgumentParser, output_folder
from cabinbench.errors import EXIT_INTERRUPTED, EXIT_USAGE, UsageError, UserError
from cabinbench.executors import EXECUTOR_NAMES, executors
from cabinbench.executors.base import JobFailure

SHIP_DIR = Path("baselines/ppo_gail/checkpoints")  # the repository's, never the installed package's
CONFIG_CLASSES = list(dict.fromkeys(trainer.config_class for trainer in TRAINERS.values()))
"""The config classes of the trainers, ``TrainConfig`` first: their option fields are the config's options."""


@dataclass
class TrainCommand:
    """The options of the train command that are not the run's config: what to train, and what to do with
    the run. Declared as fields, like the config's, so that ``parse_args`` generates their options alike."""

    baselines: list[str] = option(flag="--baseline", metavar="NAME", required=True)
    """The learned baseline to train (with --seeds, several: one sweep of them all)."""
    stage: str | None = option(None, choices=STAGES)
    """Which network of ppo_gail_study to train (required for it, and only for it)."""
    run_dir: Path | None = option(None, parse=output_folder)
    """Run directory (default runs/train/<baseline>__seed<S>); with --seeds: the folder of their runs."""
    resume: bool = option(False)
    """Continue the run in --run-dir from its latest checkpoint, as it would have gone on."""
    ship: bool = option(False)
    """Copy the exported policy to --ship-dir, where run --baseline finds it."""
    ship_dir: Path = option(SHIP_DIR)
    """Where --ship puts the policy: the repository's baselines/ppo_gail/checkpoints (run from its root)."""
    keep: bool = option(False)
    """Copy the policy and training records to results/training/<baseline>/seed<S>/ (results/ablation.md)."""
    export_latest: bool = option(False)
    """Do not train: export the run's latest checkpoint as its policy.pt (then --ship or --keep it)."""
    no_progress: bool = option(False)
    """No progress bar."""
    seeds: list[int] | None = option(None, metavar="S")
    """Train one run per seed at once (instead of --seed)."""
    executor: str = option("local", choices=EXECUTOR_NAMES)
    """With --seeds: local processes or Ray tasks."""
    address: str | None = option(None)
    """With --executor ray: the cluster ('auto' or HOST:PORT; default local)."""


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    """The command's options: ``TrainCommand``'s, and the config's (None where not given: the config's
    default, or a resumed run's saved value, applies)."""
    parser = ArgumentParser(
        prog="python -m cabinbench.train",
        description="Train PPO + curiosity + GAIL (or an ablation) with rsl-rl.",
    )
    add_options(parser, TrainCommand, unset=False)
    add_options(parser, TrainConfig)
    common = {field.name for field in option_fields(TrainConfig)}
    for config_class in CONFIG_CLASSES[1:]:
        own = [field.name for field in option_fields(config_class) if field.name not in common]
        users = [name for name, trainer in TRAINERS.items() if trainer.config_class is config_class]
        add_options(parser.add_argument_group(f"{', '.join(users)} only"), config_class, own)
    args = parser.parse_args(argv)
    args.baseline = args.baselines[0]  # a single run's; a sweep sets each run's own
    return args


def trainer_of(args: argparse.Namespace) -> Trainer:
    """The trainer of ``args.baseline``, checked against the options given."""
    trainer = TRAINERS.get(args.baseline)
    if trainer is None:
        raise UsageError(
            f"cannot train baseline {args.baseline!r}; trainable baselines: {', '.join(TRAINERS)}"
        )
    if bool(trainer.stages) != (args.stage is not None):
        studies = [name for name, other in TRAINERS.items() if other.stages]
        raise UsageError(
            f"--stage {'|'.join(STAGES)} is for --baseline {', '.join(studies)}, and it needs one"
        )
    if args.suite and (args.layouts or not trainer.trains_on_suites):
        on_suites = [name for name, other in TRAINERS.items() if other.trains_on_suites]
        raise UsageError(f"--suite trains {', '.join(on_suites)} on a suite instead of --layout")
    return trainer


def build_config(args: argparse.Namespace) -> tuple[TrainConfig, Path]:
    """The run's config and directory: the trainer's config of the options given, or when resuming (or
    exporting) the saved one with those options over it."""
    trainer = TRAINERS[args.baseline]
    options = {field.name: field for config_class in CONFIG_CLASSES for field in option_fields(config_class)}
    given = {name: getattr(args, name) for name in options if getattr(args, name) is not None}
    accepted = {field.name for field in fields(trainer.config_class)}
    foreign = [name for name in given if name not in accepted]
    if foreign:
        users = [
            name for name, other in TRAINERS.items() if foreign[0] in other.config_class.__dataclass_fields__
        ]
        flags = ", ".join(flag(options[name]) for name in foreign)
        raise UsageError(f"{flags}: only for {', '.join(users)}, not {args.baseline}")
    config = trainer.config(args.baseline, args.stage, given)
    run_dir = Path(args.run_dir) if args.run_dir else default_run_dir(config, name=shipped_name(args))
    saved_path = run_dir / CONFIG_FILE
    if (args.resume or args.export_latest) and saved_path.exists():
        config = type(config).from_dict({**json.loads(saved_path.read_text()), **given})
    return config, run_dir


def shipped_name(args: argparse.Namespace) -> str:
    """What a run's policy ships as (``Trainer.shipped_name``)."""
    return TRAINERS[args.baseline].shipped_name(args.baseline, args.stage, args.suite)


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    if args.seeds is not None:
        return sweep(args)
    if args.executor != "local" or args.address is not None:
        print("error: --executor and --address run the seeds of --seeds; give --seeds S ...", file=sys.stderr)
        return EXIT_USAGE
    if len(args.baselines) > 1:
        print("error: --baseline: several baselines train as one sweep; give --seeds S ...", file=sys.stderr)
        return EXIT_USAGE
    return train_one(args)


def train_one(args: argparse.Namespace) -> int:
    """Train the run of ``args`` (one seed); the exit status. Ctrl-C, at any moment, is one line."""
    try:
        trainer = trainer_of(args)
        if args.ship and not args.ship_dir.is_dir():
            raise UsageError(
                f"--ship-dir {args.ship_dir} is not a folder; "
                "run from the repository root or give --ship-dir DIR"
            )
        config, run_dir = checked_config(args)
    except UserError as error:
        print(f"error: {error}", file=sys.stderr)
        return EXIT_USAGE
    try:
        return train_checked(args, trainer, config, run_dir)
    except KeyboardInterrupt:
        return interrupted(run_dir)


def checked_config(args: argparse.Namespace) -> tuple[TrainConfig, Path]:
    """``build_config``, every mistake in it a ``UsageError``, its layouts loaded (a bad one names the valid
    ones) before any work starts."""
    from cabinbench.layouts.resolve import load_layout

    try:
        config, run_dir = build_config(args)
        if args.demo_layouts is not None and not config.suite:
            raise UsageError("--demo-layouts goes with --suite: the expert demonstrates every --layout")
        for layout in config.layouts:
            load_layout(layout)
    except UserError:
        raise
    except (ValueError, TypeError) as error:
        raise UsageError(str(error)) from None
    return config, run_dir


def replaced_defaults(args: argparse.Namespace, trainer: Trainer) -> str | None:
    """The note for an ``--algorithm`` without settings the baseline's config gives: it replaces that
    dict, so those take the algorithm's defaults, which trains another method unnoticed."""
    if getattr(args, "algorithm", None) is None:
        return None
    ours, fallback = trainer.config(args.baseline, args.stage, {}).algorithm, algorithm_defaults()
    left_out = {name: value for name, value in ours.items() if name not in args.algorithm}
    changed = {  # compared as JSON, which the config holds: a default tuple is its list
        name: fallback.get(name)
        for name, value in left_out.items()
        if json.dumps(fallback.get(name)) != json.dumps(value)
    }
    if not changed:
        return None
    return (
        f"note: --algorithm replaces {args.baseline}'s {json.dumps(ours)}, so this run trains with "
        f"{json.dumps(changed)[1:-1]} (the algorithm's defaults); give "
        f"{json.dumps({name: ours[name] for name in changed})[1:-1]} in it to keep them"
    )


def train_checked(args: argparse.Namespace, trainer: Trainer, config: TrainConfig, run_dir: Path) -> int:
    """Train (or export) the run of a checked config, then ship or keep it as asked; the exit status."""
    name = shipped_name(args)
    if note := replaced_defaults(args, trainer):
        print(note, file=sys.stderr)
    print(
        f"{'exporting' if args.export_latest else 'training'} {name} on {config.trained_on}: "
        f"{config.iterations} iterations x {config.num_envs} envs x {config.num_steps_per_env} steps; "
        f"run dir {run_dir}",
        file=sys.stderr,
    )
    try:
        if args.export_latest:
            result = trainer.export_latest(config, run_dir)
        else:
            result = trainer.train(config, run_dir, resume=args.resume, progress=not args.no_progress)
    except (UserError, FileExistsError, FileNotFoundError, ValueError) as error:
        print(f"error: {error}", file=sys.stderr)
        return EXIT_USAGE
    if result.interrupted:
        return interrupted(run_dir)
    summary = result.summary
    print(
        f"done: {result.iterations} of {config.iterations} iterations, {summary['timesteps']} steps, "
        f"{result.train_time / 60:.1f} min of training; last iterations: "
        f"coverage {summary['final_coverage']}, success {summary['final_success']}"
    )
    print(
        f"policy: {result.policy_path} (the checkpoint of iteration {summary['exported_iteration']}, "
        f"--export {config.export})\ncurves: {result.run_dir / 'curves.png'}\n"
        f"metrics: {result.run_dir / 'metrics.csv'}"
    )
    if config.validation_episodes:
        print(f"validation of the checkpoints: {result.run_dir / 'validation.csv'}")
    print(f"onnx twin: {export_twin(result.policy_path)}")  # every trainer's policy passes here
    if args.ship:
        print(trainer.ship(result, name, args.ship_dir, config))
    if args.keep:
        print(f"kept: {keep(result, name, config)} (score it with the loop in scripts/make_results.sh)")
    return 0


def interrupted(run_dir: Path) -> int:
    """Say what Ctrl-C left, in one line; the exit status."""
    print(f"interrupted: finished checkpoints are kept in {run_dir}; continue with --resume", file=sys.stderr)
    return EXIT_INTERRUPTED


def sweep(args: argparse.Namespace) -> int:
    """Train every seed of ``--seeds`` of every ``--baseline`` with the executor of ``--executor``; the worst
    exit status."""
    several = len(set(args.seeds)) > 1
    untrainable = [name for name in args.baselines if name not in TRAINERS]
    refused = [
        (args.seed is not None, "--seed: give the seeds with --seeds alone"),
        (several and args.ship, "--ship: seeds would overwrite each other's shipped policy; ship one seed"),
        (untrainable, f"--baseline {' '.join(untrainable)}: trainable baselines: {', '.join(TRAINERS)}"),
        (
            args.executor == "local" and args.address is not None,
            "--address: only --executor ray runs on a cluster",
        ),
    ]
    for mistake, message in refused:
        if mistake:
            print(f"error: {message}", file=sys.stderr)
            return EXIT_USAGE
    # Each seed's run works in this folder (a Ray worker's own is elsewhere): run directories, --keep and
    # --ship land where a local run would put them.
    here = str(Path.cwd())
    jobs = []
    for baseline in dict.fromkeys(args.baselines):
        for seed in dict.fromkeys(args.seeds):
            job = argparse.Namespace(
                **{
                    **vars(args),
                    "baseline": baseline,
                    "seeds": None,
                    "seed": seed,
                    "workers": 1 if args.workers is None else args.workers,  # the sweep gives a run one CPU
                    "no_progress": True,
                    "workdir": here,
                }
            )
            if args.run_dir:
                job.run_dir = str(Path(args.run_dir) / f"{shipped_name(job)}__seed{seed}")
            jobs.append(job)
    try:
        executor = executors()[args.executor](
            workers=min(len(jobs), os.cpu_count() or 1), address=args.address
        )
    except UsageError as error:
        print(f"error: {error}", file=sys.stderr)
        return EXIT_USAGE
    print(f"training {', '.join(map(job_name, jobs))} with the {args.executor} executor", file=sys.stderr)
    statuses = {}
    try:
        with executor:
            for outcome in executor.map(train_seed, jobs):
                if isinstance(outcome, JobFailure):
                    job, status, what = outcome.job, 1, f"failed: {outcome.message}"
                else:
                    job, status = outcome
                    what = "done" if status == 0 else f"exit status {status}"
                statuses[job_name(job)] = status
                print(f"{job_name(job)}: {what} ({run_dir(job)})", file=sys.stderr)
    except KeyboardInterrupt:
        statuses[None] = EXIT_INTERRUPTED
    if any(status != 0 for status in statuses.values()):
        unfinished = [job_name(job) for job in jobs if statuses.get(job_name(job)) != 0]
        print(
            f"not finished: {', '.join(unfinished)}; continue them from their checkpoints with the same "
            "command and --resume",
            file=sys.stderr,
        )
    for status in (EXIT_INTERRUPTED, EXIT_USAGE, 1):
        if status in statuses.values():
            return status
    return 0


def job_name(args: argparse.Namespace) -> str:
    """A run of a sweep as its messages name it: ``<baseline> seed <S>``."""
    return f"{args.baseline} seed {args.seed}"


def run_dir(args: argparse.Namespace) -> Path:
    """The run directory of ``args`` (one seed)."""
    from cabinbench.baselines.ppo_gail.training import TrainConfig, default_run_dir

    return (
        Path(args.run_dir)
        if args.run_dir
        else default_run_dir(TrainConfig(seed=args.seed), name=shipped_name(args))
    )


def train_seed(args: argparse.Namespace) -> tuple[argparse.Namespace, int]:
    """One seed of a sweep, in a worker: its arguments and exit status."""
    os.chdir(args.workdir)
    return args, train_one(args)


def bench_iteration(iterations: int = 3, warmup: int = 1) -> dict[str, dict[str, float]]:
    """Seconds per training iteration of each ablation, split into env, rollout and update: what
    ``python -m cabinbench.bench`` asks a trainer for (``cabinbench.baselines.ppo_gail.bench``)."""
    from cabinbench.baselines.ppo_gail.bench import bench_iteration as measure

    return measure(iterations, warmup)


if __name__ == "__main__":
    raise SystemExit(main())
