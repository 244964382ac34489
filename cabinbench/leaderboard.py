"""Regenerate the leaderboard from the per-episode records: ``python -m cabinbench.leaderboard``.

    python -m cabinbench.leaderboard [--runs results/runs] [--ablation-runs results/ablation_runs]
        [--training results/training] [--out results]

Reads every ``*.jsonl`` in ``--runs`` and ``--ablation-runs`` (default: ``ablation_runs`` beside ``--runs``),
and the ``.npz`` beside each (see :mod:`cabinbench.records`), and writes, from those files only:

- ``<out>/leaderboard.md`` and ``<out>/leaderboard.csv``: one row per (layout, baseline,
  protocol, K), sorted; per metric the mean and its 95% bootstrap interval (:mod:`cabinbench.stats`),
  the interquartile mean of coverage, ``t90`` over the episodes that reached 90% with the fraction
  that did, the number of episodes and of distinct episode seeds, and the layout's navigation
  complexity (normalised and total). No timestamps: the same records give byte-identical files.
- ``<out>/figures/``:
  ``trajectory__<layout>__<baseline>__<protocol>__k<K>.png``: the first episode (lowest seed, then
  episode index) drawn from its stored final coverage raster and sampled positions (the seed's
  Fig. 5.11); ``coverage_time__<layout>.png``: coverage over simulated time, one line per
  baseline (median over episodes, interquartile band); ``bars_coverage.png`` and
  ``bars_time.png``: means with 95% interval error bars, grouped by layout;
  ``makespan_agents.png``: team makespan against the number of robots, one panel per layout, for the
  settings run with several K whose episodes all succeeded (a makespan cut short by the step limit
  measures the limit, not the team), with the ideal T(1)/K and each K's speed-up T(1)/T(K);
  ``training__<baseline>.png``: the training curves (the seed's Fig. 5.8) of each shipped learned
  policy, from the ``metrics.csv`` that ``python -m cabinbench.train --ship`` keeps in ``--training``.
- ``<out>/uncovered.md`` and ``<out>/uncovered.csv``: where each row's uncovered floor lies. Per band of distance
  from the nearest wall (``CLEARANCE_BANDS`` of :mod:`cabinbench.metrics`), the uncovered coverable area over the
  whole coverable area, averaged over the row's episodes from their stored final coverage rasters (the bands sum to
  1 - coverage), beside the band's share of the layout. Rows whose layout file is not found, or has changed since
  the run, are left out with a warning.
- ``<out>/ablation.md`` and ``<out>/ablation.csv``: the learned baselines across training runs. One training
  run per ablation says little: two seeds of the same command differ as much as the ablations do. So the
  policies of further training seeds (``results/training/<baseline>/seed<S>/policy.pt``) are run like the
  shipped ones, into ``--ablation-runs`` (only those records: the leaderboard's rows stay the shipped
  policies'); per (layout, baseline) the table gives each policy's mean over its episodes, and the mean over
  policies with the lowest and highest policy. The shipped policies' episodes come from ``--runs``.
  ``figures/ablation_coverage.png`` draws the coverage: a bar for the mean over policies, a dot per policy.

Exits 1 when there are no records.
"""

from __future__ import annotations

import argparse
import json
import sys
from functools import cache, lru_cache
from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib import colormaps
from matplotlib.figure import Figure  # no pyplot: figures render with Agg, no window, no global state

from .layout import LayoutError, load_layout
from .metrics import CLEARANCE_BANDS, uncovered_by_clearance
from .records import read_records, read_trajectories, safe_name
from .render import COVERED, FLOOR, OBSTACLE, ROBOT_COLOURS
from .stats import Summary, iqm, mean_ci, summarize
from .training_records import plot_curves, read_metrics
from .world import TIME_STEP

