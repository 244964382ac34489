"""The team's division of work: who sweeps what, and in which order the robots drive.

Input: a ``Layout``, the protocol and the team size K; output: a ``TeamSplit`` (``team_split``),
one ``TeamStage`` per stage (one cell in ``sequential``; the whole layout in ``open``) and each
robot's rank. Cabin aisles and legroom pockets are single file (a 0.35 m robot in a 0.48 m
aisle: two cannot pass), so the work is split so that robots never have to pass or meet
head-on, and they move in a fixed *convoy*:

- **The way.** Each stage has a *through way*: the shortest path along the aisle from the near
  end of the region (the galley wall in the first cell) to the exit landmark of the next cell,
  or to the far end in a dead end (the last cell, ``open``). The band ``THROUGH_BAND`` around it
  is left to the robots driving along it (a pass covers it); nobody sweeps it, so no sweep ever
  runs along the aisle.
- **Work units.** The band cuts the region into the pieces that branch off the aisle
  (``work_units``).
- **Shares.** The units are ordered along the cabin, farthest first, and cut into K contiguous
  groups minimising the largest estimated finishing time (departure delay + travel + planned
  sweep times; a small dynamic programme). Group ``r`` is the share of the robot of *rank*
  ``r``; extra robots (more robots than units) wait where they are. Shares are disjoint and
  cover the region; the band belongs to the leader's share (it drives it), except the stretches
  where one robot can sweep it with nobody else about: behind everyone for the last robot to
  set off in the first stage, beyond everyone for the leader in a dead end.
- **Convoy order.** Ranks are fixed for the episode: in the first stage they are assigned from
  where the robots stand (by default the team's start poses,
  :func:`cabinbench.sim.world.start_poses`) by minimising the summed squared travel, which gives
  the farthest share to the robot nearest the way out and, robots scattered along the aisle (a
  random start), keeps their order along it: nobody has to pass anybody to reach its share.

The stages depend on the layout alone (the way is laid from the layout's start, whoever stands
there), so robots starting anywhere share out the same work; only the ranks follow the robots.
"""

from __future__ import annotations

from collections import OrderedDict
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TypeVar

import numpy as np
from cabinbench.baselines.boustrophedon.legs import MIN_SWEEP_COMPONENT_PX, plan_region
from cabinbench.baselines.boustrophedon.regions import (
    arc_position,
    cell_region,
    geodesic_from,
    near_bounds,
    near_polyline,
    nearest_pixel,
    pixel_centre,
    reachable,
)
from cabinbench.baselines.boustrophedon.work_units import work_units
from cabinbench.baselines.coverage_planning import FreeSpace
from scipy import ndimage
from scipy.optimize import linear_sum_assignment

from cabinbench.geometry import nearest_point
from cabinbench.layouts.fields import RESOLUTION
from cabinbench.layouts.model import Layout
from cabinbench.sim.world import start_poses

DEPARTURE_GAP = 2.0  # seconds between robots setting off, in convoy (rank) order

THROUGH_BAND = 0.2  # metres each side of the through way left to the robots driving along it

BAND_OWNER_GAP = 0.1  # metres kept between a robot sweeping the band and the others' shares


@dataclass
class TeamStage:
    """One stage of the team's work: ``cell`` (-1 for the whole layout in ``open``), the point
    where the team comes in, and per rank the share (robot-centre pixels) and its goal markers."""

    cell: int
    entry: np.ndarray
    shares: list[np.ndarray]
    goals: list[np.ndarray]
    through: np.ndarray  # the way the convoy drives through (swept by driving, not by sweeps)
    ways: list[np.ndarray]  # the centre lines of those ways (N, 2), metres, one per aisle
    sweeps: list[np.ndarray]  # by rank: what that robot sweeps (its share, less the band others drive)
    estimates: list[float] = field(default_factory=list)  # estimated finishing time per rank (s)


