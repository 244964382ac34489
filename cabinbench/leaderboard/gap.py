"""The leaderboard's generalisation gap (:func:`gap_section`): every learner scored on the training suite
``cabin-v1-train`` (``ppo_gail``, trained on the study's two cells, and ``ppo_gail_suite``, on the suite),
on the layouts it trained on, on ``cabin-v1-test`` and on ``cabin-v1-ood``, and the differences test −
train and ood − train, over every training seed, with a generated finding.

The train column is each learner's own training layouts, read from its runs' ``config.json``
(the baseline's ``training_layouts``, through the registry: ``baselines/ppo_gail/training/suite_draws.py``
for the learners here): a run on cells trained on
those cells; a run on the suite drew a layout at every reset, which the config fixes, so the column is
each seed's first layouts of the suite that its run began an episode on for certain. The first layouts
of a suite are not its training layouts: a run of 322 episodes over 500 layouts never saw most of them.
Where the seeds' samples differ (runs with env seeds of their own) the layouts are nested in the seeds,
and the bootstrap draws each seed's apart; where they are one sample, crossed with them.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd

from cabinbench.agents import baseline_class
from cabinbench.layouts.suites import get_suite
from cabinbench.leaderboard.suites import from_random_starts, suite_cells
from cabinbench.leaderboard.table import SHIPPED, markdown_cell, policy_of
from cabinbench.stats import stratified_bootstrap, stratified_difference

GAP_SPLITS = {"train": "cabin-v1-train", "test": "cabin-v1-test", "ood": "cabin-v1-ood"}
"""The generalisation gap's splits: the training suite, its held-out test split, out of distribution."""
GAP_METRIC = "coverage"
TRAIN_SAMPLE = 30
"""How many of a suite learner's training layouts the train column scores, per training seed
(``scripts/make_results.sh`` plays, for each seed, the suite's first layouts up to the last of its own)."""


def training_configs(policies: set[str], baseline: str, training: Path) -> dict[str, dict]:
    """{policy: its run's ``config.json``} of the ``policies`` (as :func:`policy_of` names them) whose run
    has one: the shipped policy's in ``training/<baseline>/``, a kept seed's beside its checkpoint."""
    configs = {}
    for policy in sorted(policies):
        folder = training / baseline if policy == SHIPPED else Path(policy).parent
        if (folder / "config.json").is_file():
            configs[policy] = json.loads((folder / "config.json").read_text(encoding="utf-8"))
    return configs


def train_split(episodes: pd.DataFrame, baseline: str, training: Path) -> tuple[pd.DataFrame, dict]:
    """The baseline's episodes from random starts on each policy's training sample, by the policies whose
    training config is known, and what the samples are: ``layouts`` ({policy: its sample}), ``own`` (whether
    they differ: layouts nested in seeds), ``suite`` (None: cells), ``first`` (the fewest and the most of the
    suite's first layouts holding a sample), ``policies``, ``shared_envs`` of ``num_envs`` (envs the runs
    seeded alike)."""
    policies = {policy_of(config) for config in episodes["baseline_config"]}
    configs = training_configs(policies, baseline, training)
    learner = baseline_class(baseline)
    samples = {
        policy: learner.training_layouts([config], TRAIN_SAMPLE)[0] for policy, config in configs.items()
    }
    shared = learner.training_layouts(list(configs.values()), TRAIN_SAMPLE)[1] if configs else 0
    suite = next(iter(configs.values())).get("suite") if configs else None
    policy = episodes["baseline_config"].map(policy_of)
    own_sample = pd.Series(
        [layout in samples.get(name, ()) for name, layout in zip(policy, episodes["layout"])], episodes.index
    )
    chosen = episodes[from_random_starts(episodes) & policy.isin(configs) & own_sample]
    if suite:
        chosen = chosen[chosen["suite"] == suite]
    first = None
    if suite and any(samples.values()):
        ends = [get_suite(suite).layout_names.index(sample[-1]) + 1 for sample in samples.values() if sample]
        first = (min(ends), max(ends))
    envs = max((config["num_envs"] for config in configs.values()), default=0)
    return chosen, {
        "layouts": samples,
        "own": len({tuple(sample) for sample in samples.values()}) > 1,
        "suite": suite,
        "first": first,
        "policies": len(configs),
        "shared_envs": shared,
        "num_envs": envs,
    }


def gap_rows(records: pd.DataFrame, training: Path) -> list[dict]:
    """Per baseline (sequential, K = 1) with records on the training suite: its ``GAP_METRIC`` score on its
    training sample (:func:`train_split`) and on each held-out split
    (:func:`~cabinbench.stats.stratified_bootstrap` over its training seeds and the split's layouts), each
    held-out split's difference to the train column (seeds paired), and the sample (``sample``)."""
    episodes = records[(records["protocol"] == "sequential") & (records["n_agents"] == 1)]
    learners = sorted(set(episodes.loc[episodes["suite"] == GAP_SPLITS["train"], "baseline"]))
    rows = []
    for baseline in learners:
        own = episodes[episodes["baseline"] == baseline]
        trained, sample = train_split(own, baseline, training)
        row, cells = {"baseline": baseline, "sample": sample}, {}
        for split, suite in GAP_SPLITS.items():
            chosen = trained if split == "train" else own[own["suite"] == suite]
            if chosen.empty:
                continue
            own_layouts = split == "train" and sample["own"]
            found, _ = suite_cells(chosen, crossed=not own_layouts)
            cells[split] = {key: cell[GAP_METRIC].astype(float) for key, cell in found.items()}
            row[split] = stratified_bootstrap(cells[split], own_layouts=own_layouts)
            row[f"{split}_layouts"] = len({layout for _, layout in found})
            row[f"{split}_seeds"] = len({policy for policy, _ in found})
        for split in ("test", "ood"):
            if split in cells and "train" in cells:
                row[f"{split}_gap"] = stratified_difference(cells["train"], cells[split], sample["own"])
        rows.append(row)
    return rows