ROW_KEY = ["layout", "baseline", "protocol", "n_agents"]
SORT_KEY = ["layout", "protocol", "n_agents", "baseline"]  # baselines side by side per setting
# metric → (column title, format of its numbers)
COLUMNS = {
    "coverage": ("coverage", ".3f"),
    "coverage_free": ("coverage_free", ".3f"),
    "path_length": ("path_length (m)", ".1f"),
    "path_efficiency": ("path_efficiency", ".3f"),
    "time": ("time (s)", ".1f"),
    "t90": ("t90 (s) [reached]", ".1f"),
    "collisions": ("collisions", ".1f"),
    "success": ("success", ".2f"),
}
CONFIG_FIELDS = ("layout_hash", "env_config", "baseline_config")  # should not differ within a row
stored_run = lru_cache(maxsize=None)(read_trajectories)  # each .npz is read once per leaderboard
PNG_METADATA = {"Software": None}  # keeps committed figures free of the matplotlib version string
CURVE_POINTS = 200
ABLATION_METRICS = {"coverage": ".3f", "success": ".2f", "cells_cleared": ".2f"}  # metric → number format
SHIPPED = "shipped"  # the policy a learned baseline runs when no checkpoint is given
SIGNALS = (
    "use_curiosity",
    "use_gail",
)  # the reward signals a learned baseline adds to PPO (its training config)


# ------------------------------------------------------------------------------------ rows
def row_label(row) -> str:
    """How a row is named in figures: the baseline, plus protocol and K when not the default."""
    if row["protocol"] == "sequential" and row["n_agents"] == 1:
        return str(row["baseline"])
    return f"{row['baseline']} [{row['protocol']}, K={row['n_agents']}]"


def group_rows(records: pd.DataFrame) -> list[tuple[dict, pd.DataFrame]]:
    """(row key, its episodes sorted by seed, episode, file) for every row, in table order."""
    records = records.sort_values(["seed", "episode", "source"], kind="stable")
    groups = []
    for values, episodes in records.groupby(ROW_KEY, sort=False):
        groups.append((dict(zip(ROW_KEY, values)), episodes))
    return sorted(groups, key=lambda group: tuple(group[0][name] for name in SORT_KEY))


def summarize_row(key: dict, episodes: pd.DataFrame) -> dict:
    """One leaderboard row: identifiers, counts, complexity, and a Summary per metric."""
    complexity = episodes["layout_complexity"].iloc[0]
    row = {
        **key,
        "episodes": len(episodes),
        "seeds": int((episodes["seed"] + episodes["episode"]).nunique()),
        "complexity_normalized": complexity["normalized"],
        "complexity_total": complexity["total"],
        "coverage_iqm": iqm(episodes["coverage"]),
    }
    for metric in COLUMNS:
        row[metric] = summarize(metric, episodes[metric].tolist())
    return row


def mixed_settings(key: dict, episodes: pd.DataFrame) -> list[str]:
    """Notes for rows that pool episodes run under different layouts files or settings."""
    notes = []
    for name in CONFIG_FIELDS:
        distinct = sorted({repr(value) for value in episodes[name]})
        if len(distinct) > 1:
            notes.append(
                f"{row_name(key)} pools {len(distinct)} different `{name}` values: {', '.join(distinct)}"
            )
    return notes


def row_name(key: dict) -> str:
    return f"{key['layout']} / {key['baseline']} / {key['protocol']} / K={key['n_agents']}"


# ---------------------------------------------------------------------------------- tables
def csv_table(rows: list[dict]) -> pd.DataFrame:
    table = []
    for row in rows:
        line = {
            name: row[name]
            for name in (*ROW_KEY, "episodes", "seeds", "complexity_normalized", "complexity_total")
        }
        for metric in COLUMNS:
            summary: Summary = row[metric]
            line.update(
                {
                    f"{metric}_mean": summary.mean,
                    f"{metric}_ci_low": summary.low,
                    f"{metric}_ci_high": summary.high,
                }
            )
            if metric == "coverage":
                line["coverage_iqm"] = row["coverage_iqm"]
            if summary.reached is not None:
                line[f"{metric}_reached"] = summary.reached
        table.append(line)
    return pd.DataFrame(table)


def markdown_cell(summary: Summary, number_format: str) -> str:
    """``mean ± half-width of the 95% interval``; the mean alone when there is no interval."""
    if np.isnan(summary.mean):
        cell = "—"
    elif np.isnan(summary.low):
        cell = f"{summary.mean:{number_format}}"
    else:
        cell = f"{summary.mean:{number_format}} ± {(summary.high - summary.low) / 2:{number_format}}"
    return cell if summary.reached is None else f"{cell} [{summary.reached:.0%}]"


