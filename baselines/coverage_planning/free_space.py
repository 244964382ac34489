"""The centre-free raster as the planner's stages query it: segment checks, A*, geodesic distances.

Input: ``centre_free``, a boolean raster ``[row, col]`` of the pixels where the robot centre may
be. Points are pixel coordinates (row, col): a pixel centre has integer coordinates and the pixel
covers [row - 0.5, row + 0.5] x [col - 0.5, col + 0.5]. ``segment_is_free`` tells whether a
straight segment stays on free pixels (every zigzag and shortcut of a plan is checked with it);
``FreeSpace`` answers A* transits (8-connected, no corner cutting, simplified by line-of-sight
shortcuts) and geodesic distances between pixels (the route's costs).
"""

from __future__ import annotations

import heapq
import math
from collections.abc import Sequence
from functools import cached_property

import numpy as np
from scipy import sparse
from scipy.sparse.csgraph import dijkstra
from scipy.spatial.distance import cdist

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
    low = np.floor(np.minimum(start, end) + 0.5).astype(int)
    high = np.floor(np.maximum(start, end) + 0.5).astype(int)
    if low.min() < 0 or high[0] >= free.shape[0] or high[1] >= free.shape[1]:
        return False
    window = free[low[0] : high[0] + 1, low[1] : high[1] + 1]
    if window.all():
        return True
    delta = end - start
    rows, cols = np.nonzero(~window)
    offset = (rows + low[0] - start[0]) * delta[1] - (cols + low[1] - start[1]) * delta[0]
    reach = 0.5 * (abs(delta[0]) + abs(delta[1]))
    return not bool(np.any(np.abs(offset) <= reach + 1e-9))


class FreeSpace:
    """A centre-free raster prepared for repeated A* searches and geodesic distance queries.

    A* runs in pure Python over a flat list with a one-pixel obstacle border, so that the inner
    loop needs no bounds checks. Geodesic distances use the same 8-connected graph (diagonal
    moves only where both side pixels are free) as a sparse matrix for scipy's Dijkstra.
    """

    def __init__(self, free: np.ndarray, search_radius_px: float = math.inf):
        self.free = np.asarray(free, dtype=bool)
        self.search_radius_px = search_radius_px
        height, width = self.free.shape
        self.padded_width = width + 2
        padded = np.zeros((height + 2, width + 2), dtype=bool)
        padded[1:-1, 1:-1] = self.free
        self.free_flat = padded.ravel().tolist()
        self.node_id = np.full(self.free.shape, -1, dtype=np.int64)
        self.node_id[self.free] = np.arange(int(self.free.sum()))

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

    def astar(self, start: Sequence[int], goal: Sequence[int]) -> np.ndarray | None:
        """Shortest 8-connected pixel path from start to goal (inclusive), or None."""
        width = self.padded_width
        free = self.free_flat
        start_node = (start[0] + 1) * width + start[1] + 1
        goal_node = (goal[0] + 1) * width + goal[1] + 1
        if not (free[start_node] and free[goal_node]):
            return None
        goal_row, goal_col = divmod(goal_node, width)
        # (offset, step cost, the two side neighbours a diagonal step must not cut between)
        moves = [(1, 1.0, 0, 0), (-1, 1.0, 0, 0), (width, 1.0, 0, 0), (-width, 1.0, 0, 0)]
        moves += [(dr * width + dc, SQRT2, dr * width, dc) for dr in (-1, 1) for dc in (-1, 1)]
        best_cost = {start_node: 0.0}
        parent = {start_node: start_node}
        heap = [(0.0, 0.0, start_node)]
        closed = set()
        while heap:
            _, negative_cost, node = heapq.heappop(heap)
            if node == goal_node:
                break
            if node in closed:
                continue
            closed.add(node)
            cost = -negative_cost
            for offset, step, side_a, side_b in moves:
                neighbour = node + offset
                if not free[neighbour] or (side_a and not (free[node + side_a] and free[node + side_b])):
                    continue
                new_cost = cost + step
                if new_cost < best_cost.get(neighbour, math.inf):
                    best_cost[neighbour] = new_cost
                    parent[neighbour] = node
                    row, col = divmod(neighbour, width)
                    d_row, d_col = abs(row - goal_row), abs(col - goal_col)
                    octile = d_row + d_col + (SQRT2 - 2.0) * min(d_row, d_col)
                    # Ties on f go to the larger cost so far, i.e. the node nearer the goal.
                    heapq.heappush(heap, (new_cost + octile, -new_cost, neighbour))
        else:
            return None
        path = [goal_node]
        while path[-1] != start_node:
            path.append(parent[path[-1]])
        rows, cols = np.divmod(np.array(path[::-1]), width)
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
        pixels = np.asarray(pixels, dtype=int)
        nodes = self.node_id[pixels[:, 0], pixels[:, 1]]
        unique_nodes, inverse = np.unique(nodes, return_inverse=True)
        radius = self.search_radius_px
        # A few sources at a time: Dijkstra returns a dense row over the whole raster per source.
        rows_per_batch = max(1, 2**22 // self.graph.shape[0])
        distances = np.vstack(
            [
                dijkstra(self.graph, directed=False, indices=batch, limit=radius)[:, unique_nodes]
                for batch in np.array_split(unique_nodes, math.ceil(len(unique_nodes) / rows_per_batch))
            ]
        )
        distances = distances[np.ix_(inverse, inverse)]
        return np.where(np.isfinite(distances), distances, radius + cdist(pixels, pixels))


def astar(centre_free: np.ndarray, start: Sequence[int], goal: Sequence[int]) -> np.ndarray | None:
    """Shortest 8-connected path (no corner cutting, octile heuristic) between two pixels.

    Returns the (K, 2) array of (row, col) pixels from start to goal inclusive, or None when the
    goal cannot be reached. Use ``FreeSpace(centre_free).transit`` for the simplified path.
    """
    return FreeSpace(centre_free).astar(start, goal)
