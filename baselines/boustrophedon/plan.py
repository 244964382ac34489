"""The whole plan of one robot: ``plan_layout`` (a team's robots get theirs from ``convoy``).

Input: a ``Layout``, the protocol, the robot and the team size; output: the robot's legs in
driving order. In ``open`` the whole reachable layout is one sweep. In ``sequential`` the robot
plans cell by cell, as the cells open: each cell's sweep stays clear of its closed bounds and
sweeps the sub-cells holding goal markers last (so that the cell, which clears when its last goal
is reached, is fully swept by then), then an A* transit drives to the exit landmark of the next
cell. In the last cell the goal the sweep would reach last is held back until the rest is swept.
"""

from __future__ import annotations

import numpy as np
from cabinbench.baselines.boustrophedon.convoy import plan_team
from cabinbench.baselines.boustrophedon.legs import Leg, held_back_goal, plan_region
from cabinbench.baselines.boustrophedon.regions import cell_region, near_bounds, transit

from cabinbench.geometry import nearest_point
from cabinbench.layouts.model import Layout
from cabinbench.sim.world import start_poses


def plan_layout(
    layout: Layout,
    protocol: str = "sequential",
    agent: int = 0,
    n_agents: int = 1,
    start=None,
    team_start=None,
) -> list[Leg]:
    """The whole plan for robot ``agent`` of a team of ``n_agents``, as legs in driving order. A
    lone robot plans from ``start`` (x, y), the pose it finds (default: the layout's start); a
    team from ``team_start`` (K, 2 or 3), where its robots stand (default: the team's start
    poses, :func:`~cabinbench.sim.world.start_poses`)."""
    if n_agents > 1:
        try:
            return plan_team(layout, protocol, agent, n_agents, team_start)
        except ValueError:
            if team_start is None:
                raise
            # Drawn starts can leave a share's sweep no route from where its robot stands: the team then
            # plans from its start poses, as from the fixed start, and each robot drives there first.
            return plan_team(layout, protocol, agent, n_agents, None)
    start = start_poses(layout, 1)[0, :2] if start is None else np.asarray(start, dtype=float)[:2]
    drivable = layout.centre_free  # already keeps the disc 1 cm off every wall
    if protocol == "open":
        return [Leg(plan_region(layout, drivable, start, goals=None).waypoints, 0, "sweep")]
    legs, position = [], start
    first_cell = max(0, layout.cleared_cells - 1)
    for cell in range(first_cell, len(layout.cells)):
        if cell >= layout.cleared_cells:
            region = drivable & cell_region(layout, cell)
            goals = layout.cells[cell].goals
            plan = plan_region(layout, region, position, goals)
            if cell + 1 == len(layout.cells) and len(goals):
                final_goal, keep_off = held_back_goal(layout, plan.waypoints, goals)
                plan = plan_region(layout, region & ~keep_off, position, goals)
                legs.append(Leg(plan.waypoints, cell, "sweep"))
                legs.append(
                    Leg(transit(layout, region | keep_off, plan.waypoints[-1], final_goal), cell, "goals")
                )
            else:
                legs.append(Leg(plan.waypoints, cell, "sweep"))
            position = legs[-1].waypoints[-1]
        if cell + 1 < len(layout.cells):
            exit_point = nearest_point(layout.passages[cell].exits, position)
            corridor = (
                drivable & np.isin(layout.cell_raster, (cell, cell + 1)) & ~near_bounds(layout, cell - 1)
            )
            legs.append(Leg(transit(layout, corridor, position, exit_point), cell, "exit"))
            position = exit_point
    return legs
