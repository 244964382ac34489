"""``CoveragePathPlanner`` (``--baseline coverage_path_planner``): the plan of the PyPI package
``coverage-path-planner`` (a C++ Complete Coverage Path Planner for robot mowers, after the CaSSAndRA
project; ``pip install cabinbench[thirdparty]``), driven by the ``path`` baseline's follower.

    python -m cabinbench.run --baseline coverage_path_planner --suite classic --start fixed

The planner is given the free area of the robot centre: ``layout.boundary`` moved in and each of
``layout.obstacles`` moved out by the robot radius plus the contact clearance (corners rounded), in
metres, with ``distanceToBorder`` 0. (Given the walls themselves and that distance as
``distanceToBorder``, it keeps its lanes off the walls but joins them by A* through the walls'
own corners, where the robot cannot be.) Its lanes are ``offset`` = the tool width (the robot's
diameter) apart, at ``angle`` (0: along the cabin). No border or obstacle laps: the lanes alone, as the
``boustrophedon`` baseline drives. One robot.

The plan starts where the robot stands (``info["pose"]``). ``planned_*`` (what ``run`` reports beside
the executed metrics) is the plan from the layout's own start pose, the same plan under ``--start
fixed``.
"""

from __future__ import annotations

import numpy as np
from cabinbench.baselines.boustrophedon import Leg
from cabinbench.baselines.path import PathBaseline
from cabinbench.baselines.path.baseline import NO_CELL, stretches_between_stops

from cabinbench.agents import Baseline, EpisodeContext
from cabinbench.errors import BaselineError
from cabinbench.layouts.fields import CONTACT_CLEARANCE
from cabinbench.layouts.model import Layout

MIN_MITRE_COSINE = 0.3  # a corner sharper than about 145 degrees gets a capped mitre
ARC_STEP = np.pi / 12  # radians between the points of a rounded corner
PATTERNS = ("lines", "squares", "rings")  # the planner's patterns; "lines" is the boustrophedon


def import_planner():
    """The ``coverage_path_planner`` module, or a ``BaselineError`` saying how to install it."""
    try:
        import coverage_path_planner
    except ImportError:
        raise BaselineError(
            "baseline coverage_path_planner needs the package coverage-path-planner; "
            "pip install 'cabinbench[thirdparty]'"
        ) from None
    return coverage_path_planner


def offset_ring(ring: np.ndarray, distance: float, outward: bool) -> np.ndarray:
    """``ring`` (an (N, 2) polygon) with every edge moved ``distance`` out (``outward``) or in: where
    the moved edges part, an arc round the corner (every ``ARC_STEP`` rad), so a convex obstacle grows
    to exactly the points within ``distance`` of it; where they cross, their mitre (a spike's capped at
    ``1 / MIN_MITRE_COSINE`` times the distance)."""
    ring = np.asarray(ring, dtype=float)
    x, y = ring.T
    if np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y) < 0:
        ring = ring[::-1]  # counter-clockwise: each edge's right-hand normal points out
    edges = np.roll(ring, -1, axis=0) - ring
    leaving = np.stack([edges[:, 1], -edges[:, 0]], axis=1) / np.hypot(*edges.T)[:, None]
    leaving = leaving if outward else -leaving
    reaching = np.roll(leaving, 1, axis=0)  # the normal of the edge that reaches each corner
    points = []
    for corner, edge_in, normal_in, normal_out in zip(ring, np.roll(edges, 1, axis=0), reaching, leaving):
        if np.dot(normal_out - normal_in, edge_in) > 0:  # the moved edges part: round the corner
            first, last = np.arctan2(normal_in[1], normal_in[0]), np.arctan2(normal_out[1], normal_out[0])
            sweep = (last - first + np.pi) % (2 * np.pi) - np.pi
            angles = first + sweep * np.linspace(0, 1, int(np.ceil(abs(sweep) / ARC_STEP)) + 1)
            points += list(corner + distance * np.stack([np.cos(angles), np.sin(angles)], axis=1))
        else:
            bisector = (normal_in + normal_out) / np.hypot(*(normal_in + normal_out))
            points.append(corner + bisector * distance / max(np.dot(bisector, normal_out), MIN_MITRE_COSINE))
    return np.array(points)


