"""Learning curves of the learned baselines: each checkpoint's validation score against the env steps
its training had taken, per training seed. ``<out>/learning_curves.csv`` (a row per baseline, seed and
validated checkpoint), ``<out>/figures/learning_curves.png`` (a panel per baseline) and the "Learning
curves" section of ``leaderboard.md`` and of the paper.

Drawn from the training records alone (:mod:`cabinbench.training_records`): every run in
``<training>/<baseline>/`` (``--ship``) and its ``seed*/`` folders (``--keep``) whose ``validation.csv``
exists, its seed read from its ``config.json``.

- The metric: the headline ``clean_score`` where every seed of the baseline records it in
  ``validation.csv``, else the mean coverage; one metric per baseline, named in the ``metric`` column,
  so that no axis mixes two. Either is the mean over the checkpoint's validation episodes.
- The env steps: ``metrics.csv``'s ``timesteps`` at the checkpoint's iteration, what the trainer counted
  (rsl-rl runs: iterations × num_envs × num_steps_per_env, every robot's step; bc and dagger: the steps
  of every round collected so far, the expert's included). Where it is missing the cell is empty and
  ``env_steps_note`` says so; it also says what the count leaves out (a policy the run started from).
- The validation layouts, from ``validation.csv``'s ``layout`` column set against what the run trained
  on: ``cabin-v1-val (20 layouts)``, ``training layouts a320_cell + a320_tracking_cell``, or a sample of
  the training suite.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.figure import Figure  # no pyplot: no window, no global state

from cabinbench.errors import UsageError
from cabinbench.leaderboard.figures import save_figure
from cabinbench.stats import t_interval
from cabinbench.training_records import read_metrics

CURVES_CSV = "learning_curves.csv"
CURVES_FIGURE = "learning_curves.png"
HEADLINE_METRIC, FALLBACK_METRIC = "clean_score", "coverage"
HELD_OUT = "cabin-v1-val"  # the validation split no training run reads
COLUMNS = [
    "baseline",
    "seed",
    "iteration",
    "env_steps",
    "env_steps_note",
    "validation_layouts",
    "validation_episodes",
    "metric",
    "value",
]
PANEL_COLUMNS = 3
CURVES_CAPTION = (
    "Learning curves: each checkpoint's validation score against the env steps its training had taken, "
    "a panel per learned baseline; each training seed a thin line, the mean over the n seeds (n in the "
    "panel's title) a thick line with its 95% Student-t interval as a band. Each title names the layouts "
    "its baseline was validated on: only cabin-v1-val is held out from training."
)
"""The figure's caption in the paper and on the site."""


def training_runs(training: Path) -> dict[str, list[Path]]:
    """``{baseline: its run folders that hold a validation.csv}``, one per seed, the shipped one
    first. Two folders with the same seed are one run kept twice (``--ship`` and ``--keep``) when
    their validation records agree, and a user error otherwise."""
    runs: dict[str, list[Path]] = {}
    for baseline in sorted(path for path in training.glob("*") if path.is_dir()):
        seeds: dict[int, Path] = {}
        for folder in [baseline, *sorted(path.parent for path in baseline.glob("seed*/config.json"))]:
            if not (folder / "validation.csv").is_file():
                continue
            seed = json.loads((folder / "config.json").read_text(encoding="utf-8"))["seed"]
            if seed in seeds:
                if (seeds[seed] / "validation.csv").read_bytes() != (folder / "validation.csv").read_bytes():
                    raise UsageError(
                        f"--training: {seeds[seed]} and {folder} both hold seed {seed} of {baseline.name} "
                        "with different validation.csv; keep one of them"
                    )
                continue
            seeds[seed] = folder
        if seeds:
            runs[baseline.name] = list(seeds.values())
    return runs


def validation_layouts(config: dict, validation: pd.DataFrame) -> str:
    """Where a run's checkpoints were validated, in words, against what it trained on."""
    names = sorted(set(validation["layout"]))
    suite = config.get("suite")
    if names == [suite]:  # one row per checkpoint over a sample of the training suite
        episodes = int(validation["episodes"].iloc[0])
        return f"{suite}, its training suite ({episodes} layouts)"
    suites = {name.split("/")[0] for name in names if "/" in name}
    if len(suites) == 1 and all("/" in name for name in names):
        [validated] = suites
        return f"{validated} ({len(names)} layouts)" + (", its training suite" if validated == suite else "")
    if set(names) == set(config.get("layouts") or []):
        return f"training layouts {' + '.join(names)}"
    return " + ".join(names)


def env_steps_note(config: dict, missing: list[int]) -> str:
    """What a run's env steps count beyond the plain case, and where they are unknown."""
    notes = []
    if config.get("n_agents", 1) > 1:
        notes.append(f"every robot's step, {config['n_agents']} robots per team step")
    if config.get("init_policy"):
        notes.append(
            "started from the policy in its config.json's init_policy, whose training is not counted"
        )
    if missing:
        notes.append(f"unknown at iteration {', '.join(map(str, missing))}: metrics.csv has no timesteps")
    return "; ".join(notes)


