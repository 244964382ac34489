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
    between = distances[1:, 1:].reshape(unit_count, variant_count, unit_count, variant_count)
    # transit[a, v, b, w]: from the exit of unit a swept by variant v to the entry of b by w.
    transit = between[:, np.arange(variant_count) ^ 1]
    costs = RouteCosts(start_to, transit, in_unit_length)

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
    transit: np.ndarray  # [unit, variant, unit, variant]: from an exit to an entry
    in_unit: np.ndarray  # [unit, variant]: the sweep itself

    def link(self, a: tuple[int, int] | None, b: tuple[int, int] | None) -> float:
        """Transit from step a (None: the start) to step b (None: the end of the route, free)."""
        if b is None:
            return 0.0
        return self.start_to[b] if a is None else self.transit[a + b]

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
    tour = list(tour)

    improved = True
    while improved:
        improved = False
        for group_start, group_stop in ((0, group_end), (group_end, len(tour))):
            for i in range(group_start, group_stop):
                for j in range(i, group_stop):
                    first, last = tour[i], tour[j]
                    reversed_first = (first[0], first[1] ^ 1)
                    reversed_last = (last[0], last[1] ^ 1)
                    before = tour[i - 1] if i > 0 else None
                    after = tour[j + 1] if j + 1 < len(tour) else None
                    old = costs.link(before, first) + costs.link(last, after)
                    new = costs.link(before, reversed_last) + costs.link(reversed_first, after)
                    if new < old - 1e-9:
                        tour[i : j + 1] = [(cell, variant ^ 1) for cell, variant in reversed(tour[i : j + 1])]
                        improved = True
    return tour


def _or_opt(tour, group_end, costs: RouteCosts, max_segment: int = 3) -> list[tuple[int, int]]:
    """Or-opt: move stretches of up to ``max_segment`` units, either way round, to a better place.

    This is the move that nests routes: a side pocket left for later is fitted in between two
    pieces of the corridor it branches off. Stretches stay within their group.
    """
    tour = list(tour)
    improved = True
    while improved:
        improved = False
        for length in range(1, max_segment + 1):
            i = 0
            while i + length <= len(tour):
                in_first_group = i < group_end
                if in_first_group and i + length > group_end:
                    i += 1
                    continue
                move = _best_insertion(tour, i, length, group_end, in_first_group, costs)
                if move is not None:
                    gap, stretch = move
                    rest = tour[:i] + tour[i + length :]
                    tour = rest[:gap] + stretch + rest[gap:]
                    improved = True
                i += 1
    return tour


def _best_insertion(tour, i, length, group_end, in_first_group, costs: RouteCosts):
    """The best (gap, stretch) to move tour[i : i + length] to, or None if no move gains."""
    stretch = tour[i : i + length]
    rest = tour[:i] + tour[i + length :]
    before = tour[i - 1] if i > 0 else None
    after = tour[i + length] if i + length < len(tour) else None
    removal = costs.link(before, stretch[0]) + costs.link(stretch[-1], after) - costs.link(before, after)
    rest_end = group_end - length if in_first_group else group_end
    gaps = np.arange(0, rest_end + 1) if in_first_group else np.arange(rest_end, len(rest) + 1)
    # Gap g lies between rest[g - 1] (or the start) and rest[g] (or the end of the route).
    cells = np.array([cell for cell, _ in rest] + [0], dtype=int)
    variants = np.array([variant for _, variant in rest] + [0], dtype=int)
    has_previous, has_next = gaps > 0, gaps < len(rest)
    previous, following = np.maximum(gaps - 1, 0), gaps
    p_cell, p_variant = cells[previous], variants[previous]
    f_cell, f_variant = cells[following], variants[following]

    def links_into(cell, variant):  # from the unit before each gap (or the start) to (cell, variant)
        from_start = costs.start_to[cell, variant]
        return np.where(has_previous, costs.transit[p_cell, p_variant, cell, variant], from_start)

    def links_out_of(cell, variant):  # from (cell, variant) to the unit after each gap (if any)
        return np.where(has_next, costs.transit[cell, variant, f_cell, f_variant], 0.0)

    replaced = np.where(has_next, links_into(f_cell, f_variant), 0.0)
    best_gain, best = 1e-9, None
    for candidate in (stretch, [(cell, variant ^ 1) for cell, variant in reversed(stretch)]):
        gain = removal - (links_into(*candidate[0]) + links_out_of(*candidate[-1]) - replaced)
        k = int(np.argmax(gain))
        if gain[k] > best_gain:
            best_gain, best = gain[k], (int(gaps[k]), candidate)
    return best


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
