"""Each training run's best validated checkpoint against its last, on the episodes the leaderboard plays.

Usage: python scripts/compare_checkpoints.py [RUNS]   (from the repository root; RUNS defaults to
runs/train_policies, the run directories of scripts/train_policies.sh; about 20 minutes on 2 cores)

For every run directory with a validation.csv, the policy of its best checkpoint there
(``cabinbench.training_records.best_checkpoint``) and of its last one play 20 a320_cell episodes (seeds 0-19)
and 4 full_cabin episodes (seeds 0-3). Prints one row per run, then the mean per ablation: the table behind
``TrainConfig.export``'s choice.
"""

from __future__ import annotations

import json
import os
import sys
from collections import defaultdict
from pathlib import Path

import numpy as np
from cabinbench.baselines.ppo_gail.training import VALIDATION_DIR, TrainConfig, read_validation

from cabinbench.episodes import EpisodeJob, run_jobs
from cabinbench.training_records import best_checkpoint

EPISODES = {"a320_cell": 20, "full_cabin": 4}
COLUMNS = ("a320_cell coverage", "a320_cell success", "full_cabin cells", "full_cabin coverage")


def scores(ablation: str, policy: Path) -> tuple[float, ...]:
    jobs = [
        EpisodeJob(ablation, layout, seed=0, episode=episode, baseline_config={"checkpoint": str(policy)})
        for layout, count in EPISODES.items()
        for episode in range(count)
    ]
    records = defaultdict(list)
    for result in run_jobs(jobs, workers=os.cpu_count() or 1):
        records[result.job.layout].append(result.record)
    a320, cabin = records["a320_cell"], records["full_cabin"]
    return (
        np.mean([r["coverage"] for r in a320]),
        np.mean([r["success"] for r in a320]),
        np.mean([r["cells_cleared"] for r in cabin]),
        np.mean([r["coverage"] for r in cabin]),
    )


def main(argv: list[str]) -> int:
    runs = Path(argv[0] if argv else "runs/train_policies")
    by_ablation = defaultdict(lambda: {"best": [], "last": []})
    print("| run | best iteration | " + " | ".join(f"{column} best / last" for column in COLUMNS) + " |")
    print("|---|---:|" + "---:|" * len(COLUMNS))
    for run in sorted(path.parent for path in runs.glob("*/validation.csv")):
        config = TrainConfig.from_dict(json.loads((run / "config.json").read_text()))
        best, _ = best_checkpoint(read_validation(run, config))
        measured = {
            choice: scores(config.ablation, run / VALIDATION_DIR / f"policy_{iteration:06d}.pt")
            for choice, iteration in (("best", best), ("last", config.iterations))
        }
        for choice, values in measured.items():
            by_ablation[config.ablation][choice].append(values)
            by_ablation["all runs"][choice].append(values)
        print(f"| {run.name} | {best} | {cells(measured['best'], measured['last'])} |", flush=True)
    print(
        "\n| ablation (mean over runs) | " + " | ".join(f"{column} best / last" for column in COLUMNS) + " |"
    )
    print("|---|" + "---:|" * len(COLUMNS))
    all_runs_last = sorted(by_ablation.items(), key=lambda item: item[0] == "all runs")
    for ablation, choices in all_runs_last:
        means = {choice: np.mean(values, axis=0) for choice, values in choices.items()}
        print(f"| {ablation} ({len(choices['best'])}) | {cells(means['best'], means['last'])} |")
    return 0


def cells(best_values, last_values) -> str:
    """One table cell "best / last" per column."""
    return " | ".join(f"{best:.3g} / {last:.3g}" for best, last in zip(best_values, last_values))


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
