"""Complete-coverage path planning on a raster, for a disc-shaped cleaning robot.

The planner is a pipeline of small, replaceable stages (in the spirit of Fields2Cover), one
module each, run top to bottom by ``plan_coverage``:

0. ``free_space``: the centre-free raster the stages query: ``segment_is_free``, A* transits and
   geodesic distances (``FreeSpace``).
1. ``decomposition``: boustrophedon cellular decomposition (Choset, 2000) into ``Cell`` objects;
   a cell also ends where an interval end jumps by more than ``max_jump`` pixels (the legroom
   between two seat rows), and ``transpose_cell`` tells whether a cell may be swept either way.
2. ``swaths``: the sweep lines of one cell: lanes at most one tool width apart, a pass along each
   edge of a narrow cell, one zigzag through a corridor two pixels wide, and the points and
   blocks where lanes may be cut.
3. ``units``: the route units of each cell and the ways to drive each (``cell_units``); a cell
   that may be swept either way offers the sweeps of both lane directions.
4. ``route``: the order of the units and the variant of each: greedy nearest neighbour, 2-opt,
   Or-opt and a dynamic programme over the variants, with geodesic transit costs; units of
   ``last_cells`` come after all the others.
5. ``path``: A* transits between the units (``join``), then every corner whose shortcut loses no
   coverage is cut out (``drop_idle_corners``).

``plan`` runs the pipeline for both decomposition axes and keeps the shortest plan that covers at
least ``MIN_PLAN_COVERAGE`` of the coverable area (``SweepOptions`` switches the choices of
stages 2-3 off, for comparisons).

Conventions: a raster is indexed ``[row, col] = [iy, ix]`` and pixel (iy, ix) has its centre at
``origin + ((ix + 0.5) * resolution, (iy + 0.5) * resolution)`` metres
(``cabinbench.geometry.pixels_to_world``). Internally all geometry is in pixel coordinates
(row, col), where a pixel centre has integer coordinates and the pixel covers
[row - 0.5, row + 0.5] x [col - 0.5, col + 0.5]. ``centre_free`` marks the pixels where the robot
centre may be (free space eroded by the robot radius). Every segment of a plan stays inside
``centre_free``: lanes lie on free intervals, connectors on staircases of free pixels, and every
zigzag and shortcut is checked against the raster (``segment_is_free``). A pixel counts as
covered when its centre lies within the tool radius of the path.
"""

from cabinbench.baselines.coverage_planning.decomposition import Cell, decompose, line_view, transpose_cell
from cabinbench.baselines.coverage_planning.free_space import FreeSpace, astar, segment_is_free
from cabinbench.baselines.coverage_planning.path import (
    driving_time,
    drop_idle_corners,
    join,
    path_coverage,
    segment_footprint,
)
from cabinbench.baselines.coverage_planning.plan import MIN_PLAN_COVERAGE, Plan, plan_coverage
from cabinbench.baselines.coverage_planning.route import route
from cabinbench.baselines.coverage_planning.swaths import attachment_points, is_narrow, lane_lines, swaths
from cabinbench.baselines.coverage_planning.units import Sweep, SweepOptions, cell_units

__all__ = [
    "MIN_PLAN_COVERAGE",
    "Cell",
    "FreeSpace",
    "Plan",
    "Sweep",
    "SweepOptions",
    "astar",
    "attachment_points",
    "cell_units",
    "decompose",
    "driving_time",
    "drop_idle_corners",
    "is_narrow",
    "join",
    "lane_lines",
    "line_view",
    "path_coverage",
    "plan_coverage",
    "route",
    "segment_footprint",
    "segment_is_free",
    "swaths",
    "transpose_cell",
]