@dataclass
class TeamSplit:
    stages: list[TeamStage]
    ranks: np.ndarray  # ranks[agent]: the robot's place in the convoy (0 leads, takes the farthest)


TEAM_CACHE_SIZE = 8  # teams (layout, protocol, start poses) whose stages and plans are kept
_STAGES_CACHE: OrderedDict = OrderedDict()
Value = TypeVar("Value")


def team_starts(layout: Layout, n_agents: int, starts=None) -> np.ndarray:
    """(K, 2) where the robots of the team stand: ``starts`` (K, 2 or 3), by default the team's
    start poses (:func:`~cabinbench.sim.world.start_poses`)."""
    if starts is None:
        return start_poses(layout, n_agents)[:, :2]
    return np.asarray(starts, dtype=float)[:, :2]


def cached_for_team(cache: OrderedDict, layout: Layout, team: tuple, compute: Callable[[], Value]) -> Value:
    """``compute()`` once per layout and ``team`` (what else the value depends on: the protocol,
    the team size or where its robots stand; every robot of a team asks for the same); the last
    ``TEAM_CACHE_SIZE`` entries are kept in ``cache``."""
    key = (layout.name, layout.content_hash, *team)
    if key in cache:
        cache.move_to_end(key)
        return cache[key]
    value = cache[key] = compute()
    if len(cache) > TEAM_CACHE_SIZE:
        cache.popitem(last=False)
    return value


def team_split(layout: Layout, protocol: str, n_agents: int, starts=None) -> TeamSplit:
    """The team's division of work for robots standing at ``starts`` (K, 2 or 3; default the team's
    start poses). Every robot of a team computes the same; the stages are cached per team size."""
    starts = team_starts(layout, n_agents, starts)
    stages, corridor = cached_for_team(
        _STAGES_CACHE, layout, (protocol, n_agents), lambda: _stages(layout, protocol, n_agents)
    )
    return TeamSplit(stages, _assign_ranks(layout, corridor, starts, stages[0].shares))


def _stages(layout: Layout, protocol: str, n_agents: int) -> tuple[list[TeamStage], np.ndarray]:
    """(the stages, the floor the robots reach their first shares through)."""
    start = np.asarray(layout.start[:2], dtype=float)
    drivable = reachable(layout)
    if protocol == "open":
        aisles = layout.passages[0].exits[:, 1] if layout.passages else np.array([start[1]])
        legs = [(start, _far_end(layout, drivable, start, y)) for y in aisles]
        legs = sorted(legs, key=lambda leg: abs(leg[1][1] - start[1]))[:1]
        stages = [_stage(layout, -1, drivable, layout.goals, start, n_agents, legs, True, True)]
        corridor = drivable
    else:
        first = layout.cleared_cells
        stages, entry = [], start
        for cell in range(first, len(layout.cells)):
            sources = layout.passages[cell - 1].exits if cell > 0 else entry[None]
            entry = nearest_point(sources, entry)
            region = cell_region(layout, cell) & drivable
            dead_end = cell >= len(layout.passages)
            if dead_end:
                targets = np.array([_far_end(layout, region, entry, y) for y in sources[:, 1]])
            else:
                targets = layout.passages[cell].exits
            # one way per aisle, from where the team may come in to where it leaves
            legs = [(sources[np.argmin(np.abs(sources[:, 1] - target[1]))], target) for target in targets]
            legs.sort(key=lambda leg: np.hypot(*(leg[0] - entry)) + 1e-3 * np.hypot(*(leg[1] - entry)))
            legs = legs[:1]  # the convoy's aisle (a second aisle stays in the shares: it is swept)
            stages.append(
                _stage(
                    layout,
                    cell,
                    region,
                    layout.cells[cell].goals,
                    entry,
                    n_agents,
                    legs,
                    dead_end,
                    cell == first,
                )
            )
        start_cell = layout.cell_raster[layout.to_pixel(*layout.start[:2])]
        corridor = (
            drivable & (layout.cell_raster >= min(start_cell, first)) & (layout.cell_raster <= max(first, 0))
        )
        corridor &= ~near_bounds(layout, first) if first < len(layout.passages) else True
    return stages, corridor