def third_party_plan(layout: Layout, start: tuple[float, float], angle: float, pattern: str) -> np.ndarray:
    """The (N, 2) waypoints ``coverage_path_planner`` plans on ``layout``'s free area from ``start``
    (x, y): lanes one tool width apart at ``angle`` (rad) in ``pattern`` over the area where the robot
    centre keeps the robot radius plus the contact clearance from every wall."""
    if layout.raster is not None:
        raise BaselineError(
            f"layout {layout.name}: a {layout.kind} map has no polygons for coverage_path_planner; "
            "give a layout whose floor is a boundary and obstacle polygons"
        )
    planner = import_planner()

    def polygon(ring: np.ndarray):
        return planner.Polygon([planner.Point(float(x), float(y)) for x, y in ring])

    margin = layout.robot.radius + CONTACT_CLEARANCE
    environment = planner.Environment(polygon(offset_ring(layout.boundary, margin, outward=False)))
    for obstacle in layout.obstacles:
        environment.addObstacle(polygon(offset_ring(obstacle, margin, outward=True)))
    settings = planner.PathSettings()
    settings.pattern = pattern
    settings.offset = layout.robot.tool_width
    settings.angle = angle
    settings.distanceToBorder = 0.0
    settings.mowArea = True
    settings.mowBorder = settings.mowExclusionsBorder = False
    settings.borderLaps = settings.exclusionsBorderLaps = 0
    try:
        result = planner.PathService().computeFullTask(
            environment, settings, planner.Point(*map(float, start))
        )
    except Exception as error:  # the C++ core's errors come through pybind11 as any exception type
        raise BaselineError(
            f"layout {layout.name}: coverage_path_planner failed ({type(error).__name__}: {error}); "
            "try another --config angle or pattern"
        ) from None
    points = np.array([(point.x, point.y) for point in result.path.getPoints()], dtype=float).reshape(-1, 2)
    if len(points) < 2:
        raise BaselineError(
            f"layout {layout.name}: coverage_path_planner planned {len(points)} waypoint(s), no path; "
            "the free area may be narrower than the robot"
        )
    return points


class CoveragePathPlanner(PathBaseline):
    """The ``path`` baseline following ``coverage_path_planner``'s plan of the layout (one robot).
    ``angle``: the lanes' direction (rad, 0 along x); ``pattern``: ``lines``, ``squares`` or ``rings``."""

    name = "coverage_path_planner"

    def __init__(self, angle: float = 0.0, pattern: str = "lines"):
        if pattern not in PATTERNS:
            raise BaselineError(f"--config pattern: {pattern!r} is not one of {', '.join(PATTERNS)}")
        if not isinstance(angle, (int, float)) or not np.isfinite(angle):
            raise BaselineError(f"--config angle: {angle!r} is not a finite number of radians")
        # the path baseline's file reading is not wanted: the plan comes from the planner
        Baseline.__init__(self, angle=angle, pattern=pattern)
        self.angle, self.pattern = float(angle), pattern
        import_planner()  # a missing package is told when the baseline is made

    def checked_paths(self, layout: Layout, n_agents: int, start: tuple[float, float] | None = None):
        """The plan from ``start`` (default: the layout's start pose), as the one robot's path."""
        if n_agents != 1:
            raise BaselineError(
                f"baseline coverage_path_planner plans for one robot, not {n_agents}; run it with --agents 1"
            )
        return [third_party_plan(layout, start or layout.start[:2], self.angle, self.pattern)]

    def plan(self, context: EpisodeContext, info: dict) -> list[Leg]:
        start = tuple(np.asarray(info["pose"], dtype=float)[:2])
        points = self.checked_paths(context.layout, context.n_agents, start)[0]
        return [Leg(stretch, NO_CELL, "path") for stretch in stretches_between_stops(points)]