def markdown(rows: list[dict], records: pd.DataFrame, runs: str, command: str, notes: list[str]) -> str:
    versions = ", ".join(sorted(set(records["benchmark_version"].astype(str))))
    commits = sorted({str(commit)[:12] for commit in records["git_commit"] if isinstance(commit, str)})
    lines = [
        "# cabinbench leaderboard",
        "",
        f"Generated by `{command}` from the per-episode records in `{runs}`; do not edit by hand.",
        "If you use these results, please cite cabinbench as described in `CITATION.cff` at the repository root.",
        "",
        f"{len(records)} episodes from {records['source'].nunique()} record files; benchmark version {versions}; "
        f"code commits {', '.join(commits) if commits else 'unknown'}.",
        "",
        "Cells are `mean ± half-width of the 95% percentile-bootstrap interval` over episodes (exact, possibly "
        "asymmetric bounds in `leaderboard.csv`); a lone episode has no interval. IQM: interquartile mean. "
        "t90: mean over the episodes that reached 90% coverage, [the fraction that did]. Seeds: distinct episode "
        "seeds (run seed + episode index). Complexity: the layout's navigation complexity (seed §4.1), "
        "normalised / total. Metric definitions: `cabinbench/metrics.py`.",
        "",
    ]
    titles = [
        "layout",
        "complexity",
        "baseline",
        "protocol",
        "K",
        "episodes",
        "seeds",
        "coverage",
        "coverage IQM",
        *(title for metric, (title, _) in COLUMNS.items() if metric != "coverage"),
    ]
    lines.append("| " + " | ".join(titles) + " |")
    lines.append("|" + "|".join("---" if index < 5 else "---:" for index in range(len(titles))) + "|")
    for row in rows:
        cells = [
            row["layout"],
            f"{row['complexity_normalized']:.4f} / {row['complexity_total']:.2f}",
            row["baseline"],
            row["protocol"],
            str(row["n_agents"]),
            str(row["episodes"]),
            str(row["seeds"]),
            markdown_cell(row["coverage"], ".3f"),
            f"{row['coverage_iqm']:.3f}",
        ]
        cells += [
            markdown_cell(row[metric], number_format)
            for metric, (_, number_format) in COLUMNS.items()
            if metric != "coverage"
        ]
        lines.append("| " + " | ".join(cells) + " |")
    if notes:
        lines += ["", "Notes:", "", *(f"- {note}" for note in notes)]
    return "\n".join(lines) + "\n"


# ------------------------------------------------------------------------ where the uncovered floor lies
@cache
def recorded_layout(name: str, content_hash: str):
    """The layout a run recorded, or None when it cannot be loaded or its file has changed since."""
    try:
        layout = load_layout(name)
    except (OSError, LayoutError):
        return None
    return layout if layout.content_hash == content_hash else None


def uncovered_rows(groups: list[tuple[dict, pd.DataFrame]]) -> tuple[list[dict], list[str]]:
    """Per row: its episodes' mean :func:`~cabinbench.metrics.uncovered_by_clearance` and the bands' shares of the
    layout; and a note for each row left out."""
    rows, notes = [], []
    for key, episodes in groups:
        layout = recorded_layout(key["layout"], episodes["layout_hash"].iloc[0])
        if layout is None or episodes["layout_hash"].nunique() > 1:
            notes.append(
                f"{row_name(key)}: left out of the uncovered table: its layout cannot be loaded, or is not the one it was run on"
            )
            continue
        uncovered = [
            uncovered_by_clearance(
                stored_run(source).episodes[int(episode)]["pass_count"],
                layout.coverable_raster,
                layout.clearance,
            )
            for source, episode in zip(episodes["source"], episodes["episode"])
        ]
        share = uncovered_by_clearance(
            np.zeros(layout.raster_shape), layout.coverable_raster, layout.clearance
        )
        rows.append(
            {
                **key,
                "episodes": len(episodes),
                "coverage": float(episodes["coverage"].mean()),
                "uncovered": np.mean(uncovered, axis=0),
                "share": share,
            }
        )
    return rows, notes


def band_names(bands: tuple[float, ...] = CLEARANCE_BANDS) -> list[str]:
    """``0-5 cm``, ..., ``>= 35 cm``."""
    edges = [round(edge * 100) for edge in bands]
    return [f"{low}-{high} cm" for low, high in zip(edges, edges[1:])] + [f">= {edges[-1]} cm"]


