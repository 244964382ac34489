"""Train a learned baseline: ``python -m cabinbench.train --baseline NAME [options of its trainer]``.

The baseline's class names its trainer (``Baseline.trainer``); this command loads it and hands it
every argument, so ``python -m cabinbench.train --baseline ppo_gail --help`` shows that trainer's
options. Several baselines of one trainer (``--baseline ppo_gail ppo --seeds 0 1 2``) are handed
over together: one sweep of them all, where the trainer sweeps. Exit status: 0 done; 2 a baseline
that cannot be loaded or does not learn (the ones that do are printed), or a trainer's own usage
error; 130 interrupted (finished checkpoints are kept).
"""

from __future__ import annotations

import importlib
import sys

from cabinbench.agents import baseline_class, registered_baselines
from cabinbench.cli import ArgumentParser, user_errors
from cabinbench.errors import EXIT_USAGE, BaselineError


def trainable_baselines() -> list[str]:
    """Registered baselines whose class names a trainer (those that cannot be imported here are left out)."""
    names = []
    for name in registered_baselines():
        try:
            if baseline_class(name).trainer:
                names.append(name)
        except BaselineError:
            continue
    return names


@user_errors  # a Ctrl-C before the trainer handles it (while torch loads): one line too
def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    parser = ArgumentParser(
        prog="python -m cabinbench.train",
        add_help=False,
        description="Train a learned baseline with the trainer it declares.",
    )
    parser.add_argument(
        "--baseline",
        nargs="+",
        required="-h" not in argv and "--help" not in argv,
        help="a learned baseline, e.g. ppo_gail (several, with the same trainer: one sweep of them)",
    )
    known, _ = parser.parse_known_args(argv)
    if known.baseline is None:
        parser.print_help()
        print(
            f"\ntrainable baselines: {', '.join(trainable_baselines())}; "
            "--baseline NAME --help shows a trainer's options"
        )
        return 0
    trainers = set()
    for name in known.baseline:
        try:
            trainer = baseline_class(name).trainer
        except BaselineError as error:
            print(f"error: {error}", file=sys.stderr)
            return EXIT_USAGE
        if not trainer:
            print(
                f"error: baseline {name!r} does not learn; trainable baselines: "
                f"{', '.join(trainable_baselines())}",
                file=sys.stderr,
            )
            return EXIT_USAGE
        trainers.add(trainer)
    if len(trainers) > 1:
        print(f"error: --baseline: one sweep needs one trainer; these have {len(trainers)}", file=sys.stderr)
        return EXIT_USAGE
    module_name, function_name = trainer.split(":", 1)
    return getattr(importlib.import_module(module_name), function_name)(argv)
