"""Each robot's legs in a team: the shares of ``shares`` driven in convoy, with departure gates.

Input: a ``Layout``, the protocol and the team size; output: every robot's legs
(``team_plans``). Ranks are fixed for the episode (``shares.team_split``): rank ``r`` sets off
``r × DEPARTURE_GAP`` seconds after the start, so robots enter the aisle in rank order, the
leader heading farthest; every transit keeps to the band and the robot's own share where it can,
so nobody crosses another robot's share. Each robot sets off from where it stands (a suite
episode scatters the team over the start cell) straight for the first entry of its share; that
first sweep is the one its rank makes from the team's start poses, so the robots stage and drive
on in the convoy the gates were laid out for, wherever they start.

- **Sequential.** The team works through the cells together. Every robot sweeps its share, the
  pieces with goal markers last, up to the first touch of its last goal marker, and waits there,
  at the dead end of a pocket, out of everyone's way. The cell clears when the last robot
  reaches its goal; all robots see that in ``info["cells_cleared"]`` on the same step. Then all
  back out at once to a *staging point* clear of the aisle (two radii and ``STAGING_GAP`` from
  the way), and rank ``r`` drives on ``T + r × DEPARTURE_GAP`` seconds after the clear (``T``:
  the longest estimated back-out), into its share of the next cell, the leader through the exit
  landmark (which moves the team's cell on). In the last cell every robot holds its final goal
  back until the rest of its share is swept (then sweeps the spot it held back), so the episode,
  which ends on the team's last goal, ends only when every share is swept.
- **Open.** One stage over the whole layout: each robot drives along the aisle to its block of
  the cabin and sweeps it, the leader taking the farthest block.
"""

from __future__ import annotations

import math
from collections import OrderedDict
from dataclasses import dataclass, field

import numpy as np
from cabinbench.baselines.boustrophedon.legs import (
    MIN_SWEEP_COMPONENT_PX,
    SAMPLE_SPACING,
    Leg,
    first_touches,
    held_back_goal,
    plan_region,
)
from cabinbench.baselines.boustrophedon.regions import (
    cell_region,
    geodesic_map,
    near_bounds,
    near_points,
    near_polyline,
    nearest_pixel,
    pixel_centre,
    reachable,
    transit,
)
from cabinbench.baselines.boustrophedon.shares import (
    DEPARTURE_GAP,
    TeamSplit,
    TeamStage,
    cached_for_team,
    team_split,
    team_starts,
)
from cabinbench.baselines.coverage_planning import driving_time
from scipy import ndimage

from cabinbench.geometry import (
    arc_lengths,
    distances_to_segments,
    drop_repeated_points,
    nearest_point,
    segment_samples,
)
from cabinbench.layouts.fields import RESOLUTION
from cabinbench.layouts.model import Layout
from cabinbench.sim.world import start_poses

GOAL_TOUCH_MARGIN = 0.03  # metres inside the reach at which a sweep counts as touching a goal
STAGING_GAP = 0.06  # metres between a staged robot and one passing along the through way
STAGING_MARGIN = 0.5  # seconds added to the estimated back-out time before the convoy moves on

_PLAN_CACHE: OrderedDict = OrderedDict()


def plan_team(layout: Layout, protocol: str, agent: int, n_agents: int, starts=None) -> list[Leg]:
    """Robot ``agent``'s legs in a team of ``n_agents`` standing at ``starts`` (see
    :func:`team_plans`)."""
    return list(team_plans(layout, protocol, n_agents, starts)[agent])


def team_plans(layout: Layout, protocol: str, n_agents: int, starts=None) -> list[list[Leg]]:
    """Every robot's legs, each from where it stands: ``starts`` (K, 2 or 3), by default the team's
    start poses (computed once per layout and team: each robot's baseline instance takes its own).
    The departure gates of a cell are set from all robots' plans: once the cell clears, every robot
    backs out to its staging point (clear of the aisle), and rank r drives on
    ``T + r × DEPARTURE_GAP`` seconds after the clear, T being the longest estimated back-out."""
    starts = team_starts(layout, n_agents, starts)
    return cached_for_team(
        _PLAN_CACHE, layout, (protocol, starts.tobytes()), lambda: _gated_plans(layout, protocol, starts)
    )


