"""The centre-free raster as the planner's stages query it: segment checks, A*, geodesic distances.

Input: ``centre_free``, a boolean raster ``[row, col]`` of the pixels where the robot centre may
be. Points are pixel coordinates (row, col): a pixel centre has integer coordinates and the pixel
covers [row - 0.5, row + 0.5] x [col - 0.5, col + 0.5]. ``segment_is_free`` tells whether a
straight segment stays on free pixels (every zigzag and shortcut of a plan is checked with it);
``FreeSpace`` answers A* transits (8-connected, no corner cutting, simplified by line-of-sight
shortcuts) and geodesic distances between pixels (the route's costs).
"""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from functools import cached_property

import numpy as np
from numba import njit
from scipy import sparse

from cabinbench.errors import UsageError

SQRT2 = math.sqrt(2.0)


def segment_is_free(free: np.ndarray, start: Sequence[float], end: Sequence[float]) -> bool:
    """True if every pixel that the segment start-end (pixel coordinates) passes through or
    touches is free.

    A pixel square meets the segment's line when the line passes within half the square's
    extent across the line of its centre; inside the bounding box of the endpoints' pixels,
    that is the segment itself. A segment passing exactly through a pixel corner touches all
    the pixels at that corner (so it never cuts a corner, like A*).
    """
    start, end = np.asarray(start, dtype=float), np.asarray(end, dtype=float)
    return _segment_is_free(free, start[0], start[1], end[0], end[1])


@njit(cache=True)
def _segment_is_free(free, start_row, start_col, end_row, end_col):
    """``segment_is_free`` compiled (the planner checks tens of thousands of segments on a building)."""
    low_row, low_col = (
        int(np.floor(min(start_row, end_row) + 0.5)),
        int(np.floor(min(start_col, end_col) + 0.5)),
    )
    high_row, high_col = (
        int(np.floor(max(start_row, end_row) + 0.5)),
        int(np.floor(max(start_col, end_col) + 0.5)),
    )
    if min(low_row, low_col) < 0 or high_row >= free.shape[0] or high_col >= free.shape[1]:
        return False
    delta_row, delta_col = end_row - start_row, end_col - start_col
    reach = 0.5 * (abs(delta_row) + abs(delta_col))
    for row in range(low_row, high_row + 1):
        for col in range(low_col, high_col + 1):
            if not free[row, col]:
                offset = (row - start_row) * delta_col - (col - start_col) * delta_row
                if abs(offset) <= reach + 1e-9:
                    return False
    return True


