"""Groups of training runs compared on cabin-v1-val alone: the headline score of each seed's best validated
checkpoint (the one ``--export best`` exports) and of its last, and per group the mean with a t interval
over seeds. The first group is the reference; each other group's mean is placed against the reference's
seed spread (the lowest to the highest of its seeds), the rule by which a cheaper training setting is
adopted (issue 42, item 7; docs/experiments.md, "What a training iteration costs").

Usage (from the repository root):
    python scripts/compare_runs.py --group defaults runs/train_policies/ppo_gail__seed{0,1,2} \\
        --group cheaper runs/cheaper/ppo_gail__seed{0,1,2}

Reads each run's config.json, metrics.csv and validation.csv; plays nothing. Every run must have been
validated on the same cabin-v1-val layouts, so that the groups are compared episode for episode.
"""

from __future__ import annotations

import argparse
import csv
import json
import sys
from pathlib import Path

from cabinbench.stats import t_interval
from cabinbench.training_records import best_checkpoint, read_metrics, validation_score


def run_scores(run: Path) -> dict:
    """One run's seed, chosen and last checkpoint scores and training time; a ValueError names what is
    missing."""
    for name in ("config.json", "metrics.csv", "validation.csv"):
        if not (run / name).is_file():
            raise ValueError(f"{run}: no {name}; give the folder of a finished training run")
    with open(run / "validation.csv", newline="") as file:
        validation = list(csv.DictReader(file))
    if not validation or any(row.get("clean_score") in (None, "") for row in validation):
        raise ValueError(
            f"{run}/validation.csv: no clean_score; only runs validated on cabin-v1-val are compared"
        )
    best, best_score = best_checkpoint(validation)
    last = max(int(row["iteration"]) for row in validation)
    metrics = read_metrics(run / "metrics.csv")
    return {
        "seed": json.loads((run / "config.json").read_text())["seed"],
        "layouts": sorted({row["layout"] for row in validation}),
        "best": best,
        "best_score": best_score,
        "last": last,
        "last_score": validation_score([row for row in validation if int(row["iteration"]) == last]),
        "minutes": float(metrics[-1]["train_time"]) / 60,
        "s_per_iteration": float(metrics[-1]["train_time"]) / int(metrics[-1]["iteration"]),
    }


def report(groups: dict[str, list[dict]]) -> str:
    lines = [
        "| group | seed | chosen checkpoint | val clean_score there | at the last checkpoint | "
        "training min | s / iteration |",
        "|---|---|---|---|---|---|---|",
    ]
    for name, runs in groups.items():
        lines += [
            f"| {name} | {run['seed']} | {run['best']} | {run['best_score']:.3f} | {run['last_score']:.3f} "
            f"| {run['minutes']:.1f} | {run['s_per_iteration']:.2f} |"
            for run in runs
        ]
    lines.append("")
    reference, *others = groups
    low = min(run["best_score"] for run in groups[reference])
    high = max(run["best_score"] for run in groups[reference])
    for name, runs in groups.items():
        chosen = t_interval([run["best_score"] for run in runs])
        minutes = sum(run["minutes"] for run in runs) / len(runs)
        interval = (
            f"[{chosen.low:.3f}, {chosen.high:.3f}] (t interval, n = {chosen.n} seeds)"
            if chosen.n > 1
            else "(one seed: no interval)"
        )
        line = f"- {name}: chosen checkpoints' val clean_score {chosen.mean:.3f} {interval}; "
        line += f"{minutes:.1f} min of training a run"
        if name != reference:
            place = "below" if chosen.mean < low else "above" if chosen.mean > high else "within"
            line += f"; its mean lies {place} {reference}'s seed spread [{low:.3f}, {high:.3f}]"
        lines.append(line)
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "--group",
        nargs="+",
        action="append",
        required=True,
        metavar=("NAME", "RUN"),
        help="a name, then the run folders of its seeds (two groups or more; the first is the reference)",
    )
    args = parser.parse_args(argv)
    try:
        if len(args.group) < 2 or any(len(group) < 2 for group in args.group):
            raise ValueError("give at least two --group NAME RUN [RUN ...], each with at least one run")
        groups = {name: [run_scores(Path(run)) for run in runs] for name, *runs in args.group}
        layouts = {tuple(run["layouts"]) for runs in groups.values() for run in runs}
        if len(layouts) > 1:
            raise ValueError(
                "the runs were validated on different layouts; compare runs of one validation_episodes"
            )
    except ValueError as error:
        print(f"compare_runs: {error}", file=sys.stderr)
        return 2
    print(report(groups))
    return 0


if __name__ == "__main__":
    sys.exit(main())