def run_curve(baseline: str, folder: Path) -> pd.DataFrame:
    """One run's checkpoints: iteration, env steps, validation layouts and episodes, and the
    episode-weighted mean of each metric its ``validation.csv`` records."""
    config = json.loads((folder / "config.json").read_text(encoding="utf-8"))
    validation = pd.read_csv(folder / "validation.csv")
    steps = {
        int(row["iteration"]): int(float(row["timesteps"]))
        for row in read_metrics(folder / "metrics.csv")
        if row.get("timesteps") not in ("", None)
    }
    metrics = [name for name in (HEADLINE_METRIC, FALLBACK_METRIC) if name in validation]
    weighted = validation[metrics].mul(validation["episodes"], axis=0)
    checkpoints = (
        weighted.groupby(validation["iteration"])
        .sum()
        .div(validation.groupby("iteration")["episodes"].sum(), axis=0)
    )
    iterations = checkpoints.index.to_numpy()
    missing = [int(iteration) for iteration in iterations if iteration not in steps]
    return checkpoints.reset_index().assign(
        baseline=baseline,
        seed=int(config["seed"]),
        env_steps=[steps.get(int(iteration)) for iteration in iterations],
        env_steps_note=env_steps_note(config, missing),
        validation_layouts=validation_layouts(config, validation),
        validation_episodes=validation.groupby("iteration")["episodes"].sum().to_numpy(),
    )


def learning_curves(training: Path) -> pd.DataFrame:
    """Every validated checkpoint of every kept training run (:data:`COLUMNS`), one metric per
    baseline, sorted by baseline, seed and iteration."""
    tables = []
    for baseline, folders in training_runs(training).items():
        runs = [run_curve(baseline, folder) for folder in folders]
        metric = HEADLINE_METRIC if all(HEADLINE_METRIC in run for run in runs) else FALLBACK_METRIC
        tables += [run.assign(metric=metric, value=run[metric]) for run in runs]
    if not tables:
        return pd.DataFrame(columns=COLUMNS)
    curves = pd.concat(tables, ignore_index=True)[COLUMNS]
    curves["env_steps"] = curves["env_steps"].astype("Int64")  # empty where unknown, never a float
    return curves.sort_values(["baseline", "seed", "iteration"], kind="stable", ignore_index=True)


def mean_curve(curves: pd.DataFrame) -> pd.DataFrame:
    """One baseline's mean over seeds at the checkpoints every seed validated: env steps (their mean),
    the metric's mean and its 95% t interval over the seeds (n = seeds), clipped to [0, 1]."""
    seeds = curves["seed"].nunique()
    rows = []
    for _, checkpoint in curves.groupby("iteration"):
        if checkpoint["seed"].nunique() < seeds or checkpoint["env_steps"].isna().any():
            continue
        summary = t_interval(checkpoint["value"].to_numpy(dtype=float))
        rows.append(
            {
                "env_steps": float(checkpoint["env_steps"].astype(float).mean()),
                "mean": summary.mean,
                "low": np.clip(summary.low, 0.0, 1.0),
                "high": np.clip(summary.high, 0.0, 1.0),
            }
        )
    return pd.DataFrame(rows, columns=["env_steps", "mean", "low", "high"])


