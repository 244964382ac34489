"""Layout kind ``polygons``: an outer boundary polygon plus obstacle polygons, in metres."""

from __future__ import annotations

from cabinbench.layouts.fields import FieldChecker, KindGeometry, LayoutKind, RobotSpec
from cabinbench.layouts.sizes import check_layout_size


def build_polygons(check: FieldChecker, block, robot: RobotSpec) -> KindGeometry:
    """The outer outline and the obstacles, as written (metres)."""
    block = check.mapping(block, "polygons")
    check.known_keys(block, {"boundary", "obstacles"}, "polygons.")
    if "boundary" not in block:
        check.fail("polygons.boundary", "missing", "give the outer outline as [[x, y], ...]")
    boundary = check.polygon(block["boundary"], "polygons.boundary")
    (xmin, ymin), (xmax, ymax) = boundary.min(axis=0), boundary.max(axis=0)
    extent = f"a {xmax - xmin:,.1f} x {ymax - ymin:,.1f} m floor"
    fix = "draw the floor to be cleaned, in metres"
    check_layout_size(check, "polygons.boundary", extent, fix, xmax - xmin, ymax - ymin, len(boundary))
    obstacles_spec = block.get("obstacles", [])
    if not isinstance(obstacles_spec, list):
        check.fail(
            "polygons.obstacles", "expected a list of polygons", "write obstacles: [[[x, y], ...], ...]"
        )
    obstacles = [check.polygon(p, f"polygons.obstacles[{i}]") for i, p in enumerate(obstacles_spec)]
    walls = len(boundary) + sum(len(obstacle) for obstacle in obstacles)
    fix = "use fewer obstacle corners (a room's furniture as rectangles), or a smaller floor"
    check_layout_size(check, "polygons.obstacles", extent, fix, xmax - xmin, ymax - ymin, walls)
    return KindGeometry(boundary, obstacles)


POLYGONS = LayoutKind("polygons", build_polygons)