class FreeSpace:
    """A centre-free raster prepared for repeated A* searches and geodesic distance queries.

    Both searches run compiled (numba) on the same 8-connected pixel graph (diagonal moves only
    where both side pixels are free), over a flat copy of the raster with a one-pixel obstacle
    border so that the inner loop needs no bounds checks. Their scratch arrays span the raster and
    are kept between searches, each search resetting only the pixels it touched: a building map's
    route makes thousands of short searches. ``graph`` is the same graph as a sparse matrix, for
    scipy's Dijkstra.
    """

    def __init__(self, free: np.ndarray, search_radius_px: float = math.inf):
        self.free = np.asarray(free, dtype=bool)
        self.search_radius_px = search_radius_px
        height, width = self.free.shape
        self.padded_width = width + 2
        padded = np.zeros((height + 2, width + 2), dtype=bool)
        padded[1:-1, 1:-1] = self.free
        self.free_flat = padded.ravel()
        self.node_id = np.full(self.free.shape, -1, dtype=np.int64)
        self.node_id[self.free] = np.arange(int(self.free.sum()))
        self._scratch = _Scratch(self.free_flat.size)

    @cached_property
    def graph(self) -> sparse.csr_matrix:
        """The 8-connected pixel graph (built on first use: A* alone does not need it)."""
        free, ids = self.free, self.node_id
        tails, heads, weights = [], [], []

        def add_edges(tail_ids, head_ids, mask, weight):
            tails.append(tail_ids[mask])
            heads.append(head_ids[mask])
            weights.append(np.full(int(mask.sum()), weight))

        add_edges(ids[:, :-1], ids[:, 1:], free[:, :-1] & free[:, 1:], 1.0)
        add_edges(ids[:-1, :], ids[1:, :], free[:-1, :] & free[1:, :], 1.0)
        square_free = free[:-1, :-1] & free[1:, 1:] & free[:-1, 1:] & free[1:, :-1]
        add_edges(ids[:-1, :-1], ids[1:, 1:], square_free, SQRT2)
        add_edges(ids[:-1, 1:], ids[1:, :-1], square_free, SQRT2)
        node_count = int(free.sum())
        return sparse.csr_matrix(
            (np.concatenate(weights), (np.concatenate(tails), np.concatenate(heads))),
            shape=(node_count, node_count),
        )

    def _flat(self, pixel: Sequence[int]) -> int:
        return (int(pixel[0]) + 1) * self.padded_width + int(pixel[1]) + 1

    def astar(self, start: Sequence[int], goal: Sequence[int]) -> np.ndarray | None:
        """Shortest 8-connected pixel path from start to goal (inclusive), or None."""
        start_node, goal_node = self._flat(start), self._flat(goal)
        if not (self.free_flat[start_node] and self.free_flat[goal_node]):
            return None
        scratch = self._scratch
        nodes = _astar(
            self.free_flat,
            self.padded_width,
            start_node,
            goal_node,
            scratch.cost,
            scratch.parent,
            scratch.closed,
        )
        if nodes is None:
            return None
        rows, cols = np.divmod(nodes, self.padded_width)
        return np.column_stack((rows - 1, cols - 1))

    def shortcut(self, pixel_path: np.ndarray) -> np.ndarray:
        """Simplify a pixel path to few waypoints with line-of-sight shortcuts.

        First keep only the pixels where the step direction changes, then, from each kept
        waypoint, jump to the farthest following one that is in straight line of sight.
        """
        if len(pixel_path) <= 2:
            return pixel_path
        steps = np.diff(pixel_path, axis=0)
        turns = np.any(steps[1:] != steps[:-1], axis=1)
        corners = pixel_path[np.concatenate(([True], turns, [True]))]
        kept = [0]
        while kept[-1] < len(corners) - 1:
            anchor = kept[-1]
            farthest = anchor + 1
            while farthest + 1 < len(corners) and segment_is_free(
                self.free, corners[anchor], corners[farthest + 1]
            ):
                farthest += 1
            kept.append(farthest)
        return corners[kept]

    def transit(self, start: Sequence[int], goal: Sequence[int]) -> np.ndarray:
        """Few-waypoint collision-free path between two free pixels (A* then shortcuts)."""
        pixel_path = self.astar(start, goal)
        if pixel_path is None:
            raise ValueError(f"no free path from pixel {tuple(start)} to pixel {tuple(goal)}")
        return self.shortcut(pixel_path)

    def pairwise_distances(self, pixels: np.ndarray) -> np.ndarray:
        """Geodesic distances (pixels) between free pixels, searched up to the routing radius.

        Pairs beyond the radius get (radius + straight-line distance): larger than every exact
        distance, and still ordered by how far apart the pixels are.
        """
        pixels = np.asarray(pixels, dtype=np.int64)
        flat = (pixels[:, 0] + 1) * self.padded_width + pixels[:, 1] + 1
        sources, inverse = np.unique(flat, return_inverse=True)
        _refuse_tables_too_large(len(pixels), len(sources))
        scratch = self._scratch
        distances = _bounded_distances(
            self.free_flat,
            self.padded_width,
            sources,
            self.search_radius_px,
            *(scratch.cost, scratch.closed, scratch.target),
        )
        return _spread(distances, inverse.ravel(), pixels, self.search_radius_px)


def _refuse_tables_too_large(points: int, sources: int) -> None:
    """Refuse, before allocating them, distance tables larger than this machine's memory (a whole
    campus floor planned as one cell): a clear line instead of a MemoryError."""
    needed = 8 * (points**2 + sources**2)
    available = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    if needed > available:
        raise UsageError(
            f"planning this floor in one piece routes between {points:,} points, whose distance tables "
            f"need about {needed / 2**30:.0f} GB, more than this machine's {available / 2**30:.0f} GB: "
            "split it into cells (an occupancy map: cells: auto) and plan it cell by cell (the "
            "sequential protocol), or crop the map"
        )


class _Scratch:
    """The searches' per-pixel arrays, kept clean between searches (each resets what it touched)."""

    def __init__(self, size: int):
        self.cost = np.full(size, np.inf)
        self.parent = np.zeros(size, dtype=np.int64)
        self.closed = np.zeros(size, dtype=np.bool_)
        self.target = np.full(size, -1, dtype=np.int64)


