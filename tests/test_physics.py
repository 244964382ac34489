"""A world builds its walls' physics space once and reuses it across resets: an episode must not
depend on the episodes before it, in this process or another."""

import hashlib
import subprocess
import sys

import numpy as np
import pytest

from cabinbench.layouts.resolve import load_layout
from cabinbench.sim.world import World


def episode_digest(world: World, seed: int, steps: int = 150) -> str:
    """Hash of an episode's poses and contact counts: the robots drive forward at random speeds and
    turns, so they meet walls, bounds and each other."""
    world.reset(np.random.default_rng(seed))
    rng, digest = np.random.default_rng(seed), hashlib.sha256()
    for _ in range(steps):
        events = world.step(rng.uniform(-1, 1, (world.n_robots, 2)) * [0.5, 0.3] + [0.5, 0.0])
        digest.update(world.poses.tobytes())
        digest.update(
            repr([(r.collisions, r.robot_collisions, r.bound_violations) for r in events.robots]).encode()
        )
    return digest.hexdigest()


# three robots: Chipmunk orders their contacts by the numbers it gave their shapes, which a reused
# space must give again; full_cabin closes and opens bounds during an episode
@pytest.mark.parametrize("layout, n_robots", [("a320_cell", 3), ("full_cabin", 1), ("full_cabin", 3)])
def test_an_episode_after_others_is_the_episode_in_a_new_world(layout, n_robots):
    loaded = load_layout(layout)
    fresh = episode_digest(World(loaded, n_robots), seed=7)
    reused = World(loaded, n_robots)
    for other in (1, 2):
        episode_digest(reused, seed=other)
        assert episode_digest(reused, seed=7) == fresh


def test_an_episode_is_the_same_in_another_process():
    here = episode_digest(World(load_layout("a320_cell"), 3), seed=7)
    code = (
        "from cabinbench.layouts.resolve import load_layout; from cabinbench.sim.world import World; "
        "from tests.test_physics import episode_digest; "
        "print(episode_digest(World(load_layout('a320_cell'), 3), seed=7))"
    )
    there = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert there.strip() == here
