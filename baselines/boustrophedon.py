"""``boustrophedon``: the classic coverage planner, planned from the layout and driven through the
env's actions (never by moving the robot).

Planning (:func:`plan_layout`) runs the raster pipeline of :mod:`.coverage_planning`
(boustrophedon decomposition → swaths → route → A* transits) on the reachable robot-centre
raster. In the ``sequential`` protocol it plans cell by cell, as the cells open: each cell's
sweep stays clear of its closed bounds and sweeps the sub-cells holding goal markers last (so
that the cell, which clears when its last goal is reached, is fully swept by then), then an A*
transit drives to the exit landmark of the next cell. In ``open`` the whole layout is one plan.

Teams (``n_agents`` = K > 1, :func:`team_split`, :func:`team_plans`). Cabin aisles and legroom
pockets are single file (a 0.35 m robot in a 0.48 m aisle: two cannot pass), so the work is
split so that robots never have to pass or meet head-on, and they move in a fixed *convoy*:

- **The way.** Each stage (one cell in ``sequential``; the whole layout in ``open``) has a
  *through way*: the shortest path along the aisle from the near end of the region (the galley
  wall in the first cell) to the exit landmark of the next cell, or to the far end in a dead end
  (the last cell, ``open``). The band ``THROUGH_BAND`` around it is left to the robots driving
  along it (a pass covers it); nobody sweeps it, so no sweep ever runs along the aisle.
- **Work units.** The band cuts the region into the pieces that branch off the aisle: legroom
  pockets, the two halves of a galley zone, the corridors between two aisles. A piece holding
  several goal markers (everything beyond a second aisle) is cut further around them (each pixel
  joins the goal marker nearest along the free space); a piece without one joins the nearest
  unit on its side of the aisle, and pieces beyond the last goal marker (a rear galley) all go to
  one unit. Units meeting along a long boundary are merged, a unit that does not touch the band
  joins the unit that leads to it, and with fewer units than robots the largest open unit is
  halved. Without goal markers the region is cut into strips across x instead.
- **Shares.** The units are ordered along the cabin, farthest first, and cut into K contiguous
  groups minimising the largest estimated finishing time (departure delay + travel + planned
  sweep times; a small dynamic programme). Group ``r`` is the share of the robot of *rank*
  ``r``; extra robots (more robots than units) wait where they are. Shares are disjoint and
  cover the region; the band belongs to the leader's share (it drives it), except the stretches
  where one robot can sweep it with nobody else about: behind everyone for the last robot to
  set off in the first stage, beyond everyone for the leader in a dead end.
- **Convoy order.** Ranks are fixed for the episode: in the first stage they are assigned from
  the start poses (:func:`cabinbench.world.start_poses`) by minimising the summed squared travel,
  which gives the farthest share to the robot nearest the way out. Rank ``r`` sets off
  ``r × DEPARTURE_GAP`` seconds after the start, so robots enter the aisle in rank order, the
  leader heading farthest; every transit keeps to the band and the robot's own share where it
  can, so nobody crosses another robot's share.
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
- **Safety.** A robot whose lidar shows another robot right in front of it stops driving
  forward (it may still turn) until the way is clear, for at most ``BLOCKED_PATIENCE`` seconds
  (then it drives on rather than wait for ever). The plans make such meetings rare (a robot
  catching up with one turning into a pocket).

A baseline sees only its own ``info``, so the team coordinates through its plans (all robots'
plans are computed once per layout and team, each robot takes its own) and the team's shared
``info`` entries (``time``, ``cells_cleared``): it waits, it never moves a robot but through
actions.

Following: a :class:`~.path_following.PathFollower` turns the waypoints into velocity commands
from ``info["pose"]``.

Demonstrations for GAIL: :func:`record_demonstrations` runs this baseline in the env and saves
``observations`` [N, D] float32, ``actions`` [N, 2] float32, ``episode`` [N] int32 and
``observation_config`` (JSON of the env's ``observation_config``: the settings that shape the
observation) to an ``.npz``.
"""

from __future__ import annotations

import json
import math
from collections import OrderedDict
from dataclasses import dataclass, field

import numpy as np
from scipy import ndimage
from scipy.optimize import linear_sum_assignment
from scipy.sparse.csgraph import dijkstra

from cabinbench.agents import Baseline, EpisodeContext
from cabinbench.geometry import pixels_to_world, world_to_pixel
from cabinbench.layout import RESOLUTION, Layout
from cabinbench.lidar import LidarConfig
from cabinbench.observation import LIDAR_CHANNELS, lidar_rays
from cabinbench.world import TIME_STEP, start_poses

from .coverage_planning import FreeSpace, driving_time, plan_coverage
from .path_following import PathFollower

BOUND_MARGIN = 0.03  # metres kept between the robot's disc and a closed bound
DEPARTURE_GAP = 2.0  # seconds between robots setting off, in convoy (rank) order
FOLLOW_GAP = 0.12  # metres: stop driving forward when another robot is this close in front
ON_WAYPOINT = 0.05  # metres: a leg whose first waypoint is this close starts at its second
BLOCKED_PATIENCE = 5.0  # seconds a robot waits for a robot in front before it drives on anyway
MIN_SWEEP_COMPONENT_PX = 4  # smaller scraps of a share are left to the neighbouring sweeps
GOAL_TOUCH_MARGIN = 0.03  # metres inside the reach at which a sweep counts as touching a goal
STAGING_GAP = 0.06  # metres between a staged robot and one passing along the through way
STAGING_MARGIN = 0.5  # seconds added to the estimated back-out time before the convoy moves on
THROUGH_BAND = 0.2  # metres each side of the through way left to the robots driving along it
MERGE_BOUNDARY_PX = 3  # units meeting along this many pixels or more are merged
OPEN_UNIT_PX = 3  # a unit this many pixels from its edge at its widest is open floor (it may be halved)
BAND_OWNER_GAP = 0.1  # metres kept between a robot sweeping the band and the others' shares


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