def uncovered_csv(rows: list[dict]) -> pd.DataFrame:
    lines = []
    for row in rows:
        line = {name: row[name] for name in (*ROW_KEY, "episodes", "coverage")}
        for band, uncovered, share in zip(band_names(), row["uncovered"], row["share"]):
            line.update({f"uncovered {band}": uncovered, f"share {band}": share})
        lines.append(line)
    return pd.DataFrame(lines)


def uncovered_markdown(rows: list[dict], runs: str, command: str, notes: list[str]) -> str:
    lines = [
        "# cabinbench: where the uncovered floor lies",
        "",
        f"Generated by `{command}` from the per-episode records in `{runs}` and their stored final coverage rasters; "
        "do not edit by hand.",
        "",
        "The coverable floor is split into bands of distance from the nearest wall (a pixel centre's exact "
        "distance; floor within 5 cm of a wall is covered only by a robot whose edge comes within 5 cm of the "
        "wall). A cell gives the uncovered coverable area in that band as a fraction of the whole coverable area, "
        "averaged over the row's episodes, then `/` the band's share of the coverable area: `0.080 / 0.183` is "
        "0.080 of the floor left uncovered out of the 0.183 that lies in the band. A row's bands sum to "
        "1 - coverage. Definition: `uncovered_by_clearance` in `cabinbench/metrics.py`.",
        "",
        "| layout | baseline | protocol | K | episodes | coverage | " + " | ".join(band_names()) + " |",
        "|---|---|---|---|---:|---:|" + "---:|" * len(CLEARANCE_BANDS),
    ]
    for row in rows:
        cells = [
            row["layout"],
            row["baseline"],
            row["protocol"],
            str(row["n_agents"]),
            str(row["episodes"]),
            f"{row['coverage']:.3f}",
            *(f"{uncovered:.3f} / {share:.3f}" for uncovered, share in zip(row["uncovered"], row["share"])),
        ]
        lines.append("| " + " | ".join(cells) + " |")
    if notes:
        lines += ["", "Notes:", "", *(f"- {note}" for note in notes)]
    return "\n".join(lines) + "\n"


# --------------------------------------------------------------------------------- figures
def save_figure(figure: Figure, path: Path) -> None:
    figure.tight_layout()
    figure.savefig(path, dpi=120, metadata=PNG_METADATA)


def trajectory_figure(key: dict, first: pd.Series, path: Path) -> None:
    """The first episode: floor, obstacles, the covered area (from its stored final coverage
    raster) and each robot's sampled path, with start (circle) and end (square)."""
    stored = stored_run(first["source"])
    episode = stored.episodes[int(first["episode"])]
    image = np.empty((*stored.floor.shape, 3), dtype=np.uint8)
    image[:] = OBSTACLE
    image[stored.floor] = FLOOR
    image[episode["pass_count"] > 0] = COVERED
    left, right, bottom, top = stored.extent
    figure = Figure(figsize=(min(16.0, max(4.0, (right - left) * 0.9)), max(3.0, (top - bottom) * 0.9 + 0.8)))
    axes = figure.subplots()
    axes.imshow(image, origin="lower", extent=stored.extent, interpolation="nearest")
    for robot in range(episode["positions"].shape[1]):
        colour = np.array(ROBOT_COLOURS[robot % len(ROBOT_COLOURS)]) / 255
        path_xy = episode["positions"][:, robot]
        axes.plot(path_xy[:, 0], path_xy[:, 1], color=colour, linewidth=0.8)
        axes.plot(*path_xy[0], "o", color=colour, markersize=5)
        axes.plot(*path_xy[-1], "s", color=colour, markersize=5)
    axes.set_title(
        f"{row_name(key)}\nseed {first['seed'] + first['episode']}: coverage {first['coverage']:.3f} "
        f"in {first['time']:.0f} s",
        fontsize=9,
    )
    axes.set_xlabel("x (m)")
    axes.set_ylabel("y (m)")
    save_figure(figure, path)


def coverage_curves(episodes: pd.DataFrame, times: np.ndarray) -> np.ndarray:
    """(episodes, len(times)) coverage, each held at its final value after its episode ended."""
    curves = []
    for source, episode in zip(episodes["source"], episodes["episode"]):
        stored = stored_run(source).episodes[int(episode)]
        curves.append(np.interp(times, stored["steps"] * TIME_STEP, stored["coverage"]))
    return np.array(curves)


