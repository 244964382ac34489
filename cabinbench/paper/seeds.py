"""A learned baseline's training seeds in the reproduction report: which seeds exist, which seed an
episode's policy came from, and a claim judged on every seed.

The seeds are the shipped policy (its ``config.json`` names its seed; the study's pair ships
``ppo_gail_study_<stage>.config.json`` beside its networks) and every further seed ``python -m
cabinbench.train ... --seed S --keep`` kept in ``results/training/<name>/seed<S>/policy.pt``; for the
study's pair ``<name>`` is ``ppo_gail_study_cleaning`` and ``ppo_gail_study_tracking``, and a seed counts
when both its stages were kept. ``scripts/make_results.sh`` scores the further seeds into
``results/ablation_runs``.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from pathlib import Path

import pandas as pd

from cabinbench.leaderboard.headline import CHECKPOINTS
from cabinbench.records import read_records
from cabinbench.stats import mean_ci, t_interval

STUDY = "ppo_gail_study"
STUDY_STAGES = ("cleaning", "tracking")


def seeds_verdict(verdicts: list[str]) -> str:
    """One verdict from each training seed's: *reproduced* when every seed reproduces the claim, *not*
    when none does even partly, else *partly*."""
    if all(verdict == "reproduced" for verdict in verdicts):
        return "reproduced"
    return "not" if all(verdict == "not" for verdict in verdicts) else "partly"


def seed_number(label: str) -> int:
    return int(label.removeprefix("seed")) if label.removeprefix("seed").isdigit() else -1


def training_seed(learner: str, baseline_config: dict, shipped: str) -> str:
    """The training seed an episode's policy came from: the folder of its policy file (``seed1`` of
    ``results/training/<name>/seed1/policy.pt``; the study's pair by its cleaning network), or
    ``shipped`` for the shipped policy."""
    policy = baseline_config.get("cleaning" if learner == STUDY else "checkpoint")
    return Path(policy).parent.name if policy and Path(policy).parent.name != CHECKPOINTS.name else shipped


def learner_seeds(results: Path, configs: dict[str, dict | None]) -> dict[str, list[str]]:
    """Each learner's training seeds that exist (``configs``: learner -> its training configuration or
    None): the shipped policy's (``seed<S>`` from its config, ``shipped`` without one), then each seed
    ``train --keep`` kept; the study's pair counts a seed when both its stages were kept."""
    seeds = {}
    for learner in configs:
        names = [f"{learner}_{stage}" for stage in STUDY_STAGES] if learner == STUDY else [learner]
        kept = [
            {path.parent.name for path in (results / "training" / name).glob("seed*/policy.pt")}
            for name in names
        ]
        config = configs.get(learner)
        shipped = f"seed{config['seed']}" if config and "seed" in config else "shipped"
        further = sorted(set.intersection(*kept) - {shipped}, key=seed_number)
        seeds[learner] = [shipped, *further]
    return seeds


def learner_records(records: pd.DataFrame, results: Path, seeds: dict[str, list[str]]) -> pd.DataFrame:
    """The episodes of ``seeds``' learners, each with the training ``seed`` of its policy: the shipped
    policies' from ``records``, every further seed's from ``results/ablation_runs``."""
    further = results / "ablation_runs"
    frames = [records, read_records(further) if further.is_dir() else pd.DataFrame()]
    frames = [frame[frame["baseline"].isin(list(seeds))] for frame in frames if not frame.empty]
    if not frames:
        return pd.DataFrame()
    learned = pd.concat(frames, ignore_index=True)
    labels = [
        training_seed(learner, config, seeds[learner][0])
        for learner, config in zip(learned["baseline"], learned["baseline_config"])
    ]
    return learned.assign(seed=labels)


def over_seeds(
    runs: pd.DataFrame,
    measure: Callable[[pd.DataFrame], tuple[float, str]],
    verdict_of: Callable[[float], str],
    expected: Iterable[str] = (),
    number_format: str = ".1%",
) -> tuple[str, str, str]:
    """A claim judged on each training seed's episodes (``runs``' ``seed`` column): (ours, verdict,
    why). ``measure`` gives a seed's value and its text; ours lists every seed's, then, from two seeds
    on, their mean with a t interval over seeds (a fraction's clipped to [0, 1]); the verdict is
    :func:`seeds_verdict` of the seeds'; why says how many seeds reproduce it and names the
    ``expected`` seeds that have no episodes here."""
    values = {
        seed: measure(episodes)
        for seed, episodes in sorted(runs.groupby("seed"), key=lambda item: seed_number(item[0]))
    }
    verdicts = [verdict_of(value) for value, _ in values.values()]
    parts = [f"{seed}: {text}" for seed, (_, text) in values.items()]
    if len(values) > 1:
        summary = t_interval([value for value, _ in values.values()])
        low, high = summary.low, summary.high
        if number_format.endswith("%"):  # a fraction's interval stays in [0, 1]
            low, high = max(0.0, low), min(1.0, high)
        parts.append(
            f"over {summary.n} seeds {summary.mean:{number_format}} "
            f"[{low:{number_format}}, {high:{number_format}}]"
        )
    why = f"{verdicts.count('reproduced')} of {len(verdicts)} training seeds reproduce it"
    missing = [seed for seed in expected if seed not in values]
    if missing:
        why += f" ({', '.join(missing)} not scored here)"
    return "; ".join(parts), seeds_verdict(verdicts), why


def interval(values, number_format: str = ".1%") -> str:
    summary = mean_ci(list(values))
    return f"{summary.mean:{number_format}} [{summary.low:{number_format}}, {summary.high:{number_format}}]"


def coverage_of(episodes: pd.DataFrame) -> tuple[float, str]:
    return float(episodes["coverage_free"].mean()), interval(episodes["coverage_free"])


def completed_of(episodes: pd.DataFrame) -> tuple[float, str]:
    """The share of episodes that completed the mission as the study counts it: every goal marker (its
    white cubes) reached, which ends a sequential episode."""
    rate = float(episodes["goals_reached"].mean())
    return rate, f"{rate:.0%} of {len(episodes)}"
