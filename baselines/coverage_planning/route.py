"""Stage 4, route: the order of the route units and the variant of each.

Input: the units' variants, the start pixel and a transit cost function (geodesic distances from
``FreeSpace.pairwise_distances``); output: the tour, a list of (unit, variant). Greedy nearest
neighbour from the start, then 2-opt, Or-opt (which fits a side pocket in between two stretches
of the corridor it branches off) and a dynamic programme over the variants. Units in
``last_units`` come after all the others. A route of more than ``EXHAUSTIVE_ROUTE_UNITS`` units
(a large building) tries only the moves that make a link to one of a unit's
``NEIGHBOUR_UNITS`` nearest units.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from numba import njit

from cabinbench.geometry import polyline_length

# Routing costs are geodesic distances, computed by Dijkstra from every cell corner. Searching
# the whole raster from every corner would dominate the planning time (its cost grows with the
# searched area), and the route only needs exact costs between nearby cells, so each search stops
# at this radius; pairs farther apart are ranked by (radius + straight-line distance). Radii from
# 1.5 m to 8 m give plans within 1% of each other on the built-in layouts.
ROUTING_SEARCH_RADIUS_M = 3.0
# Each pass of 2-opt and Or-opt tries every pair of route positions: milliseconds for a cabin's
# tens of units or a small building's hundreds, but most of the planning time of a building with
# thousands. Longer routes try only the moves that link a unit to one of its nearest units
# (neighbour lists, as in Lin-Kernighan codes): an improving move nearly always makes such a link.
EXHAUSTIVE_ROUTE_UNITS = 500
NEIGHBOUR_UNITS = 16


def route(
    sweeps: list[list[np.ndarray]],
    start: Sequence[int],
    pairwise_distance: Callable[[np.ndarray], np.ndarray],
    last_units: set[int] | frozenset[int] = frozenset(),
) -> list[tuple[int, int]]:
    """Order the units and choose how to sweep each: a list of (unit index, variant index).

    ``sweeps[i]`` lists the variants of unit i (polylines in pixels; variant k ^ 1 must be
    variant k reversed). ``pairwise_distance(points)`` returns the transit cost matrix between
    pixel points. Units in ``last_units`` come after all the others.

    The objective is transits plus in-unit lengths. Greedy nearest neighbour builds a first
    route; then 2-opt (reversing a stretch of the route reverses each of its units, which is
    still a valid sweep, so the move is exact), Or-opt (moving short stretches) and a dynamic
    programme that picks the best variant of every unit for the fixed order alternate until none
    improves.
    """
    entries = np.array([[variant[0] for variant in unit] for unit in sweeps])  # (units, variants, 2)
    unit_count, variant_count = entries.shape[:2]
    if unit_count == 0:
        return []
    in_unit_length = np.array([[polyline_length(variant) for variant in unit] for unit in sweeps])
    # Exits are the entries of the reversed variants, so one set of points serves for both.
    points = np.vstack((np.asarray(start)[None, :], entries.reshape(-1, 2)))
    distances = pairwise_distance(points)
    costs = RouteCosts(distances, in_unit_length)
    near = _near_units(distances, variant_count, exhaustive=unit_count <= EXHAUSTIVE_ROUTE_UNITS)

    groups = [
        [index for index in range(unit_count) if index not in last_units],
        sorted(set(last_units) & set(range(unit_count))),
    ]
    tour = _greedy(groups, costs)
    group_end = len(groups[0])
    cost = costs.tour(tour)
    while True:
        tour = _two_opt(tour, group_end, costs, near)
        tour = _or_opt(tour, group_end, costs, near)
        tour = _best_variants([cell for cell, _ in tour], costs)
        new_cost = costs.tour(tour)
        if new_cost >= cost - 1e-9:
            return tour
        cost = new_cost


@dataclass
class RouteCosts:
    """The costs of a route (see ``route``). Steps are (unit, variant) tuples, or one index,
    unit * variants + variant, whose reversal is index ^ 1: the exit of a step is the entry of its
    reversal, so the distances between the start and the entries serve for every transit."""

    distances: np.ndarray  # [p, q] between points: 0 is the start, 1 + step the entry of a step
    in_unit: np.ndarray  # [unit, variant]: the sweep itself

    @property
    def variant_count(self) -> int:
        return self.in_unit.shape[1]

    def transits_from(self, step: tuple[int, int] | None) -> np.ndarray:
        """[unit, variant]: from the exit of ``step`` (None: the start) to the entry of every step."""
        source = 0 if step is None else 1 + ((step[0] * self.variant_count + step[1]) ^ 1)
        return self.distances[source, 1:].reshape(self.in_unit.shape)

    def link(self, a: tuple[int, int] | None, b: tuple[int, int] | None) -> float:
        """Transit from step a (None: the start) to step b (None: the end of the route, free)."""
        return 0.0 if b is None else self.transits_from(a)[b]

    def tour(self, tour: list[tuple[int, int]]) -> float:
        steps = [None, *tour, None]
        transits = sum(self.link(a, b) for a, b in zip(steps[:-1], steps[1:]))
        return float(sum(self.in_unit[step] for step in tour) + transits)


def _greedy(groups, costs: RouteCosts) -> list[tuple[int, int]]:
    """Nearest neighbour: repeatedly sweep the unswept cell whose entry is the closest."""
    tour: list[tuple[int, int]] = []
    for group in groups:
        remaining = list(group)
        while remaining:
            options = costs.transits_from(tour[-1] if tour else None)[remaining]
            # Equal transits (adjacent units) are decided by the cheaper way through the unit.
            options = options + 1e-6 * costs.in_unit[remaining]
            flat = int(np.argmin(options))
            row, variant = divmod(flat, options.shape[1])
            tour.append((remaining.pop(row), variant))
    return tour


def _near_units(distances: np.ndarray, variant_count: int, exhaustive: bool) -> np.ndarray:
    """``near[0]``: the ``NEIGHBOUR_UNITS`` units whose entries lie nearest the start; ``near[1 + s]``:
    those nearest the entry of step s (by distance, then unit). With ``exhaustive``, no columns:
    every move is tried."""
    points = distances.shape[0]
    unit_count = (points - 1) // variant_count
    if exhaustive or unit_count <= NEIGHBOUR_UNITS:
        return np.empty((points, 0), dtype=np.int64)
    return _nearest_units(distances, variant_count, NEIGHBOUR_UNITS)


@njit(cache=True)
def _nearest_units(distances, variant_count, count):
    """``_near_units`` compiled (a building's matrix holds tens of millions of distances)."""
    unit_count = (distances.shape[0] - 1) // variant_count
    near = np.empty((distances.shape[0], count), dtype=np.int64)
    nearest = np.empty(count)
    for point in range(distances.shape[0]):
        nearest[:] = np.inf
        for unit in range(unit_count):
            distance = distances[point, 1 + unit * variant_count : 1 + (unit + 1) * variant_count].min()
            if distance < nearest[count - 1]:  # insert it in order; the earlier unit stays on ties
                slot = count - 1
                while slot > 0 and nearest[slot - 1] > distance:
                    nearest[slot], near[point, slot] = nearest[slot - 1], near[point, slot - 1]
                    slot -= 1
                nearest[slot], near[point, slot] = distance, unit
    return near


def _two_opt(tour, group_end, costs: RouteCosts, near: np.ndarray) -> list[tuple[int, int]]:
    """2-opt on the open route with a fixed start; stretches never cross the group boundary."""
    steps = _steps(tour, costs)
    _two_opt_compiled(steps, group_end, costs.distances, near, costs.variant_count)
    return _tour(steps, costs)


def _or_opt(
    tour, group_end, costs: RouteCosts, near: np.ndarray, max_segment: int = 3
) -> list[tuple[int, int]]:
    """Or-opt: move stretches of up to ``max_segment`` units, either way round, to a better place.

    This is the move that nests routes: a side pocket left for later is fitted in between two
    pieces of the corridor it branches off. Stretches stay within their group.
    """
    steps = _steps(tour, costs)
    _or_opt_compiled(steps, group_end, costs.distances, near, costs.variant_count, max_segment)
    return _tour(steps, costs)


# The moves run compiled (numba): a building's route has thousands of units. There a step is its
# index (see ``RouteCosts``) and the route's own links are kept in a table. Step -1 stands for the
# start (before the first step) or the end of the route (after the last), where the transit is
# free. ``near`` (see ``_near_units``) has rows 1 + step and holds units; ``where[unit]`` is the
# unit's position in the route.
def _steps(tour, costs: RouteCosts) -> np.ndarray:
    return np.array([unit * costs.variant_count + variant for unit, variant in tour], dtype=np.int64)


def _tour(steps: np.ndarray, costs: RouteCosts) -> list[tuple[int, int]]:
    return [divmod(step, costs.variant_count) for step in steps.tolist()]


@njit(cache=True)
def _link(distances, a, b):
    """Transit from step a (-1: the start) to step b (-1: the end of the route, free)."""
    if b < 0:
        return 0.0
    return distances[0 if a < 0 else 1 + (a ^ 1), 1 + b]


@njit(cache=True)
def _route_links(steps, distances):
    """links[k]: the transit into step k of the route from the step before it (k = 0: from the
    start; k = len: to the end, free)."""
    count = len(steps)
    links = np.zeros(count + 1)
    for k in range(count):
        links[k] = _link(distances, steps[k - 1] if k > 0 else -1, steps[k])
    return links


@njit(cache=True)
def _positions(steps, variant_count):
    """where[unit]: the position of the unit in the route."""
    where = np.empty(len(steps), dtype=np.int64)
    for position in range(len(steps)):
        where[steps[position] // variant_count] = position
    return where


@njit(cache=True)
def _distinct_within(candidates, low, high):
    """The distinct candidates in [low, high), ascending (the order an exhaustive pass tries them in)."""
    values = np.sort(candidates)
    kept = np.empty(len(values), dtype=np.int64)
    count = 0
    for value in values:
        if low <= value < high and (count == 0 or kept[count - 1] != value):
            kept[count] = value
            count += 1
    return kept[:count]


@njit(cache=True)
def _two_opt_ends(steps, where, near, i, group_stop):
    """The ends j to try for a 2-opt reversal of i..j: those whose new link into the reversed stretch
    (from the step before i, or the start) or out of it (to the step after j) reaches a near unit,
    and the end of the route (the link out of it is free)."""
    if near.shape[1] == 0:
        return np.arange(i, group_stop)
    count = len(steps)
    first = near[0] if i == 0 else near[1 + (steps[i - 1] ^ 1)]  # from the exit of the step before i
    out = near[1 + steps[i]]  # the exit of reversed steps[i] is the entry of steps[i]
    candidates = np.empty(len(first) + len(out) + 1, dtype=np.int64)
    for k in range(len(first)):
        candidates[k] = where[first[k]]
    for k in range(len(out)):
        candidates[len(first) + k] = where[out[k]] - 1
    candidates[-1] = count - 1
    return _distinct_within(candidates, i, group_stop)


@njit(cache=True)
def _two_opt_compiled(steps, group_end, distances, near, variant_count):
    """2-opt in place: reversing stretch i..j reverses each of its steps (index ^ 1); first
    improvement, scanning i then j, until a whole pass gains nothing."""
    count = len(steps)
    links = _route_links(steps, distances)
    where = _positions(steps, variant_count)
    improved = True
    while improved:
        improved = False
        for group_start, group_stop in ((0, group_end), (group_end, count)):
            for i in range(group_start, group_stop):
                before = steps[i - 1] if i > 0 else -1
                for j in _two_opt_ends(steps, where, near, i, group_stop):
                    after = steps[j + 1] if j + 1 < count else -1
                    old = links[i] + links[j + 1]
                    new = _link(distances, before, steps[j] ^ 1) + _link(distances, steps[i] ^ 1, after)
                    if new < old - 1e-9:
                        steps[i : j + 1] = steps[i : j + 1][::-1] ^ 1
                        links = _route_links(steps, distances)
                        for position in range(i, j + 1):
                            where[steps[position] // variant_count] = position
                        improved = True


@njit(cache=True)
def _or_opt_compiled(steps, group_end, distances, near, variant_count, max_segment):
    """Or-opt in place: for each stretch length and position, the best gap (first of equal gains)
    and way round to move the stretch to, moved there when it gains; until a pass gains nothing."""
    count = len(steps)
    links = _route_links(steps, distances)
    where = _positions(steps, variant_count)
    improved = True
    while improved:
        improved = False
        for length in range(1, max_segment + 1):
            i = 0
            while i + length <= count:
                in_first_group = i < group_end
                if in_first_group and i + length > group_end:
                    i += 1
                    continue
                gap, reverse = _best_insertion(steps, links, where, near, i, length, group_end, distances)
                if gap >= 0:
                    stretch = steps[i : i + length][::-1] ^ 1 if reverse else steps[i : i + length].copy()
                    rest = np.concatenate((steps[:i], steps[i + length :]))
                    steps[:] = np.concatenate((rest[:gap], stretch, rest[gap:]))
                    links = _route_links(steps, distances)
                    where = _positions(steps, variant_count)
                    improved = True
                i += 1


@njit(cache=True)
def _insertion_gaps(where, near, i, length, head, tail, first_gap, last_gap):
    """The gaps to try for the stretch i .. i + length - 1 (entered at ``head``, left at ``tail``):
    those whose step before reaches the head, or whose step after is reached from the tail, through
    a near unit; the stretch's own place, the start and the end of the route."""
    if near.shape[1] == 0:
        return np.arange(first_gap, last_gap + 1)
    into, out = near[1 + head], near[1 + (tail ^ 1)]  # the exit of the tail is the entry of tail ^ 1
    candidates = np.empty(len(into) + len(out) + 3, dtype=np.int64)
    count = 0
    for k in range(len(into) + len(out)):
        position = where[into[k]] if k < len(into) else where[out[k - len(into)]]
        if i <= position < i + length:
            continue
        # the gap after the unit reaching the head, or before the unit the tail reaches, in the
        # route without the stretch
        candidates[count] = (position if position < i else position - length) + (k < len(into))
        count += 1
    candidates[count], candidates[count + 1], candidates[count + 2] = i, first_gap, last_gap
    return _distinct_within(candidates[: count + 3], first_gap, last_gap + 1)


@njit(cache=True)
def _best_insertion(steps, links, where, near, i, length, group_end, distances):
    """The best (gap, reversed) to move stretch i .. i + length - 1 to, or (-1, False) if no move
    gains. Gap g lies between rest[g - 1] (or the start) and rest[g] (or the end of the route),
    where rest is the route without the stretch."""
    count = len(steps)
    last = i + length - 1
    closing = _link(distances, steps[i - 1] if i > 0 else -1, steps[last + 1] if last + 1 < count else -1)
    removal = links[i] + links[last + 1] - closing
    rest_count = count - length
    first_gap, last_gap = (0, group_end - length) if i < group_end else (group_end, rest_count)
    best_gain, best_gap, best_reverse = 1e-9, -1, False
    for reverse in (False, True):
        # the stretch's first and last steps, either way round
        head = steps[last] ^ 1 if reverse else steps[i]
        tail = steps[i] ^ 1 if reverse else steps[last]
        # into the head from every point, and out of the tail to every point
        into_head, out_of_tail = distances[:, 1 + head], distances[1 + (tail ^ 1)]
        gain_here, gap_here = -np.inf, -1
        for gap in _insertion_gaps(where, near, i, length, head, tail, first_gap, last_gap):
            previous = gap - 1 if gap - 1 < i else gap - 1 + length  # rest[gap - 1] in the route
            following = gap if gap < i else gap + length  # rest[gap]
            into = into_head[0] if gap == 0 else into_head[1 + (steps[previous] ^ 1)]
            out = out_of_tail[1 + steps[following]] if gap < rest_count else 0.0
            replaced = closing if gap == i else links[following] if gap < rest_count else 0.0
            gain = removal - (into + out - replaced)
            if gain > gain_here:
                gain_here, gap_here = gain, gap
        if gain_here > best_gain:
            best_gain, best_gap, best_reverse = gain_here, gap_here, reverse
    return best_gap, best_reverse


def _best_variants(order, costs: RouteCosts) -> list[tuple[int, int]]:
    """For a fixed unit order, the cheapest variant of every unit (Viterbi over the variants)."""
    cost = costs.transits_from(None)[order[0]] + costs.in_unit[order[0]]
    choices = []
    for previous, cell in zip(order[:-1], order[1:]):
        transits = np.array([costs.transits_from((previous, variant))[cell] for variant in range(len(cost))])
        candidates = cost[:, None] + transits
        choices.append(np.argmin(candidates, axis=0))
        cost = candidates.min(axis=0) + costs.in_unit[cell]
    variants = [int(np.argmin(cost))]
    for choice in reversed(choices):
        variants.append(int(choice[variants[-1]]))
    return list(zip(order, reversed(variants)))