@njit(cache=True)
def _spread(distances, inverse, pixels, radius):
    """The distances between the sources as the distances between ``pixels`` (source
    ``inverse[k]`` is pixel k), (radius + straight-line distance) where the search stopped."""
    count = len(inverse)
    spread = np.empty((count, count))
    for a in range(count):
        for b in range(count):
            distance = distances[inverse[a], inverse[b]]
            if distance == np.inf:
                d_row, d_col = pixels[a, 0] - pixels[b, 0], pixels[a, 1] - pixels[b, 1]
                distance = radius + np.sqrt(d_row * d_row + d_col * d_col)
            spread[a, b] = distance
    return spread


@njit(cache=True)
def _moves(width):
    """(offset, step cost, the two side neighbours a diagonal step must not cut between) of the 8 moves."""
    offsets = np.array([1, -1, width, -width, -width - 1, -width + 1, width - 1, width + 1])
    steps = np.array([1.0, 1.0, 1.0, 1.0, SQRT2, SQRT2, SQRT2, SQRT2])
    side_a = np.array([0, 0, 0, 0, -width, -width, width, width])
    side_b = np.array([0, 0, 0, 0, -1, 1, -1, 1])
    return offsets, steps, side_a, side_b


@njit(cache=True)
def _passable(free, node, neighbour, side_a, side_b):
    """A step from node to neighbour stays on free pixels (a diagonal one, ``side_a`` nonzero, does
    not cut between its two side pixels)."""
    return free[neighbour] and (side_a == 0 or (free[node + side_a] and free[node + side_b]))


@njit(cache=True)
def _room(array, count):
    """``array``, doubled in length when its ``count`` entries fill it."""
    return np.concatenate((array, array)) if count == len(array) else array


@njit(cache=True)
def _heap_less(f, g, node, i, j):
    """Entry i before entry j: by f, then by g (the larger cost so far), then by node."""
    if f[i] != f[j]:
        return f[i] < f[j]
    if g[i] != g[j]:
        return g[i] < g[j]
    return node[i] < node[j]


@njit(cache=True)
def _heap_swap(f, g, node, i, j):
    f[i], f[j] = f[j], f[i]
    g[i], g[j] = g[j], g[i]
    node[i], node[j] = node[j], node[i]


@njit(cache=True)
def _heap_push(f, g, node, size, key_f, key_g, key_node):
    """Push an entry onto the heap of ``size`` entries (the arrays have room for it)."""
    f[size], g[size], node[size] = key_f, key_g, key_node
    child = size
    while child > 0:
        parent = (child - 1) // 2
        if not _heap_less(f, g, node, child, parent):
            break
        _heap_swap(f, g, node, child, parent)
        child = parent


@njit(cache=True)
def _heap_pop(f, g, node, size):
    """Move the least entry to index ``size - 1`` and restore the heap on the first ``size - 1``."""
    last = size - 1
    _heap_swap(f, g, node, 0, last)
    index = 0
    while True:
        least, left, right = index, 2 * index + 1, 2 * index + 2
        if left < last and _heap_less(f, g, node, left, least):
            least = left
        if right < last and _heap_less(f, g, node, right, least):
            least = right
        if least == index:
            return
        _heap_swap(f, g, node, index, least)
        index = least