def plan_layout(layout: Layout, protocol: str = "sequential", agent: int = 0, n_agents: int = 1) -> list[Leg]:
    """The whole plan for robot ``agent`` of a team of ``n_agents``, as legs in driving order."""
    if n_agents > 1:
        return plan_team(layout, protocol, agent, n_agents)
    start = start_poses(layout, n_agents)[agent, :2]
    drivable = layout.centre_free  # already keeps the disc 1 cm off every wall
    if protocol == "open":
        return [Leg(_plan(layout, drivable, start, goals=None).waypoints, 0, "sweep")]
    legs, position = [], start
    first_cell = max(0, layout.cleared_cells - 1)
    for cell in range(first_cell, len(layout.cells)):
        if cell >= layout.cleared_cells:
            region = drivable & _cell_region(layout, cell)
            goals = layout.cells[cell].goals
            plan = _plan(layout, region, position, goals)
            if cell + 1 == len(layout.cells) and len(goals):
                # Reaching the last goal ends the episode: hold back the goal this sweep would
                # touch last, sweep around its spot, then drive to it.
                final_goal = goals[np.argmax(_first_touches(plan.waypoints, goals, layout.robot.radius))]
                keep_off = _near_points(layout, final_goal[None], layout.robot.radius + 0.02)
                plan = _plan(layout, region & ~keep_off, position, goals)
                legs.append(Leg(plan.waypoints, cell, "sweep"))
                legs.append(
                    Leg(_transit(layout, region | keep_off, plan.waypoints[-1], final_goal), cell, "goals")
                )
            else:
                legs.append(Leg(plan.waypoints, cell, "sweep"))
            position = legs[-1].waypoints[-1]
        if cell + 1 < len(layout.cells):
            exits = layout.passages[cell].exits
            exit_point = exits[np.argmin(np.hypot(*(exits - position).T))]
            corridor = (
                drivable & np.isin(layout.cell_raster, (cell, cell + 1)) & ~_near_bounds(layout, cell - 1)
            )
            legs.append(Leg(_transit(layout, corridor, position, exit_point), cell, "exit"))
            position = exit_point
    return legs


def _plan(
    layout: Layout, region: np.ndarray, start: np.ndarray, goals: np.ndarray | None, quickest: bool = False
):
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


def _near_points(layout: Layout, points: np.ndarray, distance: float) -> np.ndarray:
    xs, ys = layout.pixel_centres()
    grid_x, grid_y = np.meshgrid(xs, ys)
    near = np.zeros(layout.raster_shape, dtype=bool)
    for x, y in points:
        near |= np.hypot(grid_x - x, grid_y - y) < distance
    return near


def _transit(
    layout: Layout, region: np.ndarray, start: np.ndarray, end: np.ndarray, fallback: np.ndarray | None = None
) -> np.ndarray:
    """An A* path (metres) from ``start`` to ``end`` through ``region`` (else through ``fallback``)."""
    begin, goal = (
        world_to_pixel(start, RESOLUTION, layout.origin),
        world_to_pixel(end, RESOLUTION, layout.origin),
    )
    if fallback is not None:
        try:
            pixels = FreeSpace(region).transit(begin, goal)
        except ValueError:
            pixels = FreeSpace(fallback).transit(begin, goal)
    else:
        pixels = FreeSpace(region).transit(begin, goal)
    return np.vstack([start, pixels_to_world(pixels, RESOLUTION, layout.origin)[1:-1], end])


def _first_touches(waypoints: np.ndarray, points: np.ndarray, reach: float) -> np.ndarray:
    """For each point, how far along the path (metres) the robot centre first comes within ``reach``."""
    steps = [
        np.linspace(a, b, max(2, int(np.hypot(*(b - a)) / 0.02) + 1))
        for a, b in zip(waypoints[:-1], waypoints[1:])
    ]
    dense = np.vstack(steps) if steps else waypoints
    travelled = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(dense, axis=0).T))])
    within = np.hypot(dense[:, None, 0] - points[None, :, 0], dense[:, None, 1] - points[None, :, 1]) <= reach
    return np.where(within.any(axis=0), travelled[within.argmax(axis=0)], travelled[-1])


def _near_bounds(layout: Layout, passage: int) -> np.ndarray:
    """Pixels where the robot's disc would touch the bounds of ``passage`` (none if out of range)."""
    near = np.zeros(layout.raster_shape, dtype=bool)
    if not 0 <= passage < len(layout.passages):
        return near
    xs, ys = layout.pixel_centres()
    grid_x, grid_y = np.meshgrid(xs, ys)
    for x0, y0, x1, y1 in layout.passages[passage].bounds:
        direction = np.array([x1 - x0, y1 - y0])
        t = np.clip(
            ((grid_x - x0) * direction[0] + (grid_y - y0) * direction[1]) / direction.dot(direction), 0, 1
        )
        near |= (
            np.hypot(grid_x - (x0 + t * direction[0]), grid_y - (y0 + t * direction[1]))
            < layout.robot.radius + BOUND_MARGIN
        )
    return near


def _cell_region(layout: Layout, cell: int) -> np.ndarray:
    """Robot-centre pixels of ``cell`` that keep the disc off the bounds on either side."""
    return (
        layout.centre_free
        & (layout.cell_raster == cell)
        & ~_near_bounds(layout, cell - 1)
        & ~_near_bounds(layout, cell)
    )


