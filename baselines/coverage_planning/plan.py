"""The whole plan: the five stages run for both decomposition axes, and the best plan kept.

Input: the centre-free raster in metres (resolution, origin), the tool width and the start point;
output: a ``Plan`` with its waypoints in metres. ``plan_coverage`` keeps the shortest plan that
covers at least ``MIN_PLAN_COVERAGE`` of the coverable area, trying fallback ``SweepOptions`` when
none does.
"""

from __future__ import annotations

import sys
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace

import numpy as np
from cabinbench.baselines.coverage_planning.decomposition import Cell, decompose
from cabinbench.baselines.coverage_planning.free_space import FreeSpace
from cabinbench.baselines.coverage_planning.path import (
    SHORTCUT_MARGIN_M,
    driving_time,
    drop_idle_corners,
    join,
    path_coverage,
)
from cabinbench.baselines.coverage_planning.route import ROUTING_SEARCH_RADIUS_M, route
from cabinbench.baselines.coverage_planning.swaths import max_lane_spacing_px
from cabinbench.baselines.coverage_planning.units import DEFAULT_SWEEP_OPTIONS, SweepOptions, cell_units
from scipy import ndimage
from tqdm import tqdm

from cabinbench.geometry import drop_repeated_points, pixels_to_world, polyline_length, world_to_pixel

# Plans should cover at least this fraction of the coverable area: the benchmark's success
# threshold (0.98) plus a margin for tracking errors and for what the protocol leaves out.
MIN_PLAN_COVERAGE = 0.985
# A plan that takes longer than this (a building's: a minute) shows a progress bar on a terminal,
# one step per stage of each candidate plan; a cabin's plan is done before the bar would appear.
PROGRESS_DELAY_S = 2.0
STAGES = ("decompose", "sweep", "route", "join")


@dataclass
class Plan:
    """A coverage plan: ``waypoints`` (N, 2) in metres, starting at the start point.

    ``length`` is in metres, ``duration`` the estimated driving time in seconds (see
    ``driving_time``), ``cell_order`` the indices of ``cells`` in the order they are first
    swept, ``coverage`` the fraction of the coverable area (what some reachable robot position
    covers) that the planned path covers.
    """

    waypoints: np.ndarray
    cells: list[Cell]
    sweep_axis: int
    length: float
    duration: float
    cell_order: list[int]
    coverage: float


def plan_coverage(
    centre_free: np.ndarray,
    resolution: float,
    origin: Sequence[float],
    tool_width: float = 0.35,
    start: Sequence[float] = (0.0, 0.0),
    last_cells: Callable[[Cell], bool] | None = None,
    sweep_axis: int | None = None,
    max_speed: float = 0.5,
    max_turn_rate: float = 2.0,
    min_coverage: float = MIN_PLAN_COVERAGE,
    options: SweepOptions = DEFAULT_SWEEP_OPTIONS,
) -> Plan:
    """Plan a path whose tool disc covers all the area reachable from ``start``.

    ``last_cells`` is a predicate on cells; the cells it selects are swept after all the others
    (e.g. the cells holding goal markers: ``lambda cell: cell.contains(*world_to_pixel(marker,
    resolution, origin))``).

    ``sweep_axis`` None tries both decomposition axes. Of the candidate plans the shortest one
    that covers at least ``min_coverage`` of the coverable area is kept, or the one covering the
    most if none does. The shortest sweeps are not always the most complete: the round ends of
    short lanes leave scallops along walls, and blocks of lanes leave the wall strip at each cut
    to them. So when no plan covers enough, plans without blocks, then with lanes along each
    cell's longer extent, are tried too. ``max_speed`` (m/s) and ``max_turn_rate`` (rad/s) only
    serve the ``duration`` estimate.
    The plan is restricted to the pixels 4-connected to the start (snapped to the nearest free
    pixel when it is not on one).
    """
    centre_free = np.asarray(centre_free, dtype=bool)
    if not centre_free.any():
        raise ValueError("centre_free has no free pixel")
    start_pixel = _nearest_free_pixel(centre_free, world_to_pixel(start, resolution, origin))
    labels, _ = ndimage.label(centre_free)
    reachable = labels == labels[start_pixel]
    free_space = FreeSpace(reachable, search_radius_px=ROUTING_SEARCH_RADIUS_M / resolution)
    radius_px = tool_width / 2 / resolution
    coverable = ndimage.distance_transform_edt(~reachable) <= radius_px + 1e-9
    axes = (0, 1) if sweep_axis is None else (sweep_axis,)
    # Fallbacks when no plan covers enough: no blocks, then lanes along each cell's longer extent
    # (fewer lane ends, so fewer of the scallops that round lane ends leave along walls).
    no_blocks = replace(options, lane_blocks=False)
    attempts = list(dict.fromkeys([options, no_blocks, replace(no_blocks, lane_direction="fewest_lanes")]))
    plans = []
    bar = tqdm(
        total=len(axes) * len(STAGES),
        desc="coverage plan",
        unit="stage",
        file=sys.stderr,
        leave=False,
        delay=PROGRESS_DELAY_S,
        disable=None,  # only on a terminal
    )
    with bar as progress:
        for attempt in attempts:
            progress.total = len(plans) * len(STAGES) + len(axes) * len(STAGES)  # a fallback adds its stages
            for axis in axes:
                cells, cell_order, pixel_path = _plan_for_axis(
                    free_space, axis, resolution, tool_width, start_pixel, last_cells, attempt, progress
                )
                waypoints = np.vstack(
                    (np.asarray(start, dtype=float)[None, :], pixels_to_world(pixel_path, resolution, origin))
                )
                # The start point may itself be the centre of its pixel.
                waypoints = drop_repeated_points(waypoints)
                length = polyline_length(waypoints)
                duration = driving_time(waypoints, max_speed, max_turn_rate)
                coverage = path_coverage(pixel_path, coverable, radius_px)
                plans.append(Plan(waypoints, cells, axis, length, duration, cell_order, coverage))
            if any(plan.coverage >= min_coverage for plan in plans):
                break
    enough = [plan for plan in plans if plan.coverage >= min_coverage]
    if enough:
        return min(enough, key=lambda plan: plan.length)
    return max(plans, key=lambda plan: plan.coverage)


