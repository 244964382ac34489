"""Work units: a stage's region, less the through band, cut into the pieces the team shares out.

Input: the region (a mask over the robot-centre raster), its goal markers, the through band and
its way; output: unit masks ordered farthest from the entry first, and each unit's goal markers
(``work_units``). The band cuts the region into the pieces that branch off the aisle: legroom
pockets, the two halves of a galley zone, the corridors between two aisles. A piece holding
several goal markers (everything beyond a second aisle) is cut further around them (each pixel
joins the goal marker nearest along the free space); a piece without one joins the nearest unit
on its side of the aisle, and pieces beyond the last goal marker (a rear galley) all go to one
unit. Units meeting along a long boundary are merged, a unit that does not touch the band joins
the unit that leads to it, and with fewer units than robots the largest open unit is halved.
Without goal markers the region is cut into strips across x instead (``team_share``).
"""

from __future__ import annotations

import numpy as np
from cabinbench.baselines.boustrophedon.regions import arc_position, mask_points, nearest_pixel
from cabinbench.baselines.coverage_planning import FreeSpace
from scipy import ndimage
from scipy.sparse.csgraph import dijkstra

from cabinbench.geometry import segment_projections
from cabinbench.layouts.model import Layout

MERGE_BOUNDARY_PX = 3  # units meeting along this many pixels or more are merged
OPEN_UNIT_PX = 3  # a unit this many pixels from its edge at its widest is open floor (it may be halved)


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
    if len(goals):
        units, unit_goals = _units_around_goals(layout, rest, goals, way)
        units, unit_goals = _merge_open_units(np.array(units), unit_goals)
        units, unit_goals = _attach_to_way(units, unit_goals, through)
        units, unit_goals = list(units), list(unit_goals)
        keys = [tuple(g[0]) for g in unit_goals]
    else:
        parts = 3 * n_agents
        units = [unit for unit in (team_share(layout, rest, k, parts) for k in range(parts)) if unit.any()]
        unit_goals = [np.zeros((0, 2)) for _ in units]
        keys = [_centroid(layout, unit) for unit in units]
    _halve_until_one_each(layout, units, unit_goals, keys, n_agents)
    centre_x = np.mean([key[0] for key in keys]) if keys else 0.0
    direction = 1.0 if entry[0] <= centre_x else -1.0  # the far end is the one away from the entry
    order = sorted(
        range(len(units)), key=lambda k: (-direction * round(keys[k][0], 2), -round(keys[k][1], 2))
    )
    return np.array([units[k] for k in order]).reshape(len(order), *region.shape), [
        unit_goals[k] for k in order
    ]


def _units_around_goals(layout: Layout, rest: np.ndarray, goals: np.ndarray, way: np.ndarray):
    """``rest`` (the region less the band) cut into pieces, the pieces with several goal markers cut
    between them, and the pieces without one joined to a unit: (unit masks, goal markers per unit)."""
    labels, count = ndimage.label(rest)
    owner = np.array([labels[nearest_pixel(rest, layout, goal)] for goal in goals])
    units, unit_goals = [], []
    for piece_label in range(1, count + 1):
        piece = labels == piece_label
        mine = goals[owner == piece_label]
        if len(mine):
            parts = _voronoi(layout, piece, mine) if len(mine) > 1 else [(piece, mine)]
            units += [part for part, _ in parts]
            unit_goals += [part_goals for _, part_goals in parts]
    if not units:
        return [rest], [goals]
    goalless = [
        labels == piece_label for piece_label in range(1, count + 1) if not (owner == piece_label).any()
    ]
    _join_goalless_pieces(layout, units, unit_goals, goalless, way)
    return units, unit_goals


def _join_goalless_pieces(
    layout: Layout, units: list[np.ndarray], unit_goals: list[np.ndarray], pieces: list[np.ndarray], way
) -> None:
    """Join each of ``pieces`` (no goal marker) to the nearest unit on its side of ``way``, in place.
    The units that pieces beyond the last goal marker joined, at the dead end of the way, become
    one: two robots would meet head-on in the aisle on their ways there and back."""
    sides = [_side_of_way(layout, way, unit) for unit in units]
    gaps = [ndimage.distance_transform_edt(~unit) for unit in units]
    reach = max(float(arc_position(way, layout, unit).max()) for unit in units) if len(way) > 1 else np.inf
    beyond = []
    for piece in pieces:
        side = _side_of_way(layout, way, piece)
        candidates = [k for k in range(len(units)) if sides[k] == side] or list(range(len(units)))
        k = min(candidates, key=lambda j: gaps[j][piece].min())
        units[k] = units[k] | piece
        if len(way) > 1 and arc_position(way, layout, piece).min() > reach:
            beyond.append(k)
    beyond = sorted(set(beyond))
    if len(beyond) > 1:
        keep = beyond[0]
        for k in beyond[:0:-1]:
            units[keep] = units[keep] | units.pop(k)
            unit_goals[keep] = np.concatenate([unit_goals[keep], unit_goals.pop(k)])


def _halve_until_one_each(
    layout: Layout, units: list[np.ndarray], unit_goals: list[np.ndarray], keys: list, n_agents: int
) -> None:
    """While there are fewer units than robots, halve the largest open unit (in place: ``units``,
    their goal markers and their sort ``keys``); pockets only, and the extra robots wait."""
    while len(units) < n_agents:
        widths = [ndimage.distance_transform_edt(unit).max() for unit in units]
        open_units = [k for k, width in enumerate(widths) if width >= OPEN_UNIT_PX]
        if not open_units:
            return
        k = max(open_units, key=lambda j: units[j].sum())
        first, second = _halve(units[k])
        goals_k = unit_goals[k]
        in_first = np.array([first[nearest_pixel(units[k], layout, g)] for g in goals_k], dtype=bool)
        units[k : k + 1] = [first, second]
        unit_goals[k : k + 1] = [goals_k[in_first], goals_k[~in_first]]
        keys[k : k + 1] = [_centroid(layout, first), _centroid(layout, second)]


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


def _side_of_way(layout: Layout, way: np.ndarray, mask: np.ndarray) -> int:
    """Which side of ``way`` (+1 left, -1 right, 0 on it) most of ``mask`` lies on."""
    if len(way) < 2 or not mask.any():
        return 0
    points = mask_points(layout, mask)
    direction = way[1:] - way[:-1]
    _, gaps = segment_projections(points, way[:-1], way[1:])
    segment = np.argmin((gaps**2).sum(axis=2), axis=1)
    picked = gaps[np.arange(len(points)), segment]
    cross = direction[segment, 0] * picked[:, 1] - direction[segment, 1] * picked[:, 0]
    return int(np.sign(np.sum(np.sign(cross))))


def _voronoi(layout: Layout, piece: np.ndarray, goals: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
    """``piece`` cut between ``goals``: every pixel joins the goal nearest along the free space."""
    free = FreeSpace(piece)
    nodes = np.array([free.node_id[nearest_pixel(piece, layout, goal)] for goal in goals])
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


def _centroid(layout: Layout, mask: np.ndarray) -> tuple[float, float]:
    """Mean world (x, y) of the pixels of ``mask``."""
    xs, ys = layout.pixel_centres()
    rows, cols = np.nonzero(mask)
    return xs[cols].mean(), ys[rows].mean()
