"""Layout kind ``polygons``: an outer boundary polygon plus obstacle polygons, in metres."""

from __future__ import annotations

from cabinbench.layouts.fields import FieldChecker, KindGeometry, LayoutKind, RobotSpec


def build_polygons(check: FieldChecker, block, robot: RobotSpec) -> KindGeometry:
    """The outer outline and the obstacles, as written (metres)."""
    block = check.mapping(block, "polygons")
    check.known_keys(block, {"boundary", "obstacles"}, "polygons.")
    if "boundary" not in block:
        check.fail("polygons.boundary", "missing", "give the outer outline as [[x, y], ...]")
    boundary = check.polygon(block["boundary"], "polygons.boundary")
    obstacles_spec = block.get("obstacles", [])
    if not isinstance(obstacles_spec, list):
        check.fail(
            "polygons.obstacles", "expected a list of polygons", "write obstacles: [[[x, y], ...], ...]"
        )
    obstacles = [check.polygon(p, f"polygons.obstacles[{i}]") for i, p in enumerate(obstacles_spec)]
    return KindGeometry(boundary, obstacles)


POLYGONS = LayoutKind("polygons", build_polygons)
