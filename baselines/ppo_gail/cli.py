"""The trainer of the ppo_gail baselines, run by ``python -m cabinbench.train --baseline ppo_gail ...``.

    python -m cabinbench.train --baseline ppo_gail|ppo|ppo_icm|ppo_gail_only [...]
    python -m cabinbench.train --baseline ppo_gail_study --stage cleaning|tracking
    python -m cabinbench.train --baseline ppo_gail_team [--agents K] [--[no-]centralised-critic]
        [--team-weight W] [--init-policy FILE|NAME]
        [--layout NAME ... | --suite NAME [--demo-layouts N]] [--iterations N] [--num-envs N]
        [--steps-per-env N] [--seed S]
        [--reward paper|coverage] [--[no-]terminate-on-bound] [--max-steps N] [--algorithm JSON]
        [--min-action-std X] [--coverage-patch N] [--coverage-patch-cell M] [--[no-]random-start]
        [--threads N] [--workers N] [--save-interval N] [--validation-episodes N] [--export last|best]
        [--demonstrations FILE.npz ...] [--demo-episodes N] [--demo-action-noise STD]
        [--run-dir DIR] [--resume] [--export-latest] [--ship [--ship-dir DIR]] [--keep] [--no-progress]
        [--seeds S ... [--executor local|ray [--address A]]]

``ppo_gail_study`` is two networks trained apart, each with ``--stage``: options not given take the study's
configuration (``cabinbench.baselines.ppo_gail.study``), the run lives in
``runs/train/ppo_gail_study_<stage>__seed<S>`` and ``--ship`` installs ``ppo_gail_study_<stage>.pt`` with its
``.config.json`` and ``.training.json`` (the training summary: iterations and steps reached of those
planned, time, final metrics) beside it. ``--export-latest`` trains nothing: it exports the run's latest
checkpoint as its ``policy.pt`` (its training summary says how many of the planned iterations it had), for
``--ship``.

``ppo_gail_team`` is one policy shared by every robot of a team, trained in the batched team env
(``cabinbench.baselines.ppo_gail.team_training``, whose ``TeamTrainConfig`` gives its defaults:
``full_cabin``, K = 2, a centralised critic, the actor started from the shipped ``ppo_gail``); its records are
kept as an ablation's are.

Otherwise options not given take the defaults of ``cabinbench.baselines.ppo_gail.training.TrainConfig`` (the
shipped policies' configuration; with ``--layout`` repeated, one policy trains on all of them, by default
``a320_cell`` and ``a320_tracking_cell``). With ``--suite NAME`` (e.g. ``cabin-v1-train``) it trains on the
suite instead, through ``CabinBench/Suite-v0``: every env draws a new layout of the suite at each reset; the
expert demonstrates on ``--demo-layouts`` of its layouts, validation plays one episode on each of
``--validation-episodes`` of them, and the policy ships as ``<baseline>_suite`` (``ppo_gail_suite``). The run
lives in ``--run-dir`` (default ``runs/train/<baseline>__seed<S>``): config, demonstrations, checkpoints,
``metrics.csv``, ``curves.png`` and the exported ``policy.pt``. ``--resume`` continues an interrupted run from
its latest checkpoint, with the saved config (``--iterations`` may raise the total). At the end every
checkpoint's policy plays ``--validation-episodes`` episodes (default 20) on each training layout
(``validation.csv`` in the run directory); ``--export best`` exports the checkpoint that did best there
instead of the last (see ``TrainConfig.export`` for why the last is the default). ``--ship`` copies the
exported policy to ``<ship-dir>/<baseline>.pt`` (``--ship-dir``, default the repository's
``baselines/ppo_gail/checkpoints``: run it from the repository root), where ``python -m cabinbench.run
--baseline <baseline>`` finds it, and the run's ``config.json``, ``metrics.csv`` and ``validation.csv`` to
``results/training/<baseline>/``, from which ``python -m cabinbench.leaderboard`` draws the committed training
curves. ``--keep`` copies the policy, ``config.json``, ``metrics.csv`` and ``validation.csv`` to
``results/training/<baseline>/seed<S>/``: a further training run of the same command, which
``results/make_results.sh`` scores into ``results/ablation.md``.

``--seeds S ...`` trains one run per seed at once, each exactly as ``--seed S`` would, in its own run
directory ``<name>__seed<S>`` in the folder ``--run-dir`` (default ``runs/train``), one CPU each
(``--workers``): in local processes, or with ``--executor ray`` as Ray tasks on the cluster at ``--address``
(or a local Ray instance; on several nodes the run directories must be on a shared filesystem). With several
``--baseline`` names the sweep trains every seed of each (``results/train_policies.sh``: 4 x 3 runs).
An interrupted sweep continues with the same command and ``--resume``: each unfinished seed resumes from its
latest checkpoint, a finished one is only exported again.

Exit status: 0 done (every seed); 1 a seed's worker died; 2 bad arguments (an unknown baseline: the valid
ones are printed) or a run directory that cannot be used as asked; 130 interrupted by Ctrl-C (finished
checkpoints are kept; resume with ``--resume``).
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import sys
from pathlib import Path

from cabinbench.cli import ArgumentParser, output_folder
from cabinbench.errors import UsageError
from cabinbench.executors import EXECUTOR_NAMES, executors
from cabinbench.executors.base import JobFailure
from cabinbench.sim.rewards import REWARD_PRESETS

EXIT_USAGE, EXIT_INTERRUPTED = 2, 130
ABLATION_NAMES = ("ppo_gail", "ppo", "ppo_icm", "ppo_gail_only")  # = ...ppo_gail.algorithm.ABLATIONS
STUDY_NAME = "ppo_gail_study"  # two networks, one per --stage (cabinbench.baselines.ppo_gail.study)
TEAM_NAME = "ppo_gail_team"  # one policy shared by a team (cabinbench.baselines.ppo_gail.team_training)
TEAM_OPTIONS = ("n_agents", "centralised_critic", "team_weight", "init_policy")  # TeamTrainConfig's own
TRAINABLE = (*ABLATION_NAMES, STUDY_NAME, TEAM_NAME)
TRAINING_RECORDS = Path("results/training")  # what --ship and --keep keep of a run
SHIP_DIR = Path("baselines/ppo_gail/checkpoints")  # the repository's, never the installed package's


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    parser = ArgumentParser(
        prog="python -m cabinbench.train",
        description="Train PPO + curiosity + GAIL (or an ablation) with rsl-rl.",
    )
    parser.add_argument(
        "--baseline",
        required=True,
        nargs="+",
        dest="baselines",
        metavar="NAME",
        help=f"one of {', '.join(TRAINABLE)} (with --seeds, several: one sweep of them all)",
    )
    parser.add_argument(
        "--stage",
        choices=("cleaning", "tracking"),
        help=f"which network of {STUDY_NAME} to train (required for it, and only for it)",
    )
    parser.add_argument(
        "--layout",
        action="append",
        dest="layouts",
        metavar="NAME",
        help="training layout (repeat for several; default a320_cell and a320_tracking_cell)",
    )
    parser.add_argument(
        "--suite",
        metavar="NAME",
        help="train on a suite (a new layout of it at every reset) instead of --layout",
    )
    parser.add_argument(
        "--demo-layouts", type=int, metavar="N", help="with --suite: suite layouts the expert demonstrates"
    )
    parser.add_argument("--iterations", type=int, help="total training iterations")
    parser.add_argument("--num-envs", type=int, help="parallel envs")
    parser.add_argument(
        "--steps-per-env", type=int, dest="num_steps_per_env", help="rollout steps per env and iteration"
    )
    parser.add_argument("--seed", type=int, help="seed (default 0)")
    parser.add_argument("--reward", choices=REWARD_PRESETS, help="reward preset of the training envs")
    parser.add_argument("--max-steps", type=int, help="episode step limit (default: each layout's)")
    parser.add_argument("--threads", type=int, help="torch threads")
    parser.add_argument(
        "--workers",
        type=int,
        metavar="N",
        help="cores the training uses (default 0: every core; a seed of --seeds: 1); results do not change",
    )
    parser.add_argument("--save-interval", type=int, help="checkpoint every N iterations")
    parser.add_argument(
        "--validation-episodes",
        type=int,
        metavar="N",
        help="episodes per training layout on which every checkpoint is validated (0: none)",
    )
    parser.add_argument(
        "--export", choices=("last", "best"), help="export the last checkpoint or the best validated"
    )
    parser.add_argument(
        "--algorithm",
        type=json.loads,
        metavar="JSON",
        help='further algorithm settings, e.g. \'{"gail_strength": 0.1, "entropy_coef": 0.02}\'',
    )
    parser.add_argument("--min-action-std", type=float, help="lower clamp of the policy's action std")
    parser.add_argument(
        "--coverage-patch",
        type=int,
        metavar="N",
        help="observe an N x N coverage patch (0: lidar and velocity only)",
    )
    parser.add_argument(
        "--coverage-patch-cell", type=float, metavar="M", help="size of a coverage patch cell in metres"
    )
    parser.add_argument(
        "--random-start",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="start each training episode at a random pose of the start cell",
    )
    parser.add_argument(
        "--terminate-on-bound",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="end episodes on a bound contact",
    )
    parser.add_argument(
        "--demonstrations", nargs="+", metavar="FILE", help="expert .npz files instead of recording"
    )
    parser.add_argument("--demo-episodes", type=int, metavar="N", help="expert episodes per training layout")
    parser.add_argument(
        "--demo-action-noise",
        type=float,
        metavar="STD",
        help="Gaussian noise on the expert's executed actions while recording (0: none)",
    )
    team = parser.add_argument_group(f"{TEAM_NAME} only")
    team.add_argument(
        "--agents", type=int, dest="n_agents", metavar="K", help="robots per team env (default 2)"
    )
    team.add_argument(
        "--centralised-critic",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="the critic also sees the team env's state() (default: yes)",
    )
    team.add_argument(
        "--team-weight", type=float, help="weight of the team's new area in each robot's reward"
    )
    team.add_argument(
        "--init-policy",
        metavar="FILE|NAME",
        help='policy file (or shipped name) the actor starts from (default ppo_gail; "" : random weights)',
    )
    parser.add_argument(
        "--run-dir",
        type=output_folder,
        help="run directory (default runs/train/<baseline>__seed<S>); with --seeds: the folder of their runs",
    )
    parser.add_argument(
        "--resume", action="store_true", help="continue the run in --run-dir from its latest checkpoint"
    )
    parser.add_argument("--ship", action="store_true", help="copy the exported policy to --ship-dir")
    parser.add_argument(
        "--ship-dir",
        type=Path,
        default=SHIP_DIR,
        help=f"where --ship puts the policy (default {SHIP_DIR}, relative to the repository root)",
    )
    parser.add_argument(
        "--keep",
        action="store_true",
        help="copy the policy and training records to results/training/<baseline>/seed<S>/ "
        "(results/ablation.md)",
    )
    parser.add_argument(
        "--export-latest",
        action="store_true",
        help="do not train: export the run's latest checkpoint as its policy.pt (then --ship or --keep it)",
    )
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    parser.add_argument(
        "--seeds", type=int, nargs="+", metavar="S", help="train one run per seed at once (instead of --seed)"
    )
    parser.add_argument(
        "--executor",
        choices=EXECUTOR_NAMES,
        default="local",
        help="with --seeds: local processes or Ray tasks",
    )
    parser.add_argument(
        "--address", help="with --executor ray: the cluster ('auto' or HOST:PORT; default local)"
    )
    args = parser.parse_args(argv)
    if args.algorithm is not None and not isinstance(args.algorithm, dict):
        parser.error("--algorithm must be a JSON object")
    args.baseline = args.baselines[0]  # a single run's; a sweep sets each run's own
    return args


def build_config(args: argparse.Namespace):
    """The ``TrainConfig``: the saved one when resuming (else the defaults), overridden by the options
    given."""
    from cabinbench.baselines.ppo_gail.training import CONFIG_FILE, TrainConfig, default_run_dir

    given = {
        name: getattr(args, name)
        for name in (
            "layouts",
            "suite",
            "demo_layouts",
            "iterations",
            "num_envs",
            "num_steps_per_env",
            "seed",
            "reward",
            "terminate_on_bound",
            "max_steps",
            "algorithm",
            "min_action_std",
            "coverage_patch",
            "coverage_patch_cell",
            "random_start",
            "threads",
            "workers",
            "save_interval",
            "validation_episodes",
            "export",
            "demonstrations",
            "demo_episodes",
            "demo_action_noise",
        )
        if getattr(args, name) is not None
    }
    team_given = {name: getattr(args, name) for name in TEAM_OPTIONS if getattr(args, name) is not None}
    if team_given and args.baseline != TEAM_NAME:
        raise ValueError(
            f"--agents, --centralised-critic, --team-weight and --init-policy are for {TEAM_NAME}"
        )
    if args.baseline == STUDY_NAME:
        from cabinbench.baselines.ppo_gail.study import study_config

        config = study_config(args.stage, **given)
    elif args.baseline == TEAM_NAME:
        from cabinbench.baselines.ppo_gail.team_training import TeamTrainConfig

        given |= team_given
        config = TeamTrainConfig(**given)
    else:
        config = TrainConfig(ablation=args.baseline, **given)
    run_dir = Path(args.run_dir) if args.run_dir else default_run_dir(config, name=policy_name(args))
    saved_path = run_dir / CONFIG_FILE
    if (args.resume or args.export_latest) and saved_path.exists():
        config = type(config).from_dict({**json.loads(saved_path.read_text()), **given})
    return config, run_dir


def policy_name(args: argparse.Namespace) -> str:
    """What a run's policy ships as: the baseline, ``<baseline>_suite`` when trained on a suite, or for the
    study's networks ``ppo_gail_study_<stage>``."""
    if args.baseline == STUDY_NAME:
        return f"{STUDY_NAME}_{args.stage}"
    return f"{args.baseline}_suite" if args.suite else args.baseline


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
    """Train the run of ``args`` (one seed); the exit status."""
    if args.baseline not in TRAINABLE:
        print(
            f"error: cannot train baseline {args.baseline!r}; trainable baselines: {', '.join(TRAINABLE)}",
            file=sys.stderr,
        )
        return EXIT_USAGE
    if (args.baseline == STUDY_NAME) != (args.stage is not None):
        print(
            f"error: --stage cleaning|tracking is for --baseline {STUDY_NAME}, and it needs one",
            file=sys.stderr,
        )
        return EXIT_USAGE
    if args.ship and not args.ship_dir.is_dir():
        print(
            f"error: --ship-dir {args.ship_dir} is not a folder; "
            "run from the repository root or give --ship-dir DIR",
            file=sys.stderr,
        )
        return EXIT_USAGE
    os.environ.setdefault("GIT_PYTHON_REFRESH", "quiet")
    from cabinbench.baselines.ppo_gail.training import export_latest, train

    from cabinbench.errors import LayoutError
    from cabinbench.layouts.resolve import load_layout

    try:
        if args.suite and (args.layouts or args.baseline not in ABLATION_NAMES):
            raise ValueError(f"--suite trains {', '.join(ABLATION_NAMES)} on a suite instead of --layout")
        config, run_dir = build_config(args)
        if args.demo_layouts is not None and not config.suite:
            raise ValueError("--demo-layouts goes with --suite: the expert demonstrates every --layout")
        for layout in config.layouts:
            load_layout(layout)
    except LayoutError as error:
        print(f"error: {error}", file=sys.stderr)  # it names the valid layouts
        return EXIT_USAGE
    except (ValueError, TypeError) as error:
        print(f"error: {error}", file=sys.stderr)
        return EXIT_USAGE

    name = policy_name(args)
    print(
        f"{'exporting' if args.export_latest else 'training'} {name} on {config.trained_on}: "
        f"{config.iterations} iterations x {config.num_envs} envs x {config.num_steps_per_env} steps; "
        f"run dir {run_dir}",
        file=sys.stderr,
    )
    try:
        if args.export_latest:
            result = export_latest(config, run_dir)
        else:
            result = train(config, run_dir, resume=args.resume, progress=not args.no_progress)
    except (FileExistsError, FileNotFoundError, ValueError) as error:
        print(f"error: {error}", file=sys.stderr)
        return EXIT_USAGE
    except KeyboardInterrupt:  # before the first iteration (recording demonstrations, building the runner)
        print("interrupted before training started", file=sys.stderr)
        return EXIT_INTERRUPTED
    if result.interrupted:
        return EXIT_INTERRUPTED

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
        print(f"validation of every checkpoint: {result.run_dir / 'validation.csv'}")
    if args.ship:
        shipped = args.ship_dir / f"{name}.pt"
        copy_file(result.policy_path, shipped)
        if args.baseline == STUDY_NAME:  # its networks are no ablation: their records stay beside them
            copy_file(result.run_dir / "config.json", args.ship_dir / f"{name}.config.json")
            reached = args.ship_dir / f"{name}.training.json"  # how far it trained: steps, time, metrics
            reached.write_text(json.dumps(summary, indent=2) + "\n")
            print(f"shipped: {shipped}, its config and {reached.name}")
        else:
            records = TRAINING_RECORDS / name
            for record in training_records(config):
                copy_file(result.run_dir / record, records / record)
            print(f"shipped: {shipped}; training records: {records}")
    if args.keep:
        kept = TRAINING_RECORDS / name / f"seed{config.seed}"
        for name in ("policy.pt", *training_records(config)):
            copy_file(result.run_dir / name, kept / name)
        print(f"kept: {kept} (score it with the loop in results/make_results.sh)")
    return 0


