"""Stage 4, route: the order of the route units and the variant of each.

Input: the units' variants, the start pixel and a transit cost function (geodesic distances from
``FreeSpace.pairwise_distances``); output: the tour, a list of (unit, variant). Greedy nearest
neighbour from the start, then 2-opt, Or-opt (which fits a side pocket in between two stretches
of the corridor it branches off) and a dynamic programme over the variants. Units in
``last_units`` come after all the others.
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
    start_to = distances[0, 1:].reshape(unit_count, variant_count)
    costs = RouteCosts(start_to, *_transit_tables(distances, variant_count), in_unit_length)

    groups = [
        [index for index in range(unit_count) if index not in last_units],
        sorted(set(last_units) & set(range(unit_count))),
    ]
    tour = _greedy(groups, costs)
    group_end = len(groups[0])
    cost = costs.tour(tour)
    while True:
        tour = _two_opt(tour, group_end, costs)
        tour = _or_opt(tour, group_end, costs)
        tour = _best_variants([cell for cell, _ in tour], costs)
        new_cost = costs.tour(tour)
        if new_cost >= cost - 1e-9:
            return tour
        cost = new_cost


@dataclass
class RouteCosts:
    """The cost tables of a route (see ``route``); steps are (unit, variant) tuples."""

    start_to: np.ndarray  # [unit, variant]: from the start to the entry
    transit: np.ndarray  # [a, v, b, w]: from the exit of unit a swept by variant v to the entry of b by w
    arrive: np.ndarray  # [b, w, a, v]: transit[a, v, b, w], by rows of the arriving step
    in_unit: np.ndarray  # [unit, variant]: the sweep itself

    def link(self, a: tuple[int, int] | None, b: tuple[int, int] | None) -> float:
        """Transit from step a (None: the start) to step b (None: the end of the route, free)."""
        if b is None:
            return 0.0
        return self.start_to[b] if a is None else self.transit[a + b]

    @property
    def variant_count(self) -> int:
        return self.start_to.shape[1]

    def rows(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The tables by step index (unit * variants + variant): from the start, and transit and
        arrive as (steps, steps) matrices (views)."""
        steps = self.start_to.size
        return self.start_to.ravel(), self.transit.reshape(steps, steps), self.arrive.reshape(steps, steps)

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
            options = costs.start_to[remaining] if not tour else costs.transit[tour[-1]][remaining]
            # Equal transits (adjacent units) are decided by the cheaper way through the unit.
            options = options + 1e-6 * costs.in_unit[remaining]
            flat = int(np.argmin(options))
            row, variant = divmod(flat, options.shape[1])
            tour.append((remaining.pop(row), variant))
    return tour


def _two_opt(tour, group_end, costs: RouteCosts) -> list[tuple[int, int]]:
    """2-opt on the open route with a fixed start; stretches never cross the group boundary."""
    steps = _steps(tour, costs)
    _two_opt_compiled(steps, group_end, *costs.rows())
    return _tour(steps, costs)


def _or_opt(tour, group_end, costs: RouteCosts, max_segment: int = 3) -> list[tuple[int, int]]:
    """Or-opt: move stretches of up to ``max_segment`` units, either way round, to a better place.

    This is the move that nests routes: a side pocket left for later is fitted in between two
    pieces of the corridor it branches off. Stretches stay within their group.
    """
    steps = _steps(tour, costs)
    _or_opt_compiled(steps, group_end, *costs.rows(), max_segment)
    return _tour(steps, costs)


# The moves run compiled (numba): a building's route has a thousand units, and each pass of 2-opt
# and Or-opt looks at every pair of them. There a step (unit, variant) is one index,
# unit * variants + variant (its reversal is index ^ 1), into the rows of the cost tables: from one
# step to every other (``transit``) and into one step from every other (``arrive``). The route's
# own links are kept in a table, so that a pass reads memory in order (a building's tables hold
# hundreds of MB). Step -1 stands for the start (before the first step) or the end of the route
# (after the last), where the transit is free.
def _steps(tour, costs: RouteCosts) -> np.ndarray:
    return np.array([unit * costs.variant_count + variant for unit, variant in tour], dtype=np.int64)


def _tour(steps: np.ndarray, costs: RouteCosts) -> list[tuple[int, int]]:
    return [divmod(step, costs.variant_count) for step in steps.tolist()]


@njit(cache=True)
def _transit_tables(distances, variant_count):
    """``transit`` and ``arrive`` (see ``RouteCosts``) from the distances between the start and the
    units' entries, copied a tile at a time (a building's tables are hundreds of MB)."""
    count = (distances.shape[0] - 1) // variant_count
    transit = np.empty((count, variant_count, count, variant_count))
    arrive = np.empty((count, variant_count, count, variant_count))
    tile = 16
    for a_tile in range(0, count, tile):
        for b_tile in range(0, count, tile):
            for a in range(a_tile, min(a_tile + tile, count)):
                for v in range(variant_count):
                    # the exit of a by v is the entry of a by v ^ 1
                    row = distances[1 + a * variant_count + (v ^ 1)]
                    for b in range(b_tile, min(b_tile + tile, count)):
                        for w in range(variant_count):
                            transit[a, v, b, w] = arrive[b, w, a, v] = row[1 + b * variant_count + w]
    return transit, arrive