def coverage_time_figure(
    layout: str, groups: list[tuple[dict, pd.DataFrame]], colours: dict, path: Path
) -> None:
    """Coverage over simulated time on one layout: median over episodes and interquartile band."""
    end = max(float(episodes["time"].max()) for _, episodes in groups)
    times = np.linspace(0.0, end, CURVE_POINTS)
    figure = Figure(figsize=(6.4, 4.0))
    axes = figure.subplots()
    for key, episodes in groups:
        curves = coverage_curves(episodes, times)
        low, median, high = np.percentile(curves, [25, 50, 75], axis=0)
        colour = colours[row_label(key)]
        axes.plot(times, median, color=colour, label=f"{row_label(key)} (n={len(episodes)})")
        axes.fill_between(times, low, high, color=colour, alpha=0.25, linewidth=0)
    axes.set_xlabel("simulated time (s)")
    axes.set_ylabel("coverage")
    axes.set_ylim(0, 1.02)
    axes.set_title(f"{layout}: median and interquartile range over episodes", fontsize=10)
    axes.legend(fontsize=8, loc="best")
    axes.grid(alpha=0.3)
    save_figure(figure, path)


def bar_figure(rows: list[dict], metric: str, ylabel: str, colours: dict, path: Path) -> None:
    """Means with 95% interval error bars; layouts along x, one bar per baseline setting."""
    layouts = sorted({row["layout"] for row in rows})
    labels = list(colours)
    width = 0.8 / len(labels)
    figure = Figure(figsize=(max(6.4, 1.2 * len(layouts) * max(1, len(labels) / 2)), 4.0))
    axes = figure.subplots()
    for index, label in enumerate(labels):
        chosen = {row["layout"]: row[metric] for row in rows if row_label(row) == label}
        positions = [
            layout_index + (index - (len(labels) - 1) / 2) * width
            for layout_index, layout in enumerate(layouts)
            if layout in chosen
        ]
        summaries = [chosen[layout] for layout in layouts if layout in chosen]
        means = np.array([summary.mean for summary in summaries])
        errors = np.nan_to_num(
            np.array([[summary.mean - summary.low, summary.high - summary.mean] for summary in summaries]).T
        )
        axes.bar(positions, means, width, yerr=errors, capsize=3, label=label, color=colours[label])
    axes.set_xticks(range(len(layouts)), layouts, rotation=20, ha="right")
    axes.set_ylabel(ylabel)
    axes.set_title(f"{metric}: mean and 95% bootstrap interval", fontsize=10)
    axes.legend(fontsize=8)
    axes.grid(axis="y", alpha=0.3)
    save_figure(figure, path)


def makespan_figure(groups: list[tuple[dict, pd.DataFrame]], path: Path) -> bool:
    """Team makespan (a single robot's: its episode time) against the number of robots K, one panel
    per layout, one line per (baseline, protocol) run with several K and successful in every episode;
    dashed: the ideal T(1)/K; each point is labelled with its speed-up T(1)/T(K). False when there is
    nothing to draw."""
    series: dict[tuple, list[tuple[int, Summary]]] = {}
    for key, episodes in groups:
        values = episodes["makespan"] if key["n_agents"] > 1 else episodes["time"]
        series.setdefault((key["layout"], key["baseline"], key["protocol"]), []).append(
            (key["n_agents"], mean_ci(values), bool(episodes["success"].all()))
        )
    series = {
        name: sorted(points, key=lambda point: point[0])
        for name, points in series.items()
        if len(points) > 1 and all(success for *_, success in points) and points[0][0] == 1
    }
    if not series:
        return False
    layouts = sorted({layout for layout, *_ in series})
    figure = Figure(figsize=(5.0 * len(layouts), 4.0))
    for axes, layout in zip(np.atleast_1d(figure.subplots(1, len(layouts))), layouts):
        for (_, baseline, protocol), points in sorted(
            item for item in series.items() if item[0][0] == layout
        ):
            agents = np.array([k for k, *_ in points])
            means = np.array([summary.mean for _, summary, _ in points])
            errors = np.nan_to_num(np.array([[s.mean - s.low, s.high - s.mean] for _, s, _ in points]).T)
            line = axes.errorbar(
                agents, means, yerr=errors, marker="o", capsize=3, label=f"{baseline} / {protocol}"
            )
            axes.plot(agents, means[0] / agents, linestyle="--", color=line[0].get_color(), alpha=0.5)
            for k, mean in zip(agents[1:], means[1:]):
                axes.annotate(
                    f"×{means[0] / mean:.2f}",
                    (k, mean),
                    textcoords="offset points",
                    xytext=(6, 4),
                    fontsize=7,
                )
        axes.set_xlabel("robots (K)")
        axes.set_ylabel("makespan (simulated s)")
        axes.set_xticks(
            sorted({k for name, points in series.items() if name[0] == layout for k, *_ in points})
        )
        axes.set_ylim(bottom=0)
        axes.set_title(f"{layout}: mean, 95% interval; dashed: T(1)/K", fontsize=10)
        axes.legend(fontsize=7)
        axes.grid(alpha=0.3)
    save_figure(figure, path)
    return True


