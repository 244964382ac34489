"""The simulated lidar sees what the robot collides with: every ray's range and tag equal pymunk's
own segment queries against the world's wall and bound shapes (those in the physics space now), and
its circle queries against the shown goal and exit markers."""

import math

import numpy as np
import pymunk
import pytest

from cabinbench.envs.coverage_env import CoverageEnv
from cabinbench.sim.lidar import BOUND, EXIT, GOAL, NO_HIT, OBSTACLE, ROBOT, cast_rays
from cabinbench.sim.physics import BOUND_TYPE, WALL_TYPE

SEGMENT_TAGS = {WALL_TYPE: OBSTACLE, BOUND_TYPE: BOUND}


def pymunk_scan(
    world, circle_on: np.ndarray, x: float, y: float, heading: float
) -> tuple[np.ndarray, list[set]]:
    """Range of every ray by pymunk, and the tags of what it hits at that range (a ray into a corner
    where a bound meets a wall hits both): the nearest hit over the space's segments and the shown
    discs (a disc holding the ray origin is skipped, as the lidar skips the robot's own)."""
    max_range = world.lidar.max_range
    static = pymunk.Body(body_type=pymunk.Body.STATIC)
    targets = [
        (shape, SEGMENT_TAGS[shape.collision_type])
        for shape in world.space.shapes
        if isinstance(shape, pymunk.Segment)
    ]
    for (cx, cy, radius), tag, shown in zip(world.circles, world.circle_tags, circle_on):
        if shown and math.hypot(cx - x, cy - y) > radius:
            marker = pymunk.Circle(static, radius, (cx, cy))
            marker.cache_bb()
            targets.append((marker, tag))
    distances, tags = [], []
    for angle in heading + world.ray_angles:
        end = (x + max_range * math.cos(angle), y + max_range * math.sin(angle))
        hits = [
            (hit.alpha * max_range, tag)
            for shape, tag in targets
            if (hit := shape.segment_query((x, y), end)) is not None
        ]
        nearest = min((distance for distance, _ in hits), default=max_range)
        distances.append(nearest)
        tags.append({tag for distance, tag in hits if distance <= nearest + 1e-9} or {NO_HIT})
    return np.array(distances), tags


# at reset the tracking cell shows its exit through the open bound; full_cabin's first cell its goals
# and bound; office_floor is a building map (an occupancy layout of many wall segments, in buckets)
@pytest.mark.parametrize(
    "layout, tags_to_see",
    [("a320_tracking_cell", {EXIT}), ("full_cabin", {GOAL, BOUND}), ("office_floor", set())],
)
def test_every_ray_sees_what_pymunk_sees(layout, tags_to_see):
    env = CoverageEnv(layout)
    env.reset(seed=0)
    world = env.world
    rng = np.random.default_rng(0)
    free = np.argwhere(world.layout.centre_free)
    xs, ys = world.layout.pixel_centres()
    circle_on = world.circle_on & (world.circle_tags != ROBOT)  # rays are cast from poses the robot is not at
    tags_seen = set()
    grid = world.cell_protocol.segment_grid
    for row, col in free[rng.choice(len(free), 150, replace=False)]:
        x, y, heading = xs[col], ys[row], rng.uniform(-math.pi, math.pi)
        distances, tags = np.empty(len(world.ray_angles)), np.empty(len(world.ray_angles), dtype=np.int8)
        cast_rays(
            x,
            y,
            heading,
            world.ray_angles,
            world.lidar.max_range,
            world.segments,
            world.segment_tags,
            world.segment_on,
            grid.meta,
            grid.starts,
            grid.items,
            world.circles,
            world.circle_tags,
            circle_on,
            distances,
            tags,
        )
        expected_distances, expected_tags = pymunk_scan(world, circle_on, x, y, heading)
        np.testing.assert_allclose(distances, expected_distances, atol=1e-9)
        assert all(tag in expected for tag, expected in zip(tags.tolist(), expected_tags))
        tags_seen |= set(tags.tolist())
    assert {
        NO_HIT,
        OBSTACLE,
    } | tags_to_see <= tags_seen  # the poses covered open floor, walls and markers or bounds
