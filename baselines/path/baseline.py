"""``PathBaseline`` (``--baseline path``): drives any planner's waypoint path through the env's actions.

    python -m cabinbench.run --baseline path --config '{"file": "plan.csv"}' --layout a320_cell

It is :class:`~cabinbench.baselines.boustrophedon.Boustrophedon` with its plan read from a file
instead of planned: the same :class:`~cabinbench.baselines.path_following.PathFollower` follows
the waypoints from ``info["pose"]`` (a path whose first waypoint is where the robot stands starts
at its second), and in a team a robot that sees another right in front of it waits as the
planner's robots do. Robot ``i`` of a team follows path ``i``. A waypoint given twice in a row is a
stop: the path is cut there into legs, between which the robot halts for one control period, as the
planner's robot does between its legs. No start conditions: every robot starts at once.
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


class PathBaseline(Boustrophedon):
    """Follows the path(s) in ``file``: one file name, or a list of them (CSV, ``nav_msgs/Path`` YAML or
    GeoJSON, see :mod:`~cabinbench.baselines.path.formats`), holding one path per robot in order. The files
    are read and checked when the baseline is made; a path's fit to the layout and team (inside the
    layout, one per robot) when an episode starts, or earlier by :meth:`planned`."""

    name = "path"
    export_plan = staticmethod(export_plan)
    """:func:`~.export.export_plan`, reachable through the registry (``baseline_class("path")``) by
    ``run --export-path``, which may not import a baseline."""

    def __init__(self, file: str | list[str]):
        files = [file] if isinstance(file, str) else file
        if not isinstance(files, list) or not files or not all(isinstance(name, str) for name in files):
            raise BaselineError(
                f"--config file: {file!r} is not a file name or a list of them; "
                'give {"file": "plan.csv"} or {"file": ["robot0.csv", "robot1.csv"]}'
            )
        super().__init__(file=file)
        self.paths: list[np.ndarray] = []
        self.path_names: list[str] = []
        for name in files:
            paths = read_paths(Path(name))
            self.paths += paths
            self.path_names += (
                [name] if len(paths) == 1 else [f"{name} (line {i + 1})" for i in range(len(paths))]
            )

    def checked_paths(self, layout: Layout, n_agents: int) -> list[np.ndarray]:
        """The paths, after checking that there is one per robot and that they lie in the layout."""
        if len(self.paths) != n_agents:
            given = ", ".join(self.path_names)
            raise BaselineError(
                f"--config file: {len(self.paths)} path(s) ({given}) for {n_agents} robot(s); give one path "
                "per robot (a list of files, or a GeoJSON MultiLineString or FeatureCollection)"
            )
        check_in_layout(layout, self.paths, self.path_names)
        return self.paths

    def planned(self, layout: Layout, n_agents: int = 1) -> dict:
        """The static footprint sweep of the paths on ``layout`` (:func:`~.sweep.planned_sweep`): what
        ``run`` shows beside the executed metrics. Checks the paths as an episode would."""
        return planned_sweep(layout, self.checked_paths(layout, n_agents))

    def plan(self, context: EpisodeContext, info: dict) -> list[Leg]:
        points = self.checked_paths(context.layout, context.n_agents)[context.agent]
        return [Leg(stretch, NO_CELL, "path") for stretch in stretches_between_stops(points)]


def stretches_between_stops(points: np.ndarray) -> list[np.ndarray]:
    """A path cut at each waypoint that repeats the one before: the first copy ends a stretch, the
    second starts the next. The robot halts at such a stop for one control period, as a planner's robot
    does between two legs (an exported plan repeats the point where one leg ends and the next begins),
    so that an exported plan drives exactly as its planner did."""
    repeats = np.flatnonzero(np.all(points[1:] == points[:-1], axis=1)) + 1
    return np.split(points, repeats)