def learning_curves_figure(curves: pd.DataFrame, path: Path) -> bool:
    """A panel per baseline: each seed a thin line, the mean over seeds a thick line with its 95% t
    interval as a band (where every seed has the checkpoint); x env steps, y the metric. The title
    names the seeds and the validation layouts. False when there is nothing to draw."""
    baselines = sorted(set(curves["baseline"]))
    if not baselines:
        return False
    columns = min(PANEL_COLUMNS, len(baselines))
    rows = -(-len(baselines) // columns)
    figure = Figure(figsize=(4.8 * columns, 3.6 * rows))
    panels = np.atleast_1d(figure.subplots(rows, columns, squeeze=False)).ravel()
    for axes, baseline in zip(panels, baselines):
        own = curves[(curves["baseline"] == baseline) & curves["env_steps"].notna()]
        seeds = own["seed"].nunique()
        for index, (_, run) in enumerate(own.groupby("seed")):
            label = "each seed" if index == 0 else None
            millions = run["env_steps"].astype(float) / 1e6
            axes.plot(
                millions,
                run["value"],
                "o-",
                color="tab:blue",
                linewidth=0.7,
                markersize=2,
                alpha=0.5,
                label=label,
            )
        mean = mean_curve(own)
        axes.plot(
            mean["env_steps"] / 1e6,
            mean["mean"],
            "o-",
            color="tab:blue",
            linewidth=2,
            markersize=3,
            label=f"mean, n = {seeds}",
        )
        if seeds > 1:
            axes.fill_between(
                mean["env_steps"] / 1e6, mean["low"], mean["high"], color="tab:blue", alpha=0.2, linewidth=0
            )
        layouts = " | ".join(sorted(set(own["validation_layouts"])))
        axes.set_title(f"{baseline}: {seeds} seed{'s' * (seeds > 1)}\nvalidated on {layouts}", fontsize=8)
        axes.set_xlabel("env steps (millions)")
        axes.set_xlim(left=0)
        axes.set_ylabel(f"validation {own['metric'].iloc[0]}")
        axes.set_ylim(-0.02, 1.02)
        axes.grid(alpha=0.3)
        axes.legend(fontsize=7, loc="lower right")
    for axes in panels[len(baselines) :]:
        axes.set_axis_off()
    figure.suptitle(
        "Thin: each training seed. Thick: the mean over the n seeds; band: its 95% Student-t interval "
        "(n - 1 degrees of freedom, clipped to [0, 1])",
        fontsize=9,
    )
    save_figure(figure, path)
    return True


def learning_curves_text(curves: pd.DataFrame) -> str:
    """The section's body, from the curves alone: per baseline its seeds, validation layouts, metric and
    where it ended; which baselines were validated on layouts they trained on; what env steps count."""
    if curves.empty:
        return "No training records with validation yet (`python -m cabinbench.train ... --keep`).\n"
    lines = [
        "Each checkpoint's validation score against the env steps its training had taken "
        f"(`{CURVES_CSV}`). In the figure each training seed is a thin line, and the mean over the seeds a "
        "thick one with its 95% Student-t interval (n = seeds) as a band, at the checkpoints every seed "
        "validated. The table gives the last checkpoint's value: the mean over the seeds [min, max].",
        "",
        "| baseline | seeds (n) | validated on | metric | checkpoints | env steps at the last "
        "| value at the last |",
        "|---|---|---|---|---:|---:|---:|",
    ]
    on_own_layouts, notes = [], []
    for baseline, own in curves.groupby("baseline", sort=True):
        lines.append(summary_row(baseline, own))
        if not (own["validation_layouts"].str.startswith(HELD_OUT)).all():
            on_own_layouts.append(f"`{baseline}`")
        notes += [f"Env steps of `{baseline}`: {note}." for note in sorted(set(own["env_steps_note"]) - {""})]
    if on_own_layouts:
        lines += [
            "",
            "Validated on their own training layouts (or a sample of their training suite): "
            f"{', '.join(on_own_layouts)}. Such curves show how well a policy does where it learned, not on "
            f"layouts it never saw, and do not compare with curves on `{HELD_OUT}`. The validation protocol "
            f"of `{HELD_OUT}` applies to runs trained from now on.",
        ]
    return "\n".join([*lines, *(["", *notes] if notes else [])]) + "\n"


def summary_row(baseline: str, own: pd.DataFrame) -> str:
    """One baseline's row of the section's table."""
    last = own.sort_values("iteration", kind="stable").groupby("seed").tail(1)
    seeds = sorted(own["seed"].unique())
    steps = last["env_steps"].dropna().astype(float)
    cells = [
        f"`{baseline}`",
        f"{', '.join(map(str, seeds))} ({len(seeds)})",
        "; ".join(sorted(set(own["validation_layouts"]))),
        own["metric"].iloc[0],
        str(own.groupby("seed")["iteration"].nunique().max()),
        f"{steps.mean() / 1e6:.2f} M" if len(steps) == len(last) else "unknown",
        f"{last['value'].mean():.3f} [{last['value'].min():.3f}, {last['value'].max():.3f}]",
    ]
    return "| " + " | ".join(cells) + " |"


def read_learning_curves(path: Path) -> pd.DataFrame:
    """A ``learning_curves.csv`` as written: what the leaderboard's section and the paper's are drawn from,
    so that the two agree."""
    return pd.read_csv(path, dtype={"env_steps": "Int64", "env_steps_note": str}, keep_default_na=False)


def learning_curves_section(results: Path) -> str:
    """The paper's learning curves section, from ``<results>/learning_curves.csv``; a note when it is
    missing."""
    path = results / CURVES_CSV
    if not path.is_file():
        return f"(no `{CURVES_CSV}` yet: run `python -m cabinbench.leaderboard`)"
    return learning_curves_text(read_learning_curves(path)).strip()


def write_learning_curves(training: Path, out: Path) -> tuple[str, list[Path]]:
    """``<out>/learning_curves.csv``, ``<out>/figures/learning_curves.png`` (when there are curves; an
    earlier one is removed when not) and the "Learning curves" section of ``leaderboard.md``; the section
    and the figures written."""
    learning_curves(training).to_csv(out / CURVES_CSV, index=False, float_format="%.6g", lineterminator="\n")
    curves = read_learning_curves(out / CURVES_CSV)
    figure = out / "figures" / CURVES_FIGURE
    figure.parent.mkdir(parents=True, exist_ok=True)
    drawn = learning_curves_figure(curves, figure)
    if not drawn:
        figure.unlink(missing_ok=True)
    section = "## Learning curves\n\n" + learning_curves_text(curves)
    if drawn:
        section += f"\n![learning curves](figures/{CURVES_FIGURE})\n"
    return section + "\n", [figure] if drawn else []