def training_figures(training: Path, folder: Path) -> list[Path]:
    """``training__<baseline>.png`` for every ``<training>/<baseline>/metrics.csv`` (with its ``validation.csv``, if
    any)."""
    written = []
    for metrics in sorted(training.glob("*/metrics.csv")):
        config = json.loads((metrics.parent / "config.json").read_text(encoding="utf-8"))
        path = folder / f"training__{safe_name(metrics.parent.name)}.png"
        validation = metrics.parent / "validation.csv"
        plot_curves(
            read_metrics(metrics),
            path,
            title=f"{config['ablation']} on {' + '.join(config['layouts'])}, "
            f"seed {config['seed']}: training curves",
            validation=read_metrics(validation) if validation.exists() else None,
        )
        written.append(path)
    return written


def write_figures(groups: list[tuple[dict, pd.DataFrame]], rows: list[dict], folder: Path) -> list[Path]:
    folder.mkdir(parents=True, exist_ok=True)
    # One colour per baseline setting, the same in every figure.
    colours = {
        label: colormaps["tab10"](index % 10)
        for index, label in enumerate(sorted({row_label(row) for row in rows}))
    }
    written = []
    for key, episodes in groups:
        path = (
            folder
            / f"trajectory__{'__'.join(safe_name(key[name]) for name in ('layout', 'baseline', 'protocol'))}__k{key['n_agents']}.png"
        )
        trajectory_figure(key, episodes.iloc[0], path)
        written.append(path)
    for layout in sorted({key["layout"] for key, _ in groups}):
        path = folder / f"coverage_time__{safe_name(layout)}.png"
        coverage_time_figure(
            layout, [group for group in groups if group[0]["layout"] == layout], colours, path
        )
        written.append(path)
    for metric, ylabel in (("coverage", "coverage"), ("time", "time (s)")):
        path = folder / f"bars_{metric}.png"
        bar_figure(rows, metric, ylabel, colours, path)
        written.append(path)
    if makespan_figure(groups, folder / "makespan_agents.png"):
        written.append(folder / "makespan_agents.png")
    return written


# ------------------------------------------------------------------------ ablation over training runs
def policy_of(baseline_config: dict) -> str:
    """The trained policy an episode ran: its ``checkpoint`` file, or the shipped one."""
    return str(baseline_config.get("checkpoint", SHIPPED))


def policy_name(policy: str) -> str:
    """Short name of a policy in the tables: ``shipped``, or the folder holding its file (``seed1``)."""
    return policy if policy == SHIPPED else Path(policy).parent.name or policy


def ablation_rows(records: pd.DataFrame, training: Path) -> list[dict]:
    """Per (layout, learned baseline), sequential and one robot: each trained policy's mean of every
    ``ABLATION_METRICS`` metric over its episodes (the shipped policy first), in table order. The learned
    baselines and their reward signals are those of the shipped training records, ``<training>/<baseline>/``."""
    signals = ablation_signals(training)
    learned = records[
        records["baseline"].isin(list(signals))
        & (records["protocol"] == "sequential")
        & (records["n_agents"] == 1)
    ]
    learned = learned.assign(policy=[policy_of(config) for config in learned["baseline_config"]])
    rows = []
    for (layout, baseline), episodes in learned.groupby(["layout", "baseline"]):
        policies = sorted(episodes.groupby("policy"), key=lambda item: (item[0] != SHIPPED, item[0]))
        rows.append(
            {
                "layout": layout,
                "baseline": baseline,
                **signals[baseline],
                "policies": [policy for policy, _ in policies],
                "episodes": [len(group) for _, group in policies],
                **{
                    metric: [float(group[metric].mean()) for _, group in policies]
                    for metric in ABLATION_METRICS
                },
            }
        )
    baseline_order = list(signals)
    return sorted(rows, key=lambda row: (row["layout"], baseline_order.index(row["baseline"])))