def team_share(layout: Layout, region: np.ndarray, agent: int, n_agents: int) -> np.ndarray:
    """Robot ``agent``'s part of ``region``: the region cut across the cabin's length into
    ``n_agents`` strips of equal coverable area (robot 0 nearest the start). Strips follow the
    cabin's long axis so that each robot keeps whole legroom pockets. (The team planner uses
    :func:`team_split`, which cuts between pockets; this is its fallback for regions without
    goal markers.)"""
    if n_agents == 1:
        return region
    columns = np.flatnonzero(region.any(axis=0))
    weights = region[:, columns].sum(axis=0).cumsum()
    edges = np.searchsorted(weights, weights[-1] * np.arange(1, n_agents) / n_agents)
    bounds = np.concatenate([[columns[0]], columns[np.minimum(edges, len(columns) - 1)], [columns[-1] + 1]])
    share = np.zeros_like(region)
    share[:, bounds[agent] : bounds[agent + 1]] = region[:, bounds[agent] : bounds[agent + 1]]
    return share


# ------------------------------------------------------------------------------------ teams


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


_SPLIT_CACHE: OrderedDict = OrderedDict()
_SPLIT_CACHE_SIZE = 8


def team_split(layout: Layout, protocol: str, n_agents: int) -> TeamSplit:
    """The team's division of work (every robot of a team computes the same; cached)."""
    key = (layout.name, layout.content_hash, protocol, n_agents)
    if key in _SPLIT_CACHE:
        _SPLIT_CACHE.move_to_end(key)
        return _SPLIT_CACHE[key]
    starts = start_poses(layout, n_agents)[:, :2]
    drivable = _reachable(layout)
    if protocol == "open":
        aisles = layout.passages[0].exits[:, 1] if layout.passages else np.array([starts[0][1]])
        legs = [(starts[0], _far_end(layout, drivable, starts[0], y)) for y in aisles]
        legs = sorted(legs, key=lambda leg: abs(leg[1][1] - starts[0][1]))[:1]
        stages = [_stage(layout, -1, drivable, layout.goals, starts[0], n_agents, legs, True, True)]
        corridor = drivable
    else:
        first = layout.cleared_cells
        stages, entry = [], starts[0]
        for cell in range(first, len(layout.cells)):
            sources = layout.passages[cell - 1].exits if cell > 0 else entry[None]
            entry = sources[np.argmin(np.hypot(*(sources - entry).T))]
            region = _cell_region(layout, cell) & drivable
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
        corridor &= ~_near_bounds(layout, first) if first < len(layout.passages) else True
    split = TeamSplit(stages, _assign_ranks(layout, corridor, starts, stages[0].shares))
    _SPLIT_CACHE[key] = split
    if len(_SPLIT_CACHE) > _SPLIT_CACHE_SIZE:
        _SPLIT_CACHE.popitem(last=False)
    return split


def _reachable(layout: Layout) -> np.ndarray:
    """Robot-centre pixels connected to the start (4-connected, as the planner sees them)."""
    labels, _ = ndimage.label(layout.centre_free)
    start = layout.to_pixel(*layout.start[:2])
    return labels == labels[start] if labels[start] else layout.centre_free.copy()


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
    through = np.any([_near_polyline(layout, way, THROUGH_BAND) for way in ways], axis=0) & region
    units, unit_goals = work_units(layout, region, goals, through, ways[0], entry, n_agents)
    robot = layout.robot
    durations = np.array([_sweep_duration(layout, unit, entry) for unit in units])
    travel = _geodesic_from(layout, region, entry, units) / robot.max_speed
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
    band_s[through] = _arc_position(way, layout, through)
    spans = []
    for rank in busy:
        along = _arc_position(way, layout, shares[rank])
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


def _arc_position(way: np.ndarray, layout: Layout, mask: np.ndarray) -> np.ndarray:
    """For each pixel of ``mask``, how far along ``way`` (metres) its nearest point lies."""
    xs, ys = layout.pixel_centres()
    rows, cols = np.nonzero(mask)
    points = np.column_stack([xs[cols], ys[rows]])
    starts, ends = way[:-1], way[1:]
    direction = ends - starts
    length = np.sqrt(np.maximum((direction**2).sum(axis=1), 1e-12))
    t = np.clip(((points[:, None, :] - starts[None]) * direction[None]).sum(axis=2) / length[None] ** 2, 0, 1)
    nearest = starts[None] + t[..., None] * direction[None]
    segment = np.argmin(((points[:, None, :] - nearest) ** 2).sum(axis=2), axis=1)
    offsets = np.concatenate([[0.0], np.cumsum(length)])
    return offsets[segment] + t[np.arange(len(points)), segment] * length[segment]


def _through_way(layout: Layout, region: np.ndarray, entry: np.ndarray, target) -> np.ndarray:
    """The shortest way (N, 2) from ``entry`` to ``target``: the aisle the convoy drives along.
    Nobody sweeps the band ``THROUGH_BAND`` around it; the robots driving through cover it."""
    xs, ys = layout.pixel_centres()
    row, col = _nearest_pixel(region, layout, np.asarray(target, dtype=float))
    row0, col0 = _nearest_pixel(region, layout, entry)
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