@njit(cache=True)
def _link(start, transit, a, b):
    """Transit from step a (-1: the start) to step b (-1: the end of the route, free)."""
    if b < 0:
        return 0.0
    if a < 0:
        return start[b]
    return transit[a, b]


@njit(cache=True)
def _route_links(steps, start, transit):
    """links[k]: the transit into step k of the route from the step before it (k = 0: from the
    start; k = len: to the end, free)."""
    count = len(steps)
    links = np.zeros(count + 1)
    for k in range(count):
        links[k] = _link(start, transit, steps[k - 1] if k > 0 else -1, steps[k])
    return links


@njit(cache=True)
def _two_opt_compiled(steps, group_end, start, transit, arrive):
    """2-opt in place: reversing stretch i..j reverses each of its steps (index ^ 1); first
    improvement, scanning i then j, until a whole pass gains nothing."""
    count = len(steps)
    links = _route_links(steps, start, transit)
    improved = True
    while improved:
        improved = False
        for group_start, group_stop in ((0, group_end), (group_end, count)):
            for i in range(group_start, group_stop):
                before = steps[i - 1] if i > 0 else -1
                for j in range(i, group_stop):
                    after = steps[j + 1] if j + 1 < count else -1
                    old = links[i] + links[j + 1]
                    new = _link(start, transit, before, steps[j] ^ 1) + _link(
                        start, transit, steps[i] ^ 1, after
                    )
                    if new < old - 1e-9:
                        steps[i : j + 1] = steps[i : j + 1][::-1] ^ 1
                        links = _route_links(steps, start, transit)
                        improved = True


@njit(cache=True)
def _or_opt_compiled(steps, group_end, start, transit, arrive, max_segment):
    """Or-opt in place: for each stretch length and position, the best gap (first of equal gains)
    and way round to move the stretch to, moved there when it gains; until a pass gains nothing."""
    count = len(steps)
    links = _route_links(steps, start, transit)
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
                gap, reverse = _best_insertion(steps, links, i, length, group_end, start, transit, arrive)
                if gap >= 0:
                    stretch = steps[i : i + length][::-1] ^ 1 if reverse else steps[i : i + length].copy()
                    rest = np.concatenate((steps[:i], steps[i + length :]))
                    steps[:] = np.concatenate((rest[:gap], stretch, rest[gap:]))
                    links = _route_links(steps, start, transit)
                    improved = True
                i += 1


@njit(cache=True)
def _best_insertion(steps, links, i, length, group_end, start, transit, arrive):
    """The best (gap, reversed) to move stretch i .. i + length - 1 to, or (-1, False) if no move
    gains. Gap g lies between rest[g - 1] (or the start) and rest[g] (or the end of the route),
    where rest is the route without the stretch."""
    count = len(steps)
    last = i + length - 1
    closing = _link(
        start, transit, steps[i - 1] if i > 0 else -1, steps[last + 1] if last + 1 < count else -1
    )
    removal = links[i] + links[last + 1] - closing
    rest_count = count - length
    first_gap, last_gap = (0, group_end - length) if i < group_end else (group_end, rest_count)
    best_gain, best_gap, best_reverse = 1e-9, -1, False
    for reverse in (False, True):
        # the stretch's first and last steps, either way round
        head = steps[last] ^ 1 if reverse else steps[i]
        tail = steps[i] ^ 1 if reverse else steps[last]
        into_head, out_of_tail = arrive[head], transit[tail]
        gain_here, gap_here = -np.inf, -1
        for gap in range(first_gap, last_gap + 1):
            previous = gap - 1 if gap - 1 < i else gap - 1 + length  # rest[gap - 1] in the route
            following = gap if gap < i else gap + length  # rest[gap]
            into = start[head] if gap == 0 else into_head[steps[previous]]
            out = out_of_tail[steps[following]] if gap < rest_count else 0.0
            replaced = closing if gap == i else links[following] if gap < rest_count else 0.0
            gain = removal - (into + out - replaced)
            if gain > gain_here:
                gain_here, gap_here = gain, gap
        if gain_here > best_gain:
            best_gain, best_gap, best_reverse = gain_here, gap_here, reverse
    return best_gap, best_reverse


def _best_variants(order, costs: RouteCosts) -> list[tuple[int, int]]:
    """For a fixed unit order, the cheapest variant of every unit (Viterbi over the variants)."""
    cost = costs.start_to[order[0]] + costs.in_unit[order[0]]
    choices = []
    for previous, cell in zip(order[:-1], order[1:]):
        candidates = cost[:, None] + costs.transit[previous, :, cell, :]
        choices.append(np.argmin(candidates, axis=0))
        cost = candidates.min(axis=0) + costs.in_unit[cell]
    variants = [int(np.argmin(cost))]
    for choice in reversed(choices):
        variants.append(int(choice[variants[-1]]))
    return list(zip(order, reversed(variants)))