def train_column_text(rows: list[dict]) -> str:
    """Which layouts each row's train column is, and why, in words."""
    said = []
    for row in rows:
        sample = row["sample"]
        layouts = next(iter(sample["layouts"].values()), [])
        if not layouts:
            said.append(f"{row['baseline']}: none (no training config.json of its policies)")
        elif sample["suite"] is None:
            said.append(f"{row['baseline']}: its training cells, {' + '.join(layouts)}")
        elif sample["own"]:
            low, high = sample["first"]
            said.append(
                f"{row['baseline']}: for each of its {sample['policies']} training seeds, the first "
                f"{len(layouts)} layouts of {sample['suite']} (of the suite's first {low}-{high}) on which "
                "its own run began an episode for certain, reconstructed from the run's config.json (the "
                "layout each env drew at each reset: `baselines/ppo_gail/training/suite_draws.py`); the "
                "generator draws a suite's layouts independently by index, so they are a random sample of "
                "its training layouts, and the seeds' runs seeded their envs apart, so each seed has layouts "
                "of its own (nested in the seeds: the bootstrap draws each seed's apart)"
            )
        else:
            said.append(
                f"{row['baseline']}: the first {len(layouts)} layouts of {sample['suite']} (of the "
                f"suite's first {sample['first'][1]}) on which the runs of all its {sample['policies']} "
                "training seeds began an episode for certain, reconstructed from each run's config.json "
                "(the layout each env drew at each reset: `baselines/ppo_gail/training/suite_draws.py`); "
                "the generator draws a suite's layouts independently by index, so they are a random sample "
                "of its training layouts"
            )
            if sample["policies"] > 1:
                said[-1] += (
                    f" (the seeds' runs seeded {sample['shared_envs']} of their {sample['num_envs']} envs "
                    "alike, env i of seed s with s + i, so they trained on nearly the same layouts)"
                )
    return "; ".join(said)


def gap_finding(rows: list[dict]) -> str:
    """The gap in words, from the intervals."""
    said = []
    for row in rows:
        parts = []
        for split in ("test", "ood"):
            gap = row.get(f"{split}_gap")
            if gap is None:
                continue
            if np.isnan(gap.low):
                verdict = "no interval: not the same training seeds on both"
            elif gap.high < 0 or gap.low > 0:
                verdict = "its interval excludes 0"
            else:
                verdict = "its interval includes 0: no gap shown"
            parts.append(f"{split} {gap.mean:+.3f} ({verdict})")
        if "train" not in row:
            said.append(f"{row['baseline']} has no records on the layouts it trained on: no gap")
            continue
        said.append(
            f"{row['baseline']} covers {row['train'].mean:.3f} of the layouts it trained on, and differs on "
            + ", ".join(parts)
        )
    text = "Finding: " + "; ".join(said) + "."
    test = [row for row in rows if "test" in row]
    if len(test) > 1:
        best = max(test, key=lambda row: row["test"].mean)
        text += f" On the held-out test layouts {best['baseline']} covers most ({best['test'].mean:.3f})."
    return text


def gap_section(records: pd.DataFrame, training: Path) -> list[str]:
    """The generalisation-gap table and its finding (nothing without records on the training suite);
    ``training``: the folder of the shipped policies' training records (``results/training``)."""
    rows = gap_rows(records, training)
    if not rows:
        return []
    lines = [
        "#### Generalisation gap",
        "",
        f"{GAP_METRIC} of each learner on the layouts it trained on (train), on the held-out "
        f"{GAP_SPLITS['test']} and on the out-of-distribution {GAP_SPLITS['ood']}: episodes from random "
        "starts (the suite protocol), the mean over training seeds and layouts ± half-width of the "
        "stratified bootstrap 95% interval (training seeds, layouts and episodes resampled); a gap is "
        "held-out minus train, its interval with the training seeds resampled jointly. The train column is "
        f"{train_column_text(rows)}. Training seeds: per split when they differ (train/test/ood).",
        "",
        "| baseline | training seeds | train (layouts) | test (layouts) | ood (layouts) | test − train | "
        "ood − train |",
        "|---|---:|---:|---:|---:|---:|---:|",
    ]
    for row in rows:
        scores = [
            f"{markdown_cell(row[split], '.3f')} ({row[f'{split}_layouts']})" if split in row else "—"
            for split in GAP_SPLITS
        ]
        gaps = [
            markdown_cell(row[f"{split}_gap"], "+.3f", bounds=True) if f"{split}_gap" in row else "—"
            for split in ("test", "ood")
        ]
        seeds = [str(row[f"{split}_seeds"]) for split in GAP_SPLITS if split in row]
        seeds = seeds[:1] if len(set(seeds)) == 1 else seeds
        lines.append(f"| {row['baseline']} | {'/'.join(seeds)} | " + " | ".join(scores + gaps) + " |")
    return lines + ["", gap_finding(rows), ""]