def _gated_plans(layout: Layout, protocol: str, starts: np.ndarray) -> list[list[Leg]]:
    """Every robot's legs, the delays of the departure gates set from all of them."""
    split = team_split(layout, protocol, len(starts), starts)
    # where each rank's robot stands in the team's start poses: every rank plans its first sweep
    # from there, whoever holds it and wherever that robot stands (see _robot_legs)
    homes = start_poses(layout, len(starts))[:, :2]
    home_of_rank = dict(zip(team_split(layout, protocol, len(starts)).ranks.tolist(), homes))
    plans = [
        _robot_legs(layout, split, agent, starts[agent], home_of_rank[int(split.ranks[agent])])
        for agent in range(len(starts))
    ]
    robot = layout.robot
    back_out: dict[int, float] = {}
    for legs in plans:
        for leg in legs:
            if leg.purpose == "out":
                duration = (
                    driving_time(leg.waypoints, robot.max_speed, robot.max_turn_rate)
                    + math.pi / robot.max_turn_rate
                )
                back_out[leg.cell] = max(back_out.get(leg.cell, 0.0), duration + STAGING_MARGIN)
    for agent, legs in enumerate(plans):
        for leg in legs:
            if leg.gate:
                leg.delay = back_out.get(leg.after_cell, 0.0) + split.ranks[agent] * DEPARTURE_GAP
    return plans


def _robot_legs(
    layout: Layout, split: TeamSplit, agent: int, start: np.ndarray, home: np.ndarray
) -> list[Leg]:
    """Robot ``agent``'s legs through every stage of ``split``, from ``start`` (x, y), where it
    stands (gates still without their delay). Its first sweep is planned from ``home``, where the
    robot of its rank stands in the team's start poses, and entered from ``start``: every rank
    sweeps and stages as the convoy was laid out for, wherever its robot starts."""
    rank = int(split.ranks[agent])
    position = start
    drivable = reachable(layout)
    if split.stages[0].cell < 0:  # open: one stage
        stage = split.stages[0]
        share = stage.sweeps[rank]
        if not share.any():
            return []
        lane = drivable & ~_others(stage, rank)
        waypoints = _sweep_path(layout, share, position, None, lane, drivable, plan_from=home)
        return [Leg(waypoints, -1, "sweep", None, rank * DEPARTURE_GAP)]

    legs = _LegList(wait=(None, rank * DEPARTURE_GAP, False))
    at_cell = layout.cell_raster[layout.to_pixel(*position)]
    previous = None
    for stage in split.stages:
        cell, share, goals = stage.cell, stage.sweeps[rank], stage.goals[rank]
        if not share.any():
            continue  # nothing for this robot here: it waits where it is
        corridor, lane = _stage_ways(layout, stage, previous, rank, position, at_cell, drivable)
        previous = stage
        if rank == 0 and cell > 0 and at_cell < cell:  # the leader moves the team on through the exit
            exit_point = nearest_point(layout.passages[cell - 1].exits, position)
            legs.add(transit(layout, lane, position, exit_point, corridor), cell - 1, "exit")
            position = exit_point
        plan_from = home if stage is split.stages[0] else None
        if cell == len(layout.cells) - 1 and len(goals):
            position = _last_cell_legs(
                legs, layout, cell, share, goals, position, (lane, corridor, drivable), plan_from
            )
        else:
            sweep = _sweep_path(layout, share, position, goals, lane, corridor, plan_from)
            if len(goals):
                position = _sweep_and_stage_legs(legs, layout, stage, sweep, goals, lane, corridor)
            else:
                legs.add(sweep, cell, "sweep")
                legs.wait = (cell, 0.0, True)
                position = sweep[-1]
        at_cell = cell
    return legs.legs


@dataclass
class _LegList:
    """A robot's legs as they are planned; ``wait`` is when the next one may start: (the cell whose
    clearing it waits for or None, the delay after that, whether it is a departure gate)."""

    wait: tuple[int | None, float, bool]
    legs: list[Leg] = field(default_factory=list)

    def add(self, waypoints, cell: int, purpose: str) -> None:
        """Append a leg (none for a path of one point); the leg after it starts at once."""
        if len(waypoints) > 1:
            self.legs.append(Leg(np.asarray(waypoints, dtype=float), cell, purpose, *self.wait))
            self.wait = (None, 0.0, False)


