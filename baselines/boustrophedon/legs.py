"""What a plan is made of: ``Leg`` (a stretch of waypoints and when it may start), the coverage
plan of one region (``plan_region``), and where along a path goal markers are first reached.

Inputs are a ``Layout`` and masks over its robot-centre raster (``regions``); waypoints are world
(x, y) metres.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from cabinbench.baselines.boustrophedon.regions import near_points
from cabinbench.baselines.coverage_planning import Plan, plan_coverage

from cabinbench.geometry import arc_lengths, segment_samples, world_to_pixel
from cabinbench.layouts.fields import RESOLUTION
from cabinbench.layouts.model import Layout

MIN_SWEEP_COMPONENT_PX = 4  # smaller scraps of a share are left to the neighbouring sweeps
SAMPLE_SPACING = 0.02  # metres between the points at which a path is checked against goals or ways
HOLD_BACK_MARGIN = 0.02  # metres beyond the robot radius kept unswept around a held-back goal


@dataclass
class Leg:
    """One stretch of the plan: ``waypoints`` (N, 2) metres; ``purpose`` is "sweep", "goals",
    "exit" or "transit". A leg starts once cell ``after_cell`` is cleared (None: at once) and
    then ``delay`` more seconds have passed (from that event, or from the episode start)."""

    waypoints: np.ndarray
    cell: int
    purpose: str
    after_cell: int | None = None
    delay: float = 0.0
    gate: bool = False  # a departure gate: ``delay`` is set from the whole team's plans


def plan_region(
    layout: Layout, region: np.ndarray, start: np.ndarray, goals: np.ndarray | None, quickest: bool = False
) -> Plan:
    """``plan_coverage`` of ``region`` from ``start``; with ``quickest`` both sweep axes are
    planned and the plan with the shorter estimated driving time is kept (in a 2-pixel-wide
    pocket the shortest plan can be a zigzag across it, one turn per pixel)."""
    robot = layout.robot
    goal_pixels = [] if goals is None else [world_to_pixel(g, RESOLUTION, layout.origin) for g in goals]
    last_cells = (lambda cell: any(cell.contains(*pixel) for pixel in goal_pixels)) if goal_pixels else None
    axes = (0, 1) if quickest else (None,)
    plans = [
        plan_coverage(
            region,
            RESOLUTION,
            layout.origin,
            robot.tool_width,
            start,
            last_cells,
            sweep_axis=axis,
            max_speed=robot.max_speed,
            max_turn_rate=robot.max_turn_rate,
        )
        for axis in axes
    ]
    return min(plans, key=lambda plan: plan.duration)


def first_touches(waypoints: np.ndarray, points: np.ndarray, reach: float) -> np.ndarray:
    """For each point, how far along the path (metres) the robot centre first comes within ``reach``."""
    steps = segment_samples(waypoints, SAMPLE_SPACING)
    dense = np.vstack(steps) if steps else waypoints
    travelled = arc_lengths(dense)
    within = np.hypot(dense[:, None, 0] - points[None, :, 0], dense[:, None, 1] - points[None, :, 1]) <= reach
    return np.where(within.any(axis=0), travelled[within.argmax(axis=0)], travelled[-1])


def held_back_goal(layout: Layout, sweep: np.ndarray, goals: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The goal marker that ``sweep`` reaches last, and the pixels around it to keep unswept.

    Reaching the episode's last goal ends it: the sweep is planned again off that spot, and the
    robot drives to the goal only when the rest is swept.
    """
    final_goal = goals[np.argmax(first_touches(sweep, goals, layout.robot.radius))]
    return final_goal, near_points(layout, final_goal[None], layout.robot.radius + HOLD_BACK_MARGIN)