def _near_polyline(layout: Layout, points: np.ndarray, distance: float) -> np.ndarray:
    xs, ys = layout.pixel_centres()
    grid_x, grid_y = np.meshgrid(xs, ys)
    near = np.zeros(layout.raster_shape, dtype=bool)
    if len(points) == 1:
        points = np.vstack([points, points])
    for (x0, y0), (x1, y1) in zip(points[:-1], points[1:]):
        direction = np.array([x1 - x0, y1 - y0])
        length_sq = max(float(direction.dot(direction)), 1e-12)
        t = np.clip(((grid_x - x0) * direction[0] + (grid_y - y0) * direction[1]) / length_sq, 0, 1)
        near |= np.hypot(grid_x - (x0 + t * direction[0]), grid_y - (y0 + t * direction[1])) <= distance
    return near


def _attach_to_way(units: np.ndarray, unit_goals: list[np.ndarray], through: np.ndarray):
    """Merge every unit that does not touch the through band into the neighbour it shares the
    longest boundary with (a pocket off a second aisle joins the corridor that leads to it), so
    that every robot reaches its share from the convoy's aisle without crossing another's."""
    units, unit_goals = list(units), list(unit_goals)
    near_way = ndimage.binary_dilation(through)
    while len(units) > 1:
        detached = [k for k, unit in enumerate(units) if not (unit & near_way).any()]
        if not detached:
            break
        k = detached[0]
        grown = ndimage.binary_dilation(units[k])
        contact = [(grown & other).sum() if j != k else 0 for j, other in enumerate(units)]
        j = int(np.argmax(contact))
        if contact[j] == 0:
            break  # an island: it keeps its own robot
        keep, drop = min(j, k), max(j, k)
        units[keep] = units[keep] | units[drop]
        unit_goals[keep] = np.concatenate([unit_goals[keep], unit_goals[drop]])
        del units[drop], unit_goals[drop]
    return np.array(units).reshape(len(units), *through.shape), unit_goals


def _merge_open_units(units: np.ndarray, unit_goals: list[np.ndarray]):
    """Merge units that meet along a boundary of ``MERGE_BOUNDARY_PX`` pixels or more (two halves
    of a galley zone): robots sweeping both sides at once would meet on it. Keeps the order (a
    merged unit takes the place of its first member)."""
    count = len(units)
    label = np.full(units.shape[1:], -1)
    for k, unit in enumerate(units):
        label[unit] = k
    pairs = np.concatenate(
        [
            np.column_stack([label[:, :-1].ravel(), label[:, 1:].ravel()]),
            np.column_stack([label[:-1, :].ravel(), label[1:, :].ravel()]),
        ]
    )
    pairs = pairs[(pairs >= 0).all(axis=1) & (pairs[:, 0] != pairs[:, 1])]
    pairs = np.sort(pairs, axis=1)
    parent = list(range(count))

    def root(k):
        while parent[k] != k:
            k = parent[k]
        return k

    if len(pairs):
        found, lengths = np.unique(pairs, axis=0, return_counts=True)
        for (a, b), length in zip(found, lengths):
            if length >= MERGE_BOUNDARY_PX:
                ra, rb = root(int(a)), root(int(b))
                parent[max(ra, rb)] = min(ra, rb)
    roots = [root(k) for k in range(count)]
    kept = sorted(set(roots))
    merged = np.array([np.any(units[[k for k in range(count) if roots[k] == r]], axis=0) for r in kept])
    goals = [np.concatenate([unit_goals[k] for k in range(count) if roots[k] == r]) for r in kept]
    return merged.reshape(len(kept), *units.shape[1:]), goals