def sweep(args: argparse.Namespace) -> int:
    """Train every seed of ``--seeds`` of every ``--baseline`` with the executor of ``--executor``; the worst
    exit status."""
    several = len(set(args.seeds)) > 1
    untrainable = [name for name in args.baselines if name not in TRAINABLE]
    refused = [
        (args.seed is not None, "--seed: give the seeds with --seeds alone"),
        (several and args.ship, "--ship: seeds would overwrite each other's shipped policy; ship one seed"),
        (untrainable, f"--baseline {' '.join(untrainable)}: trainable baselines: {', '.join(TRAINABLE)}"),
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
                job.run_dir = str(Path(args.run_dir) / f"{policy_name(job)}__seed{seed}")
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
        else default_run_dir(TrainConfig(seed=args.seed), name=policy_name(args))
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


def training_records(config) -> tuple[str, ...]:
    """The files of a run that ``--ship`` and ``--keep`` keep beside its policy."""
    return ("config.json", "metrics.csv", *(("validation.csv",) if config.validation_episodes else ()))


def copy_file(source: Path, target: Path) -> None:
    """Copy atomically: a reader never sees a half-written file."""
    target.parent.mkdir(parents=True, exist_ok=True)
    temporary = target.with_name(target.name + ".tmp")
    shutil.copyfile(source, temporary)
    os.replace(temporary, target)


if __name__ == "__main__":
    raise SystemExit(main())