def _stage(
    layout: Layout,
    cell: int,
    region: np.ndarray,
    goals: np.ndarray,
    entry: np.ndarray,
    n_agents: int,
    legs: list,
    dead_end: bool,
    first: bool,
) -> TeamStage:
    # the way starts at the near end of the region (behind the entry: the galley wall in the first cell)
    ways = [
        _through_way(layout, region, _far_end(layout, region, target, source[1]), target)
        for source, target in legs
    ]
    through = np.any([near_polyline(layout, way, THROUGH_BAND) for way in ways], axis=0) & region
    units, unit_goals = work_units(layout, region, goals, through, ways[0], entry, n_agents)
    robot = layout.robot
    durations = np.array([_sweep_duration(layout, unit, entry) for unit in units])
    travel = geodesic_from(layout, region, entry, units) / robot.max_speed
    groups, estimates = _partition(durations, travel, n_agents)
    shares, share_goals = [], []
    for begin, end in groups:
        shares.append(np.any(units[begin:end], axis=0) if end > begin else np.zeros_like(region))
        share_goals.append(np.concatenate(unit_goals[begin:end]) if end > begin else np.zeros((0, 2)))
    sweeps = _band_owners(layout, ways, through, shares, first=first, dead_end=dead_end)
    shares[0] = shares[0] | (through & ~np.any(sweeps, axis=0))  # the leader drives the rest of the way
    for rank, sweep in enumerate(sweeps):
        shares[rank] = shares[rank] | (sweep & through)
    return TeamStage(
        cell, np.asarray(entry, dtype=float), shares, share_goals, through, ways, sweeps, estimates
    )


def _band_owners(
    layout: Layout,
    ways: list[np.ndarray],
    through: np.ndarray,
    shares: list[np.ndarray],
    first: bool,
    dead_end: bool,
) -> list[np.ndarray]:
    """What each rank sweeps: its share, plus the stretches of the through band where no other
    robot will drive while it sweeps: behind all the others' shares for the last robot to set
    off in the first stage (the others have left by then), and beyond all of them for the
    leader in a dead end (the last cell, or ``open``)."""
    sweeps = [share.copy() for share in shares]
    busy = [rank for rank, share in enumerate(shares) if share.any()]
    if len(busy) < 2 or len(ways) != 1 or len(ways[0]) < 2:
        return sweeps  # with several aisles, every robot may cross any stretch: leave the bands alone
    way = ways[0]
    band_s = np.full(through.shape, np.nan)
    band_s[through] = arc_position(way, layout, through)
    spans = []
    for rank in busy:
        along = arc_position(way, layout, shares[rank])
        spans.append((along.min(), along.max()))
    margin = 2 * layout.robot.radius + BAND_OWNER_GAP
    swept_up_to = -np.inf
    last, (low, high) = busy[-1], spans[-1]
    others_low = min(other_low for other_low, _ in spans[:-1])
    if first and others_low - margin > high:
        swept_up_to = others_low - margin
        sweeps[last] |= through & (band_s <= swept_up_to)
    low, high = spans[0]
    others_high = max(other_high for _, other_high in spans[1:])
    if dead_end and busy[0] == 0 and others_high + margin < low:
        sweeps[0] |= through & (band_s >= others_high + margin) & (band_s > swept_up_to)
    return sweeps


def _through_way(layout: Layout, region: np.ndarray, entry: np.ndarray, target) -> np.ndarray:
    """The shortest way (N, 2) from ``entry`` to ``target``: the aisle the convoy drives along.
    Nobody sweeps the band ``THROUGH_BAND`` around it; the robots driving through cover it."""
    xs, ys = layout.pixel_centres()
    row, col = nearest_pixel(region, layout, np.asarray(target, dtype=float))
    row0, col0 = nearest_pixel(region, layout, entry)
    path = FreeSpace(region).transit((row0, col0), (row, col))
    return np.column_stack([xs[path[:, 1]], ys[path[:, 0]]])