def _plan_for_axis(
    free_space, sweep_axis, resolution, tool_width, start_pixel, last_cells, options, progress
):
    """Decompose, sweep, route and join for one axis (each of the ``STAGES`` a step of
    ``progress``): the cells, the cell order, the pixel path."""
    max_jump = max_lane_spacing_px(tool_width, resolution) // 2
    _show_stage(progress, f"axis {sweep_axis}: {STAGES[0]}")
    cells = decompose(free_space.free, sweep_axis, max_jump=max_jump)
    progress.update()
    _show_stage(progress, f"axis {sweep_axis}: {STAGES[1]} {len(cells)} cells")
    units = [
        unit
        for index, cell in enumerate(cells)
        for unit in cell_units(cell, index, free_space.free, tool_width, resolution, max_jump, options)
    ]
    progress.update()
    _show_stage(progress, f"axis {sweep_axis}: {STAGES[2]} {len(units)} units")
    variant_count = max(len(unit.variants) for unit in units)
    # Pairs (k, k ^ 1) repeat, so padding every unit to the same variant count keeps the pairing.
    variants = [[unit.variants[k % len(unit.variants)] for k in range(variant_count)] for unit in units]
    chosen_last = {
        k for k, unit in enumerate(units) if last_cells is not None and last_cells(cells[unit.cell])
    }
    tour = route(variants, start_pixel, free_space.pairwise_distances, chosen_last)
    progress.update()
    _show_stage(progress, f"axis {sweep_axis}: {STAGES[3]}")
    path = join(free_space, start_pixel, [variants[unit][variant] for unit, variant in tour])
    path = drop_idle_corners(
        path, free_space.free, tool_width / 2 / resolution, SHORTCUT_MARGIN_M / resolution
    )
    progress.update()
    cell_order = list(dict.fromkeys(units[unit].cell for unit, _ in tour))
    return cells, cell_order, path


def _show_stage(progress: tqdm, text: str) -> None:
    """Name the stage under way on the bar, shown only once the bar is (after ``PROGRESS_DELAY_S``)."""
    progress.set_postfix_str(text, refresh=False)
    progress.update(0)


def _nearest_free_pixel(centre_free: np.ndarray, pixel: tuple[int, int]) -> tuple[int, int]:
    """The pixel itself if free (clamped into the raster), else the nearest free pixel."""
    row = min(max(pixel[0], 0), centre_free.shape[0] - 1)
    col = min(max(pixel[1], 0), centre_free.shape[1] - 1)
    if centre_free[row, col]:
        return row, col
    _, (nearest_rows, nearest_cols) = ndimage.distance_transform_edt(~centre_free, return_indices=True)
    return int(nearest_rows[row, col]), int(nearest_cols[row, col])