def work_units(
    layout: Layout,
    region: np.ndarray,
    goals: np.ndarray,
    through: np.ndarray,
    way: np.ndarray,
    entry: np.ndarray,
    n_agents: int,
):
    """``region`` less the ``through`` band cut into work units, ordered farthest from ``entry``
    (along x) first. Returns (unit masks (U, H, W) bool, goal markers (M_u, 2) per unit).

    The band cuts a cabin into the pieces that branch off the aisle: legroom pockets, the halves
    of the galley zones, the corridors between two aisles. A piece holding several goal markers
    (everything beyond a second aisle, say) is cut further, every pixel joining the goal marker
    nearest along the free space; pieces without a goal marker join the nearest unit. Then
    units meeting along a long boundary are merged (:func:`_merge_open_units`), units that do
    not touch the band join the one that leads to them (:func:`_attach_to_way`) and, while there
    are fewer units than robots, the largest open unit is halved (:func:`_halve`). Without goal
    markers the region is cut into ``3 × n_agents`` strips of equal area across x instead.
    """
    region = np.asarray(region, dtype=bool)
    rest = region & ~through
    xs, ys = layout.pixel_centres()
    units, unit_goals = [], []
    if len(goals):
        labels, count = ndimage.label(rest)
        owner = np.array([labels[_nearest_pixel(rest, layout, goal)] for goal in goals])
        for piece_label in range(1, count + 1):
            piece = labels == piece_label
            mine = goals[owner == piece_label]
            if len(mine):
                parts = _voronoi(layout, piece, mine) if len(mine) > 1 else [(piece, mine)]
                units += [part for part, _ in parts]
                unit_goals += [part_goals for _, part_goals in parts]
        if not units:
            units, unit_goals = [rest], [goals]
        # pieces without a goal marker join the nearest unit on the same side of the way
        # (pieces beyond the last goal marker, at the dead end of the way, go to one robot: two
        # robots would meet head-on in the aisle on their ways there and back)
        sides = [_side_of_way(layout, way, unit) for unit in units]
        gaps = [ndimage.distance_transform_edt(~unit) for unit in units]
        reach = (
            max(float(_arc_position(way, layout, unit).max()) for unit in units) if len(way) > 1 else np.inf
        )
        beyond = []
        for piece_label in range(1, count + 1):
            if (owner == piece_label).any():
                continue
            piece = labels == piece_label
            side = _side_of_way(layout, way, piece)
            candidates = [k for k in range(len(units)) if sides[k] == side] or list(range(len(units)))
            k = min(candidates, key=lambda j: gaps[j][piece].min())
            units[k] = units[k] | piece
            if len(way) > 1 and _arc_position(way, layout, piece).min() > reach:
                beyond.append(k)
        beyond = sorted(set(beyond))
        if len(beyond) > 1:
            keep = beyond[0]
            for k in beyond[:0:-1]:
                units[keep] = units[keep] | units.pop(k)
                unit_goals[keep] = np.concatenate([unit_goals[keep], unit_goals.pop(k)])
        units, unit_goals = _merge_open_units(np.array(units), unit_goals)
        units, unit_goals = _attach_to_way(units, unit_goals, through)
        units, unit_goals = list(units), list(unit_goals)
        keys = [tuple(g[0]) for g in unit_goals]
    else:
        parts = 3 * n_agents
        units = [unit for unit in (team_share(layout, rest, k, parts) for k in range(parts)) if unit.any()]
        unit_goals = [np.zeros((0, 2)) for _ in units]
        keys = [(xs[np.nonzero(unit)[1]].mean(), ys[np.nonzero(unit)[0]].mean()) for unit in units]
    while len(units) < n_agents:  # more robots than units: halve the largest open unit
        widths = [ndimage.distance_transform_edt(unit).max() for unit in units]
        open_units = [k for k, width in enumerate(widths) if width >= OPEN_UNIT_PX]
        if not open_units:
            break  # pockets only: the extra robots wait
        k = max(open_units, key=lambda j: units[j].sum())
        first, second = _halve(units[k])
        goals_k = unit_goals[k]
        in_first = np.array([first[_nearest_pixel(units[k], layout, g)] for g in goals_k], dtype=bool)
        units[k : k + 1] = [first, second]
        unit_goals[k : k + 1] = [goals_k[in_first], goals_k[~in_first]]
        keys[k : k + 1] = [
            (xs[np.nonzero(u)[1]].mean(), ys[np.nonzero(u)[0]].mean()) for u in (first, second)
        ]
    centre_x = np.mean([key[0] for key in keys]) if keys else 0.0
    direction = 1.0 if entry[0] <= centre_x else -1.0  # the far end is the one away from the entry
    order = sorted(
        range(len(units)), key=lambda k: (-direction * round(keys[k][0], 2), -round(keys[k][1], 2))
    )
    return np.array([units[k] for k in order]).reshape(len(order), *region.shape), [
        unit_goals[k] for k in order
    ]


def _side_of_way(layout: Layout, way: np.ndarray, mask: np.ndarray) -> int:
    """Which side of ``way`` (+1 left, -1 right, 0 on it) most of ``mask`` lies on."""
    if len(way) < 2 or not mask.any():
        return 0
    xs, ys = layout.pixel_centres()
    rows, cols = np.nonzero(mask)
    points = np.column_stack([xs[cols], ys[rows]])
    starts, ends = way[:-1], way[1:]
    direction = ends - starts
    length_sq = np.maximum((direction**2).sum(axis=1), 1e-12)
    t = np.clip(((points[:, None, :] - starts[None]) * direction[None]).sum(axis=2) / length_sq[None], 0, 1)
    gaps = points[:, None, :] - (starts[None] + t[..., None] * direction[None])
    segment = np.argmin((gaps**2).sum(axis=2), axis=1)
    picked = gaps[np.arange(len(points)), segment]
    cross = direction[segment, 0] * picked[:, 1] - direction[segment, 1] * picked[:, 0]
    return int(np.sign(np.sum(np.sign(cross))))


