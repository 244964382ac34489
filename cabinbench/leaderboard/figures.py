"""The leaderboard's figures, in ``<out>/figures/``:

- ``trajectory__<layout>__<baseline>__<protocol>__k<K>.png``: the first episode (lowest seed,
  then episode index) drawn from its stored final coverage raster and sampled positions (the
  seed's Fig. 5.11);
- ``coverage_time__<layout>.png``: coverage over simulated time, one line per baseline (median
  over episodes, interquartile band);
- ``bars_coverage__<layout>.png`` and ``bars_time__<layout>.png``: means with 95% interval error
  bars, one bar per baseline setting (a figure per layout keeps each readable at its size);
- ``makespan_agents.png``: team makespan against the number of robots, one panel per layout, for
  the settings run with several K whose teams (K > 1) succeeded in every episode (a makespan cut
  short by the step limit measures the limit, not the team); a single robot that did not is a
  hollow point, and only one that did gives the ideal T(1)/K and each K's speed-up T(1)/T(K);
- ``training__<baseline>.png``: the training curves (the study's Fig. 5.8) of each shipped learned
  policy, from the ``metrics.csv`` that ``python -m cabinbench.train --ship`` keeps.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib import colormaps
from matplotlib.figure import Figure  # no pyplot: figures render with Agg, no window, no global state

from cabinbench.leaderboard.table import row_label, row_name, stored_run
from cabinbench.metrics import team_of_one
from cabinbench.records import safe_name
from cabinbench.sim.physics import TIME_STEP
from cabinbench.sim.render import COVERED, FLOOR, OBSTACLE, ROBOT_COLOURS
from cabinbench.stats import Summary, mean_ci
from cabinbench.training_records import CURVE_PANELS, plot_curves, read_metrics

PNG_METADATA = {"Software": None}  # keeps committed figures free of the matplotlib version string
CURVE_POINTS = 200


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
    """Means with 95% interval error bars of one layout's rows, one bar per baseline setting."""
    labels = [label for label in colours if any(row_label(row) == label for row in rows)]
    figure = Figure(figsize=(max(6.4, 0.55 * len(labels) + 1.5), 4.0))
    axes = figure.subplots()
    for index, label in enumerate(labels):
        summary = next(row[metric] for row in rows if row_label(row) == label)
        error = np.nan_to_num([[summary.mean - summary.low], [summary.high - summary.mean]])
        axes.bar([index], [summary.mean], 0.8, yerr=error, capsize=3, color=colours[label])
    axes.set_xticks(range(len(labels)), labels, rotation=35, ha="right", fontsize=7)
    axes.set_ylabel(ylabel)
    axes.set_title(f"{rows[0]['layout']}: {metric}, mean and 95% bootstrap interval", fontsize=10)
    axes.grid(axis="y", alpha=0.3)
    figure.tight_layout()
    save_figure(figure, path)


def makespan_figure(groups: list[tuple[dict, pd.DataFrame]], path: Path) -> bool:
    """Team makespan (a single robot's: its episode time) against the number of robots K, one panel
    per layout, one line per (baseline, protocol) run with several K whose teams succeeded in every
    episode; hollow: a single robot that did not (its time is partly the step limit); when it did,
    dashed: the ideal T(1)/K, and each point is labelled with its speed-up T(1)/T(K). False when
    there is nothing to draw."""
    series: dict[tuple, list[tuple[int, Summary]]] = {}
    for key, episodes in groups:
        values = (episodes if key["n_agents"] > 1 else team_of_one(episodes))["makespan"]
        series.setdefault((key["layout"], key["baseline"], key["protocol"]), []).append(
            (key["n_agents"], mean_ci(values), bool(episodes["success"].all()))
        )
    series = {
        name: sorted(points, key=lambda point: point[0])
        for name, points in series.items()
        if len(points) > 1 and all(success for k, _, success in points if k > 1)
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
            colour = line[0].get_color()
            first_k, _, first_succeeded = points[0]
            if not first_succeeded:
                axes.plot(agents[:1], means[:1], marker="o", color=colour, markerfacecolor="white", zorder=5)
            if first_k != 1 or not first_succeeded:
                continue
            axes.plot(agents, means[0] / agents, linestyle="--", color=colour, alpha=0.5)
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
        axes.set_title(
            f"{layout}: mean, 95% interval\ndashed: T(1)/K; hollow: not every episode finished", fontsize=10
        )
        axes.legend(fontsize=7)
        axes.grid(alpha=0.3)
    save_figure(figure, path)
    return True


def training_figures(training: Path, folder: Path) -> list[Path]:
    """``training__<baseline>.png`` for every ``<training>/<baseline>/metrics.csv`` of an rsl-rl run (with its
    ``validation.csv``, if any). bc and dagger record no such losses (their curves: the learning curves)."""
    written = []
    for metrics in sorted(training.glob("*/metrics.csv")):
        rows = read_metrics(metrics)
        if rows and not {column for column, _ in CURVE_PANELS} <= rows[0].keys():
            continue
        config = json.loads((metrics.parent / "config.json").read_text(encoding="utf-8"))
        path = folder / f"training__{safe_name(metrics.parent.name)}.png"
        validation = metrics.parent / "validation.csv"
        team = f", K = {config['n_agents']}" if "n_agents" in config else ""  # a team trainer's
        plot_curves(
            rows,
            path,
            title=f"{metrics.parent.name} on {' + '.join(config['layouts'])}{team}, "
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
        setting = "__".join(safe_name(key[name]) for name in ("layout", "baseline", "protocol"))
        path = folder / f"trajectory__{setting}__k{key['n_agents']}.png"
        trajectory_figure(key, episodes.iloc[0], path)
        written.append(path)
    for layout in sorted({key["layout"] for key, _ in groups}):
        path = folder / f"coverage_time__{safe_name(layout)}.png"
        coverage_time_figure(
            layout, [group for group in groups if group[0]["layout"] == layout], colours, path
        )
        written.append(path)
    for layout in sorted({row["layout"] for row in rows}):
        for metric, ylabel in (("coverage", "coverage"), ("time", "time (s)")):
            path = folder / f"bars_{metric}__{safe_name(layout)}.png"
            bar_figure([row for row in rows if row["layout"] == layout], metric, ylabel, colours, path)
            written.append(path)
    if makespan_figure(groups, folder / "makespan_agents.png"):
        written.append(folder / "makespan_agents.png")
    return written