def _stage_ways(
    layout: Layout,
    stage: TeamStage,
    previous: TeamStage | None,
    rank: int,
    position: np.ndarray,
    at_cell: int,
    drivable: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """(corridor, lane) of robot ``rank`` in ``stage``, coming from cell ``at_cell``: the corridor is
    the drivable floor from there to the stage's cell, off the closed bounds, plus its share and
    where it stands; the lane, where its transits keep to, is the corridor less what the other
    robots sweep in this stage and the one before."""
    cell = stage.cell
    corridor = (
        drivable
        & (layout.cell_raster >= min(at_cell, cell))
        & (layout.cell_raster <= cell)
        & ~near_bounds(layout, min(at_cell, cell) - 1)
        & ~near_bounds(layout, cell)
    )
    corridor |= stage.sweeps[rank] | (near_points(layout, position[None], 2 * RESOLUTION) & drivable)
    lane = corridor & ~_others(stage, rank)
    if previous is not None:
        lane &= ~_others(previous, rank)
    return corridor, lane


def _last_cell_legs(
    legs: _LegList,
    layout: Layout,
    cell: int,
    share: np.ndarray,
    goals: np.ndarray,
    position: np.ndarray,
    floors: tuple[np.ndarray, np.ndarray, np.ndarray],
    plan_from: np.ndarray | None,
) -> np.ndarray:
    """The legs of the last cell, where reaching the team's last goal ends the episode: the share
    swept with this robot's final goal held back, the final goal, then the spot held back. Returns
    where the robot ends. ``floors``: (lane, corridor) as :func:`_stage_ways` gives them, and the
    drivable floor; ``plan_from``: as :func:`_sweep_path` takes it."""
    lane, corridor, drivable = floors
    sweep = _sweep_path(layout, share, position, goals, lane, corridor, plan_from)
    final_goal, keep_off = held_back_goal(layout, sweep, goals)
    sweep = _sweep_path(
        layout, share & ~keep_off, position, goals, lane & ~keep_off, corridor & ~keep_off, plan_from
    )
    legs.add(sweep, cell, "sweep")
    allowed = share | (keep_off & drivable) | corridor
    # the pixel nearest the goal that it may drive to: goals may sit where the disc cannot
    position = pixel_centre(layout, nearest_pixel(allowed, layout, final_goal))
    legs.add(
        transit(layout, allowed & (lane | share | keep_off), sweep[-1], position, allowed),
        cell,
        "goals",
    )
    # until the team's last goal ends the episode, sweep what the hold-back left
    spot = keep_off & drivable & (share | corridor)
    if spot[layout.to_pixel(*position)]:
        legs.add(plan_region(layout, spot, position, None, quickest=True).waypoints, cell, "sweep")
    return position


def _sweep_and_stage_legs(
    legs: _LegList,
    layout: Layout,
    stage: TeamStage,
    sweep: np.ndarray,
    goals: np.ndarray,
    lane: np.ndarray,
    corridor: np.ndarray,
) -> np.ndarray:
    """The legs of a cell with goals before the last: ``sweep`` up to the first touch of the last
    goal, wait there for the cell to clear, back out to the staging point clear of the aisle, then
    (a departure gate) the rest of the sweep on the way out when this robot's turn in the convoy
    comes. Returns where the robot ends."""
    cell = stage.cell
    before, after = _split_at_last_goal(sweep, goals, layout.robot.radius - GOAL_TOUCH_MARGIN)
    # the way out: the rest of the sweep, then back to the aisle
    onto_way = near_polyline(layout, stage.ways[0], RESOLUTION) & corridor & cell_region(layout, cell)
    back_to_way = pixel_centre(layout, nearest_pixel(onto_way, layout, after[-1]))
    back = transit(layout, lane, after[-1], back_to_way, corridor)
    after = np.vstack([after, back[1:]])
    out, rest = _split_at_staging(after, stage.ways, layout.robot.radius)
    legs.add(before, cell, "sweep")
    legs.wait = (cell, 0.0, False)
    legs.add(out, cell, "out")
    legs.wait = (cell, 0.0, True)
    legs.add(rest, cell, "sweep")
    return after[-1]


def _split_at_staging(
    path: np.ndarray, ways: list[np.ndarray], radius: float
) -> tuple[np.ndarray, np.ndarray]:
    """``path`` cut where it first comes closer to the through way than a passing robot needs
    (2 radii + ``STAGING_GAP``); the first part is empty when it starts that close."""
    steps = segment_samples(path, SAMPLE_SPACING)
    if not steps:
        return path[:1], path
    clearance = 2 * radius + STAGING_GAP
    for index, dense in enumerate(steps):
        near = np.min([_distance_to_polyline(dense, way) for way in ways], axis=0) < clearance
        if near.any():
            k = int(np.argmax(near))
            if index == 0 and k == 0:
                return path[:1], path
            point = dense[max(k - 1, 0)]
            return np.vstack([path[: index + 1], point]), np.vstack([point, path[index + 1 :]])
    return path, path[-1:]


def _distance_to_polyline(points: np.ndarray, polyline: np.ndarray) -> np.ndarray:
    if len(polyline) == 1:
        return np.hypot(*(points - polyline[0]).T)
    return distances_to_segments(points, polyline[:-1], polyline[1:]).min(axis=1)


def _split_at_last_goal(
    waypoints: np.ndarray, goals: np.ndarray, reach: float
) -> tuple[np.ndarray, np.ndarray]:
    """The path cut where it first comes within ``reach`` of the goal it reaches last."""
    touch = float(np.max(first_touches(waypoints, goals, reach)))
    lengths = arc_lengths(waypoints)
    k = int(np.searchsorted(lengths, touch, side="right"))
    if k >= len(waypoints):
        return waypoints, waypoints[-1:]
    a, b = waypoints[k - 1], waypoints[k]
    t = (touch - lengths[k - 1]) / max(lengths[k] - lengths[k - 1], 1e-12)
    point = a + t * (b - a)
    return np.vstack([waypoints[:k], point]), np.vstack([point, waypoints[k:]])


def _others(stage: TeamStage, rank: int) -> np.ndarray:
    """What the other robots of ``stage`` sweep (not the through band)."""
    others = [sweep for k, sweep in enumerate(stage.sweeps) if k != rank]
    return (np.any(others, axis=0) & ~stage.through) if others else np.zeros_like(stage.through)


def _sweep_path(
    layout: Layout,
    share: np.ndarray,
    start: np.ndarray,
    goals: np.ndarray | None,
    corridor: np.ndarray,
    fallback: np.ndarray | None = None,
    plan_from: np.ndarray | None = None,
) -> np.ndarray:
    """One polyline (metres) from ``start`` that sweeps every piece of ``share``: the pieces
    (4-connected) nearest first, joined by A* transits through ``corridor | share`` (else
    ``fallback``). With ``plan_from``, the order and the entries of the pieces are those of a
    sweep from there, and the robot drives from ``start`` straight on to the first entry."""
    labels, count = ndimage.label(share)
    sizes = ndimage.sum_labels(np.ones_like(labels), labels, index=np.arange(1, count + 1))
    remaining = [k + 1 for k in range(count) if sizes[k] >= MIN_SWEEP_COMPONENT_PX]
    path = [np.asarray(start, dtype=float)[None, :]]
    at = path[0][0]  # where the robot is; ``position``, where the sweep is planned from
    position = at if plan_from is None else np.asarray(plan_from, dtype=float)
    ways = corridor | share
    fallback = ways if fallback is None else (fallback | share)
    goal_pieces = set()
    for goal in [] if goals is None else goals:
        goal_pieces.add(int(labels[nearest_pixel(share, layout, goal)]))
    while remaining:
        # the piece nearest along the free space, entered at its nearest pixel; pieces holding
        # goal markers last (the last goal marker is where the robot waits for its cell to clear)
        distance = geodesic_map(layout, ways, position)
        if not np.isfinite(distance[share]).all():  # pieces reached only through others' shares: last
            distance = np.where(
                np.isfinite(distance), distance, geodesic_map(layout, fallback, position) + 1e4
            )
        nearest = [
            float(distance[labels == label].min()) + (1e6 if label in goal_pieces else 0.0)
            for label in remaining
        ]
        label = remaining.pop(int(np.argmin(nearest)))
        piece = labels == label
        if not piece[layout.to_pixel(*position)]:
            flat = int(np.argmin(np.where(piece, distance, np.inf)))
            position = pixel_centre(layout, divmod(flat, piece.shape[1]))
        if not np.array_equal(at, position):  # the robot is elsewhere: it drives to the entry
            path.append(transit(layout, ways, at, position, fallback)[1:])
        plan = plan_region(layout, piece, position, goals, quickest=True)
        path.append(plan.waypoints[1:])
        at = position = plan.waypoints[-1]
    return drop_repeated_points(np.vstack(path))