def _voronoi(layout: Layout, piece: np.ndarray, goals: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
    """``piece`` cut between ``goals``: every pixel joins the goal nearest along the free space."""
    free = FreeSpace(piece)
    nodes = np.array([free.node_id[_nearest_pixel(piece, layout, goal)] for goal in goals])
    unique_nodes = np.unique(nodes)
    _, _, sources = dijkstra(
        free.graph, directed=False, indices=unique_nodes, min_only=True, return_predecessors=True
    )
    node_to_part = {int(node): k for k, node in enumerate(unique_nodes)}
    label = np.full(piece.shape, -1)
    label[piece] = [node_to_part.get(int(source), -1) for source in sources]
    if (label[piece] < 0).any():
        _, (rows, cols) = ndimage.distance_transform_edt(label < 0, return_indices=True)
        stray = piece & (label < 0)
        label[stray] = label[rows[stray], cols[stray]]
    return [(label == k, goals[nodes == node]) for k, node in enumerate(unique_nodes)]


def _halve(unit: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``unit`` cut across its longer side into two parts of equal area."""
    rows, cols = np.nonzero(unit)
    axis = 0 if np.ptp(rows) >= np.ptp(cols) else 1
    along = rows if axis == 0 else cols
    cut = np.sort(along)[len(along) // 2]
    first = unit.copy()
    index = np.indices(unit.shape)[axis]
    first &= index < cut
    return first, unit & ~first


def _nearest_pixel(region: np.ndarray, layout: Layout, point: np.ndarray) -> tuple[int, int]:
    """The pixel of ``region`` nearest to ``point`` (metres)."""
    rows, cols = np.nonzero(region)
    xs, ys = layout.pixel_centres()
    k = int(np.argmin((xs[cols] - point[0]) ** 2 + (ys[rows] - point[1]) ** 2))
    return int(rows[k]), int(cols[k])


def _geodesic_from(layout: Layout, region: np.ndarray, point: np.ndarray, masks) -> np.ndarray:
    """Free-space distance (metres) from ``point`` to the nearest pixel of each mask."""
    free = FreeSpace(region)
    source = free.node_id[_nearest_pixel(region, layout, point)]
    distances = np.full(region.shape, np.inf)
    distances[region] = dijkstra(free.graph, directed=False, indices=source)
    return np.array([distances[mask].min() if mask.any() else np.inf for mask in masks]) * RESOLUTION


def _geodesic_map(layout: Layout, region: np.ndarray, point: np.ndarray) -> np.ndarray:
    """Free-space distance (pixels) from ``point`` to every pixel of ``region`` (inf elsewhere)."""
    free = FreeSpace(region)
    distances = np.full(region.shape, np.inf)
    distances[region] = dijkstra(
        free.graph, directed=False, indices=free.node_id[_nearest_pixel(region, layout, point)]
    )
    return distances


def _sweep_duration(layout: Layout, unit: np.ndarray, entry: np.ndarray) -> float:
    """Estimated seconds to sweep ``unit``: each of its pieces planned on its own."""
    xs, ys = layout.pixel_centres()
    labels, count = ndimage.label(unit)
    total = 0.0
    for label in range(1, count + 1):
        piece = labels == label
        if piece.sum() >= MIN_SWEEP_COMPONENT_PX:
            row, col = _nearest_pixel(piece, layout, entry)
            total += _plan(layout, piece, np.array([xs[col], ys[row]]), None, quickest=True).duration
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
        distance = _geodesic_from(layout, corridor | np.any(shares, axis=0), start, shares)
        cost[agent] = np.where(np.isfinite(distance), distance, 1e3) ** 2
    cost[:, [not share.any() for share in shares]] = 0.0
    agents, ranks = linear_sum_assignment(cost)
    result = np.empty(len(starts), dtype=int)
    result[agents] = ranks
    return result


_PLAN_CACHE: OrderedDict = OrderedDict()


def plan_team(layout: Layout, protocol: str, agent: int, n_agents: int) -> list[Leg]:
    """Robot ``agent``'s legs in a team of ``n_agents`` (see the module docstring)."""
    return list(team_plans(layout, protocol, n_agents)[agent])


def team_plans(layout: Layout, protocol: str, n_agents: int) -> list[list[Leg]]:
    """Every robot's legs (computed once per layout and team: each robot's baseline instance
    takes its own). The departure gates of a cell are set from all robots' plans: once the cell
    clears, every robot backs out to its staging point (clear of the aisle), and rank r drives
    on ``T + r × DEPARTURE_GAP`` seconds after the clear, T being the longest estimated back-out."""
    key = (layout.name, layout.content_hash, protocol, n_agents)
    if key in _PLAN_CACHE:
        _PLAN_CACHE.move_to_end(key)
        return _PLAN_CACHE[key]
    split = team_split(layout, protocol, n_agents)
    plans = [_robot_legs(layout, split, agent, n_agents) for agent in range(n_agents)]
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
    _PLAN_CACHE[key] = plans
    if len(_PLAN_CACHE) > _SPLIT_CACHE_SIZE:
        _PLAN_CACHE.popitem(last=False)
    return plans


def _robot_legs(layout: Layout, split: TeamSplit, agent: int, n_agents: int) -> list[Leg]:
    rank = int(split.ranks[agent])
    position = start_poses(layout, n_agents)[agent, :2]
    drivable = _reachable(layout)
    if split.stages[0].cell < 0:  # open: one stage
        stage = split.stages[0]
        share = stage.sweeps[rank]
        if not share.any():
            return []
        waypoints = _sweep_path(layout, share, position, None, drivable & ~_others(stage, rank), drivable)
        return [Leg(waypoints, -1, "sweep", None, rank * DEPARTURE_GAP)]

    legs: list[Leg] = []
    wait = (None, rank * DEPARTURE_GAP, False)  # the next leg starts after (cell cleared, delay, gate)
    at_cell = layout.cell_raster[layout.to_pixel(*position)]
    last_cell = len(layout.cells) - 1
    previous = None

    def add(waypoints, cell, purpose):
        nonlocal wait
        if len(waypoints) > 1:
            legs.append(Leg(np.asarray(waypoints, dtype=float), cell, purpose, *wait))
            wait = (None, 0.0, False)

    for stage in split.stages:
        cell, share, goals = stage.cell, stage.sweeps[rank], stage.goals[rank]
        if not share.any():
            continue  # nothing for this robot here: it waits where it is
        corridor = (
            drivable
            & (layout.cell_raster >= min(at_cell, cell))
            & (layout.cell_raster <= cell)
            & ~_near_bounds(layout, min(at_cell, cell) - 1)
            & ~_near_bounds(layout, cell)
        )
        corridor |= share | (
            _near_points(layout, position[None], 2 * RESOLUTION) & drivable
        )  # where it stands
        # transits keep to the aisle and this robot's own share where they can
        lane = corridor & ~_others(stage, rank)
        if previous is not None:
            lane &= ~_others(previous, rank)
        previous = stage
        if rank == 0 and cell > 0 and at_cell < cell:  # the leader moves the team on through the exit
            exits = layout.passages[cell - 1].exits
            exit_point = exits[np.argmin(np.hypot(*(exits - position).T))]
            add(_transit(layout, lane, position, exit_point, corridor), cell - 1, "exit")
            position = exit_point
        if cell == last_cell and len(goals):
            # Reaching the last goal ends the episode: hold back this robot's final goal until
            # the rest of its share is swept.
            sweep = _sweep_path(layout, share, position, goals, lane, corridor)
            final_goal = goals[np.argmax(_first_touches(sweep, goals, layout.robot.radius))]
            keep_off = _near_points(layout, final_goal[None], layout.robot.radius + 0.02)
            sweep = _sweep_path(
                layout, share & ~keep_off, position, goals, lane & ~keep_off, corridor & ~keep_off
            )
            add(sweep, cell, "sweep")
            ways = share | (keep_off & drivable) | corridor
            row, col = _nearest_pixel(ways, layout, final_goal)  # goals may sit where the disc cannot
            xs, ys = layout.pixel_centres()
            position = np.array([xs[col], ys[row]])
            add(_transit(layout, ways & (lane | share | keep_off), sweep[-1], position, ways), cell, "goals")
            # Until the team's last goal ends the episode, sweep what the hold-back left.
            spot = keep_off & drivable & (share | corridor)
            if spot[layout.to_pixel(*position)]:
                add(_plan(layout, spot, position, None, quickest=True).waypoints, cell, "sweep")
        else:
            sweep = _sweep_path(layout, share, position, goals, lane, corridor)
            if len(goals):
                # Sweep up to the first touch of the last goal and wait there for the cell to
                # clear; then back out to the staging point, clear of the aisle, and finish the
                # sweep on the way out when this robot's turn in the convoy comes.
                before, after = _split_at_last_goal(sweep, goals, layout.robot.radius - GOAL_TOUCH_MARGIN)
                # the way out: the rest of the sweep, then back to the aisle
                onto_way = (
                    _near_polyline(layout, stage.ways[0], RESOLUTION) & corridor & _cell_region(layout, cell)
                )
                row, col = _nearest_pixel(onto_way, layout, after[-1])
                xs, ys = layout.pixel_centres()
                back = _transit(layout, lane, after[-1], np.array([xs[col], ys[row]]), corridor)
                after = np.vstack([after, back[1:]])
                out, rest = _split_at_staging(after, stage.ways, layout.robot.radius)
                add(before, cell, "sweep")
                wait = (cell, 0.0, False)
                add(out, cell, "out")
                wait = (cell, 0.0, True)
                add(rest, cell, "sweep")
                position = after[-1]
            else:
                add(sweep, cell, "sweep")
                wait = (cell, 0.0, True)
                position = sweep[-1]
        at_cell = cell
    return legs


def _split_at_staging(
    path: np.ndarray, ways: list[np.ndarray], radius: float
) -> tuple[np.ndarray, np.ndarray]:
    """``path`` cut where it first comes closer to the through way than a passing robot needs
    (2 radii + ``STAGING_GAP``); the first part is empty when it starts that close."""
    steps = [
        np.linspace(a, b, max(2, int(np.hypot(*(b - a)) / 0.02) + 1)) for a, b in zip(path[:-1], path[1:])
    ]
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
    starts, ends = polyline[:-1], polyline[1:]
    direction = ends - starts
    length_sq = np.maximum((direction**2).sum(axis=1), 1e-12)
    t = np.clip(((points[:, None, :] - starts[None]) * direction[None]).sum(axis=2) / length_sq[None], 0, 1)
    nearest = starts[None] + t[..., None] * direction[None]
    return np.sqrt(((points[:, None, :] - nearest) ** 2).sum(axis=2)).min(axis=1)


def _split_at_last_goal(
    waypoints: np.ndarray, goals: np.ndarray, reach: float
) -> tuple[np.ndarray, np.ndarray]:
    """The path cut where it first comes within ``reach`` of the goal it reaches last."""
    touch = float(np.max(_first_touches(waypoints, goals, reach)))
    lengths = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(waypoints, axis=0).T))])
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
) -> np.ndarray:
    """One polyline (metres) from ``start`` that sweeps every piece of ``share``: the pieces
    (4-connected) nearest first, joined by A* transits through ``corridor | share``."""
    labels, count = ndimage.label(share)
    sizes = ndimage.sum_labels(np.ones_like(labels), labels, index=np.arange(1, count + 1))
    remaining = [k + 1 for k in range(count) if sizes[k] >= MIN_SWEEP_COMPONENT_PX]
    xs, ys = layout.pixel_centres()
    path = [np.asarray(start, dtype=float)[None, :]]
    position = np.asarray(start, dtype=float)
    ways = corridor | share
    fallback = ways if fallback is None else (fallback | share)
    goal_pieces = set()
    for goal in [] if goals is None else goals:
        goal_pieces.add(int(labels[_nearest_pixel(share, layout, goal)]))
    while remaining:
        # the piece nearest along the free space, entered at its nearest pixel; pieces holding
        # goal markers last (the last goal marker is where the robot waits for its cell to clear)
        distance = _geodesic_map(layout, ways, position)
        if not np.isfinite(distance[share]).all():  # pieces reached only through others' shares: last
            distance = np.where(
                np.isfinite(distance), distance, _geodesic_map(layout, fallback, position) + 1e4
            )
        nearest = [
            float(distance[labels == label].min()) + (1e6 if label in goal_pieces else 0.0)
            for label in remaining
        ]
        label = remaining.pop(int(np.argmin(nearest)))
        piece = labels == label
        if not piece[layout.to_pixel(*position)]:
            flat = int(np.argmin(np.where(piece, distance, np.inf)))
            row, col = divmod(flat, piece.shape[1])
            entry = np.array([xs[col], ys[row]])
            path.append(_transit(layout, ways, position, entry, fallback)[1:])
            position = entry
        plan = _plan(layout, piece, position, goals, quickest=True)
        path.append(plan.waypoints[1:])
        position = plan.waypoints[-1]
    waypoints = np.vstack(path)
    keep = np.concatenate([[True], np.any(np.diff(waypoints, axis=0) != 0, axis=1)])
    return waypoints[keep]