def ablation_signals(training: Path) -> dict[str, dict[str, bool]]:
    """``{baseline: {"use_curiosity": ..., "use_gail": ...}}`` from each ``<training>/<baseline>/config.json``, in the
    study's order: PPO alone, + curiosity, + GAIL, + both."""
    signals = {}
    for path in sorted(training.glob("*/config.json")):
        config = json.loads(path.read_text(encoding="utf-8"))
        signals[path.parent.name] = {name: bool(config[name]) for name in SIGNALS}
    return dict(sorted(signals.items(), key=lambda item: (item[1]["use_gail"], item[1]["use_curiosity"])))


def ablation_figure(rows: list[dict], path: Path) -> None:
    """Coverage of each learned baseline per layout: a bar for the mean over its policies, a dot per policy."""
    layouts = sorted({row["layout"] for row in rows})
    baselines = list(dict.fromkeys(row["baseline"] for row in rows))
    width = 0.8 / len(baselines)
    figure = Figure(figsize=(max(6.4, 1.6 * len(layouts)), 4.0))
    axes = figure.subplots()
    for index, baseline in enumerate(baselines):
        colour = colormaps["tab10"](index % 10)
        chosen = {row["layout"]: row["coverage"] for row in rows if row["baseline"] == baseline}
        offset = (index - (len(baselines) - 1) / 2) * width
        positions = [layout_index + offset for layout_index, layout in enumerate(layouts) if layout in chosen]
        values = [chosen[layout] for layout in layouts if layout in chosen]
        axes.bar(
            positions,
            [np.mean(policies) for policies in values],
            width,
            color=colour,
            alpha=0.6,
            label=baseline,
        )
        for position, policies in zip(positions, values):
            axes.plot(
                [position] * len(policies), policies, "o", color=colour, markeredgecolor="black", markersize=4
            )
    axes.set_xticks(range(len(layouts)), layouts, rotation=20, ha="right")
    axes.set_ylabel("coverage")
    axes.set_ylim(0, 1.0)
    axes.set_title("learned baselines: mean over training runs (bar), each trained policy (dot)", fontsize=10)
    axes.legend(fontsize=8)
    axes.grid(axis="y", alpha=0.3)
    save_figure(figure, path)


def ablation_csv(rows: list[dict]) -> pd.DataFrame:
    """One line per (layout, baseline, policy): its episodes and metric means."""
    lines = []
    for row in rows:
        for index, policy in enumerate(row["policies"]):
            lines.append(
                {
                    "layout": row["layout"],
                    "baseline": row["baseline"],
                    "policy": policy,
                    "episodes": row["episodes"][index],
                    **{metric: row[metric][index] for metric in ABLATION_METRICS},
                }
            )
    return pd.DataFrame(lines)


def ablation_markdown(rows: list[dict], sources: str, command: str) -> str:
    def spread(values: list[float], number_format: str) -> str:
        if len(values) == 1:
            return f"{values[0]:{number_format}}"
        return f"{np.mean(values):{number_format}} [{min(values):{number_format}}, {max(values):{number_format}}]"

    lines = [
        "# cabinbench: the learned baselines across training runs",
        "",
        f"Generated by `{command}` from the per-episode records in {sources}; do not edit by hand.",
        "",
        "Each learned baseline is trained by the same command with the same budget under several seeds "
        "(`python -m cabinbench.train --baseline NAME --seed S`). `shipped`: the policy in "
        "`baselines/ppo_gail/checkpoints/` (the leaderboard's row); `seedS`: `results/training/NAME/seedS/policy.pt`. "
        "Each policy is scored by its mean over its episodes; a cell gives the mean over the policies and, in "
        "brackets, the lowest and highest policy. With a few training runs that range, not a confidence interval, "
        "is the uncertainty to read. Sequential protocol, one robot; zero-shot on all but `a320_cell`.",
        "",
        "| layout | baseline | ICM | GAIL | policies | episodes | "
        + " | ".join(metric for metric in ABLATION_METRICS)
        + " | per policy: coverage / cells_cleared |",
        "|---|---|---|---|---:|---:|" + "---:|" * len(ABLATION_METRICS) + "---|",
    ]
    for row in rows:
        per_policy = ", ".join(
            f"{policy_name(policy)} {coverage:.3f} / {cells:.2f}"
            for policy, coverage, cells in zip(row["policies"], row["coverage"], row["cells_cleared"])
        )
        cells = [
            row["layout"],
            row["baseline"],
            "yes" if row["use_curiosity"] else "no",
            "yes" if row["use_gail"] else "no",
            str(len(row["policies"])),
            str(sum(row["episodes"])),
            *(spread(row[metric], number_format) for metric, number_format in ABLATION_METRICS.items()),
            per_policy,
        ]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