def _far_end(layout: Layout, region: np.ndarray, entry: np.ndarray, level: float | None = None) -> np.ndarray:
    """Where the aisle at height ``level`` (default: the entry's) ends, away from ``entry``
    along x (the cabin's length): the farthest pixel of ``region`` within a pixel or two of
    that height (``entry`` itself when the region has none there)."""
    xs, ys = layout.pixel_centres()
    level = entry[1] if level is None else level
    rows, cols = np.nonzero(region & (np.abs(ys - level) <= 2.5 * RESOLUTION)[:, None])
    if not len(rows):
        return np.asarray(entry, dtype=float)
    away = cols.max() if entry[0] <= xs[cols].mean() else cols.min()
    rows = rows[cols == away]
    return np.array([xs[away], ys[rows[np.argmin(np.abs(ys[rows] - level))]]])


def _sweep_duration(layout: Layout, unit: np.ndarray, entry: np.ndarray) -> float:
    """Estimated seconds to sweep ``unit``: each of its pieces planned on its own."""
    labels, count = ndimage.label(unit)
    total = 0.0
    for label in range(1, count + 1):
        piece = labels == label
        if piece.sum() >= MIN_SWEEP_COMPONENT_PX:
            start = pixel_centre(layout, nearest_pixel(piece, layout, entry))
            total += plan_region(layout, piece, start, None, quickest=True).duration
    return total


def _partition(
    durations: np.ndarray, travel: np.ndarray, n_agents: int
) -> tuple[list[tuple[int, int]], list[float]]:
    """Cut the ordered units into ``n_agents`` contiguous groups (rank r gets group r, empty
    groups last) minimising the largest estimated finishing time, where rank r finishes at
    r × DEPARTURE_GAP + travel to its farthest unit (the way there passes the others) + the
    durations of its units."""
    count = len(durations)
    groups_used = min(n_agents, count)
    prefix = np.concatenate([[0.0], np.cumsum(durations)])

    def finish(rank: int, begin: int, end: int) -> float:
        return rank * DEPARTURE_GAP + float(np.max(travel[begin:end])) + prefix[end] - prefix[begin]

    best = np.full((groups_used + 1, count + 1), np.inf)
    cut = np.zeros((groups_used + 1, count + 1), dtype=int)
    best[0, 0] = 0.0
    for rank in range(groups_used):
        for end in range(rank + 1, count + 1):
            for begin in range(rank, end):
                value = max(best[rank, begin], finish(rank, begin, end))
                if value < best[rank + 1, end] - 1e-9:
                    best[rank + 1, end], cut[rank + 1, end] = value, begin
    groups, end = [], count
    for rank in range(groups_used, 0, -1):
        groups.append((int(cut[rank, end]), end))
        end = cut[rank, end]
    groups = groups[::-1] + [(count, count)] * (n_agents - groups_used)
    estimates = [finish(rank, b, e) if e > b else 0.0 for rank, (b, e) in enumerate(groups)]
    return groups, estimates


def _assign_ranks(
    layout: Layout, corridor: np.ndarray, starts: np.ndarray, shares: list[np.ndarray]
) -> np.ndarray:
    """ranks[agent]: minimum summed squared distance from the start poses to the first stage's
    shares (squares give the farthest share to the robot nearest the way out)."""
    cost = np.zeros((len(starts), len(shares)))
    for agent, start in enumerate(starts):
        distance = geodesic_from(layout, corridor | np.any(shares, axis=0), start, shares)
        cost[agent] = np.where(np.isfinite(distance), distance, 1e3) ** 2
    cost[:, [not share.any() for share in shares]] = 0.0
    agents, ranks = linear_sum_assignment(cost)
    result = np.empty(len(starts), dtype=int)
    result[agents] = ranks
    return result