class Boustrophedon(Baseline):
    name = "boustrophedon"

    def reset(self, context: EpisodeContext, observation: np.ndarray, info: dict) -> None:
        super().reset(context, observation, info)
        self.legs = plan_layout(context.layout, context.protocol, context.agent, context.n_agents)
        robot = context.layout.robot
        self.follower = PathFollower(
            self.legs[0].waypoints if self.legs else np.zeros((1, 2)),
            robot.max_speed,
            robot.max_turn_rate,
            TIME_STEP,
        )
        self.leg, self.leg_started, self.blocked_time = 0, False, 0.0
        # cells cleared before the episode count as cleared at time 0
        self.clear_times = [0.0] * context.layout.cleared_cells
        config = context.env_config
        lidar = LidarConfig(
            config.get("n_rays", 64), config.get("lidar_range", 3.5), config.get("field_of_view", 2 * math.pi)
        )
        self.ray_angles, self.lidar_range = lidar.ray_angles(), lidar.max_range

    def act(self, observation: np.ndarray, info: dict) -> np.ndarray:
        cleared = info.get("cells_cleared", 0) + self.context.layout.cleared_cells
        while len(self.clear_times) < cleared:  # when each cell cleared: the departure gates count from it
            self.clear_times.append(info.get("time", 0.0))
        while self.leg < len(self.legs):
            leg = self.legs[self.leg]
            if not self.leg_started:
                if not self._may_start(leg, info):
                    return np.zeros(2)  # waiting for the cell to clear or for its turn
                self.follower.set_path(leg.waypoints)
                if len(leg.waypoints) > 1 and np.hypot(*(leg.waypoints[0] - info["pose"][:2])) < ON_WAYPOINT:
                    self.follower.skip_to(1)  # already there: turning to face it would waste a spin
                self.leg_started = True
            if not self.follower.done:
                break
            self.leg, self.leg_started = self.leg + 1, False
        if self.leg >= len(self.legs):
            return np.zeros(2)  # plan finished: wait for the team or the step limit
        action = self.follower.act(info["pose"])
        if self.context.n_agents > 1 and action[0] > 0 and self._robot_in_front(observation):
            self.blocked_time += TIME_STEP
            if self.blocked_time <= BLOCKED_PATIENCE:
                return np.array([0.0, action[1]])
        else:
            self.blocked_time = 0.0
        return action

    def _may_start(self, leg: Leg, info: dict) -> bool:
        if leg.after_cell is None:
            since = 0.0
        elif leg.after_cell < len(self.clear_times):
            since = self.clear_times[leg.after_cell]
        else:
            return False
        return info.get("time", 0.0) >= since + leg.delay - 1e-9

    def _robot_in_front(self, observation: np.ndarray) -> bool:
        """True when the lidar sees another robot in the strip the robot is about to drive into."""
        rays = lidar_rays(observation, self.context.observation_layout)
        robot_hits = rays[:, LIDAR_CHANNELS.index("robot")] > 0.5
        if not robot_hits.any():
            return False
        distance = rays[robot_hits, LIDAR_CHANNELS.index("distance")] * self.lidar_range
        angle = self.ray_angles[robot_hits]
        ahead, aside = distance * np.cos(angle), distance * np.sin(angle)
        radius = self.context.layout.robot.radius
        return bool(np.any((ahead > 0) & (ahead < radius + FOLLOW_GAP) & (np.abs(aside) < radius * 1.05)))


