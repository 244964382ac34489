"""``PathBaseline`` (``--baseline path``): drives any planner's waypoint path through the env's actions.

    python -m cabinbench.run --baseline path --config '{"file": "plan.csv"}' --layout a320_cell

It is :class:`~cabinbench.baselines.boustrophedon.Boustrophedon` with its plan read from a file
instead of planned: the same :class:`~cabinbench.baselines.path_following.PathFollower` follows
the waypoints from ``info["pose"]`` (a path whose first waypoint is where the robot stands starts
at its second), and in a team a robot that sees another right in front of it waits as the
planner's robots do. Robot ``i`` of a team follows path ``i``. A waypoint given twice in a row is a
stop: the path is cut there into legs, between which the robot halts for one control period, as the
planner's robot does between its legs. No start conditions: every robot starts at once.

A suite run gives a plan per layout, by the layout's name::

    --suite classic --config '{"file": {"a320_cell": "a320.csv", "full_cabin": "cabin.yaml", ...}}'
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from cabinbench.baselines.boustrophedon import Boustrophedon, Leg
from cabinbench.baselines.path.export import export_plan
from cabinbench.baselines.path.formats import read_paths
from cabinbench.baselines.path.sweep import check_in_layout, planned_sweep

from cabinbench.agents import EpisodeContext
from cabinbench.errors import BaselineError
from cabinbench.layouts.model import Layout

NO_CELL = -1  # a path from a file belongs to no cell of the layout
ANY_LAYOUT = ""  # the plan of a run that gives one plan, not one per layout


class PathBaseline(Boustrophedon):
    """Follows the path(s) in ``file``: one file name, or a list of them (CSV, ``nav_msgs/Path`` YAML or
    GeoJSON, see :mod:`~cabinbench.baselines.path.formats`), holding one path per robot in order; for a
    suite, an object of them by layout name (``{"a320_cell": "a320.csv", ...}``), one plan per layout. The
    files are read and checked when the baseline is made; a path's fit to the layout and team (inside the
    layout, one per robot) when an episode starts, or earlier by :meth:`planned`."""

    name = "path"
    config_files = ("file",)
    export_plan = staticmethod(export_plan)
    """:func:`~.export.export_plan`, reachable through the registry (``baseline_class("path")``) by
    ``run --export-path``, which may not import a baseline."""

    def __init__(self, file: str | list[str] | dict[str, str | list[str]]):
        super().__init__(file=file)
        by_layout = file if isinstance(file, dict) and file else {ANY_LAYOUT: file}
        self.plans = {layout: read_plan(files) for layout, files in by_layout.items()}

    def checked_paths(self, layout: Layout, n_agents: int) -> list[np.ndarray]:
        """The paths of ``layout``, after checking that there is one per robot and that they lie in it."""
        plan = self.plans.get(layout.name, self.plans.get(ANY_LAYOUT))
        if plan is None:
            raise BaselineError(
                f"--config file: no path for layout {layout.name} (paths for {', '.join(self.plans)}); give "
                "one per layout of the run"
            )
        paths, names = plan
        if len(paths) != n_agents:
            raise BaselineError(
                f"--config file: {len(paths)} path(s) ({', '.join(names)}) for {n_agents} robot(s); give one "
                "path per robot (a list of files, or a GeoJSON MultiLineString or FeatureCollection)"
            )
        check_in_layout(layout, paths, names)
        return paths

    def planned(self, layout: Layout, n_agents: int = 1) -> dict:
        """The static footprint sweep of the paths on ``layout`` (:func:`~.sweep.planned_sweep`): what
        ``run`` shows beside the executed metrics. Checks the paths as an episode would."""
        return planned_sweep(layout, self.checked_paths(layout, n_agents))

    def plan(self, context: EpisodeContext, info: dict) -> list[Leg]:
        points = self.checked_paths(context.layout, context.n_agents)[context.agent]
        return [Leg(stretch, NO_CELL, "path") for stretch in stretches_between_stops(points)]


def read_plan(files) -> tuple[list[np.ndarray], list[str]]:
    """The paths in ``files`` (a file name or a list of them), one per robot, and a name for each."""
    files = [files] if isinstance(files, str) else files
    if not isinstance(files, list) or not files or not all(isinstance(name, str) for name in files):
        raise BaselineError(
            f"--config file: {files!r} is not a file name or a list of them; give "
            '{"file": "plan.csv"}, {"file": ["robot0.csv", "robot1.csv"]} or {"file": {"LAYOUT": "plan.csv"}}'
        )
    paths, names = [], []
    for name in files:
        read = read_paths(Path(name))
        paths += read
        names += [name] if len(read) == 1 else [f"{name} (line {i + 1})" for i in range(len(read))]
    return paths, names


def stretches_between_stops(points: np.ndarray) -> list[np.ndarray]:
    """A path cut at each waypoint that repeats the one before: the first copy ends a stretch, the
    second starts the next. The robot halts at such a stop for one control period, as a planner's robot
    does between two legs (an exported plan repeats the point where one leg ends and the next begins),
    so that an exported plan drives exactly as its planner did."""
    repeats = np.flatnonzero(np.all(points[1:] == points[:-1], axis=1)) + 1
    return np.split(points, repeats)