# ------------------------------------------------------------------------------------ main
def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m cabinbench.leaderboard",
        description="Regenerate the leaderboard tables and figures from the per-episode records.",
    )
    parser.add_argument("--runs", default="results/runs", help="folder of run records (default results/runs)")
    parser.add_argument(
        "--training",
        default="results/training",
        help="folder of shipped training records (default results/training)",
    )
    parser.add_argument(
        "--ablation-runs",
        help="folder of run records of further training runs' policies (default: ablation_runs beside --runs)",
    )
    parser.add_argument(
        "--out",
        default="results",
        help="folder for leaderboard.{md,csv}, uncovered.{md,csv}, ablation.{md,csv} and figures/ (default results)",
    )
    args = parser.parse_args(argv)
    records = read_records(args.runs) if Path(args.runs).is_dir() else pd.DataFrame()
    if records.empty:
        print(f"no records in {args.runs}: run `python -m cabinbench.run ...` first", file=sys.stderr)
        return 1
    groups = group_rows(records)
    rows = [summarize_row(key, episodes) for key, episodes in groups]
    notes = [note for key, episodes in groups for note in mixed_settings(key, episodes)]
    for note in notes:
        print(f"warning: {note}", file=sys.stderr)

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    command = f"python -m cabinbench.leaderboard --runs {args.runs} --out {args.out}"
    (out / "leaderboard.md").write_text(markdown(rows, records, args.runs, command, notes), encoding="utf-8")
    csv_table(rows).to_csv(out / "leaderboard.csv", index=False, float_format="%.6g", lineterminator="\n")
    uncovered, uncovered_notes = uncovered_rows(groups)
    for note in uncovered_notes:
        print(f"warning: {note}", file=sys.stderr)
    (out / "uncovered.md").write_text(
        uncovered_markdown(uncovered, args.runs, command, uncovered_notes), encoding="utf-8"
    )
    uncovered_csv(uncovered).to_csv(
        out / "uncovered.csv", index=False, float_format="%.6g", lineterminator="\n"
    )
    figures = write_figures(groups, rows, out / "figures") + training_figures(
        Path(args.training), out / "figures"
    )
    print(
        f"{len(rows)} rows from {len(records)} episodes: {out / 'leaderboard.md'}, {out / 'leaderboard.csv'}, "
        f"{len(figures)} figures in {out / 'figures'}"
    )
    ablation_runs = Path(args.ablation_runs or Path(args.runs).parent / "ablation_runs").as_posix()
    further = read_records(ablation_runs) if Path(ablation_runs).is_dir() else pd.DataFrame()
    learned = ablation_rows(
        pd.concat([records, further], ignore_index=True) if not further.empty else records,
        Path(args.training),
    )
    if learned:
        sources = f"`{args.runs}` (shipped policies) and `{ablation_runs}` (the others)"
        (out / "ablation.md").write_text(
            ablation_markdown(learned, sources, f"{command} --ablation-runs {ablation_runs}"),
            encoding="utf-8",
        )
        ablation_csv(learned).to_csv(
            out / "ablation.csv", index=False, float_format="%.6g", lineterminator="\n"
        )
        ablation_figure(learned, out / "figures" / "ablation_coverage.png")
        print(
            f"{len(learned)} ablation rows: {out / 'ablation.md'}, {out / 'ablation.csv'}, "
            f"{out / 'figures' / 'ablation_coverage.png'}"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