def record_demonstrations(
    layout: str, episodes: int, path: str, seed: int = 0, action_noise: float = 0.0, **env_kwargs
) -> dict:
    """Run the planner for ``episodes`` episodes and save (observation, action) pairs to ``path``.
    Returns a summary (steps, mean coverage, success rate).

    With ``action_noise`` > 0 the env executes the planner's action plus Gaussian noise of that std (clipped to
    [-1, 1]), while the planner's own action is what is recorded (DART, Laskey et al. 2017). The planner follows its
    path from the pose it finds, so each episode drifts off the path differently and records how the expert gets
    back: demonstrations that cover the states around the path. Without noise, the planner in the deterministic env
    repeats one trajectory in every episode."""
    from cabinbench.envs.coverage_env import CoverageEnv

    env = CoverageEnv(layout, **env_kwargs)
    observations, actions, episode_of, records = [], [], [], []
    for episode in range(episodes):
        observation, info = env.reset(seed=seed + episode)
        noise = np.random.default_rng([seed, episode])
        planner = Boustrophedon()
        context = EpisodeContext(
            env.layout, env.world.protocol, seed + episode, observation_layout=env.observation_layout
        )
        planner.reset(context, observation, info)
        done = False
        while not done:
            action = np.clip(planner.act(observation, info), -1, 1)
            observations.append(observation)
            actions.append(action)
            episode_of.append(episode)
            executed = action + noise.normal(0.0, action_noise, 2) if action_noise > 0 else action
            observation, _, terminated, truncated, info = env.step(executed)
            done = terminated or truncated
        records.append(info["episode_record"])
    np.savez_compressed(
        path,
        observations=np.array(observations, dtype=np.float32),
        actions=np.array(actions, dtype=np.float32),
        episode=np.array(episode_of, dtype=np.int32),
        observation_config=np.array(json.dumps(env.observation_config)),
    )
    return {
        "steps": len(actions),
        "coverage": float(np.mean([r["coverage"] for r in records])),
        "success": float(np.mean([r["success"] for r in records])),
    }