@njit(cache=True)
def _astar(free, width, start_node, goal_node, best_cost, parent, closed):
    """A* on the padded flat raster (octile heuristic; of equal f, the node with the larger cost so
    far first, i.e. nearer the goal); the path's flat nodes, or None. Leaves the scratch clean."""
    offsets, steps, side_a, side_b = _moves(width)
    goal_row, goal_col = goal_node // width, goal_node % width
    touched = np.empty(64, dtype=np.int64)
    touched_count = 1
    touched[0] = start_node
    best_cost[start_node] = 0.0
    parent[start_node] = start_node
    f, g, heap_node = np.empty(64), np.empty(64), np.empty(64, dtype=np.int64)
    _heap_push(f, g, heap_node, 0, 0.0, 0.0, start_node)
    size, found = 1, False
    while size > 0:
        _heap_pop(f, g, heap_node, size)
        size -= 1
        node, cost = heap_node[size], -g[size]
        if node == goal_node:
            found = True
            break
        if closed[node]:
            continue
        closed[node] = True
        for move in range(8):
            neighbour = node + offsets[move]
            if not _passable(free, node, neighbour, side_a[move], side_b[move]):
                continue
            new_cost = cost + steps[move]
            if new_cost < best_cost[neighbour]:
                if best_cost[neighbour] == np.inf:
                    touched = _room(touched, touched_count)
                    touched[touched_count] = neighbour
                    touched_count += 1
                best_cost[neighbour] = new_cost
                parent[neighbour] = node
                d_row, d_col = abs(neighbour // width - goal_row), abs(neighbour % width - goal_col)
                octile = d_row + d_col + (SQRT2 - 2.0) * min(d_row, d_col)
                f, g, heap_node = _room(f, size), _room(g, size), _room(heap_node, size)
                _heap_push(f, g, heap_node, size, new_cost + octile, -new_cost, neighbour)
                size += 1
    path = None
    if found:
        length = 1
        node = goal_node
        while node != start_node:
            node = parent[node]
            length += 1
        path = np.empty(length, dtype=np.int64)
        node = goal_node
        for index in range(length - 1, -1, -1):
            path[index] = node
            node = parent[node]
    for index in range(touched_count):
        best_cost[touched[index]] = np.inf
        closed[touched[index]] = False
    return path


@njit(cache=True)
def _bounded_distances(free, width, sources, limit, cost, settled, target):
    """(len(sources), len(sources)) geodesic distances between the flat nodes ``sources`` (sorted,
    distinct), each Dijkstra search stopped at ``limit`` (inf beyond, as scipy's ``limit``). Leaves
    the scratch clean.

    The searches need no heap: their queue is three buckets of unit width, a node in bucket k
    costing [k, k + 1). A step costs 1 or sqrt(2), so it leads from bucket k to bucket k + 1 or
    k + 2, never within k: every node taken from the lowest bucket, in any order, has its final
    cost, the same float a heap would give (the least of the same sums). Stale entries (a node
    whose cost fell since) are skipped as settled.
    """
    offsets, steps, side_a, side_b = _moves(width)
    count = len(sources)
    distances = np.full((count, count), np.inf)
    for index in range(count):
        target[sources[index]] = index
    touched = np.empty(64, dtype=np.int64)
    buckets = np.empty((3, 64), dtype=np.int64)
    sizes = np.zeros(3, dtype=np.int64)
    for source in range(count):
        touched_count = 1
        touched[0] = sources[source]
        cost[sources[source]] = 0.0
        buckets[0, 0], sizes[0] = sources[source], 1
        level = 0
        while sizes.sum() > 0:
            bucket = level % 3
            for entry in range(sizes[bucket]):  # steps fill the other two buckets only
                node = buckets[bucket, entry]
                if settled[node]:
                    continue
                settled[node] = True
                if target[node] >= 0:
                    distances[source, target[node]] = cost[node]
                for move in range(8):
                    neighbour = node + offsets[move]
                    if settled[neighbour] or not _passable(free, node, neighbour, side_a[move], side_b[move]):
                        continue
                    new_cost = cost[node] + steps[move]
                    if new_cost <= limit and new_cost < cost[neighbour]:
                        if cost[neighbour] == np.inf:
                            touched = _room(touched, touched_count)
                            touched[touched_count] = neighbour
                            touched_count += 1
                        cost[neighbour] = new_cost
                        into = int(new_cost) % 3
                        if sizes[into] == buckets.shape[1]:
                            buckets = np.concatenate((buckets, np.empty_like(buckets)), axis=1)
                        buckets[into, sizes[into]] = neighbour
                        sizes[into] += 1
            sizes[bucket] = 0
            level += 1
        for index in range(touched_count):
            cost[touched[index]] = np.inf
            settled[touched[index]] = False
    for index in range(count):
        target[sources[index]] = -1
    return distances


def astar(centre_free: np.ndarray, start: Sequence[int], goal: Sequence[int]) -> np.ndarray | None:
    """Shortest 8-connected path (no corner cutting, octile heuristic) between two pixels.

    Returns the (K, 2) array of (row, col) pixels from start to goal inclusive, or None when the
    goal cannot be reached. Use ``FreeSpace(centre_free).transit`` for the simplified path.
    """
    return FreeSpace(centre_free).astar(start, goal)
