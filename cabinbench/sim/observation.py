"""The layout of the flat observation vector: the one place that knows where each part lies.

A robot's observation is, in this order:

| part               | length         | content                                                 |
|--------------------|----------------|---------------------------------------------------------|
| ``lidar``          | ``6 * n_rays`` | ray-major; per ray [distance / range, one-hot obstacle, |
|                    |                | bound, goal, exit, robot] (``LIDAR_CHANNELS``)          |
| ``coverage_patch`` | ``cells ** 2`` | only with a patch: row-major, rows from behind the      |
|                    |                | robot to ahead, columns from its right to its left      |
| ``velocity``       | 2              | forward speed / max, turn rate / max, in [-1, 1]        |

``observation_layout`` maps each part's name to its ``slice``; the slices tile the vector. The
envs expose it as ``env.unwrapped.observation_layout`` and baselines get it as
``EpisodeContext.observation_layout``: read observations through it, never through offsets of
their own. :func:`write_observation` writes the lidar and velocity parts (the world writes the
coverage patch with :func:`cabinbench.sim.coverage.write_coverage_patch`).

The project's design names the lidar's parts ``lidar_distance`` and ``lidar_tags``; they are not slices here
because the observation interleaves them per ray (the shipped policies were trained on that
order): read them with :func:`lidar_channel` / :func:`lidar_rays`.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from cabinbench.sim.lidar import TAGS, cast_rays, encode_scan

LIDAR_CHANNELS = ("distance", *TAGS)  # the values of one ray, in order


def observation_layout(n_rays: int, patch_size: int = 0) -> dict[str, slice]:
    """Part name → slice of the flat observation, for ``n_rays`` rays and a coverage patch of ``patch_size``
    entries (0: none)."""
    lidar_end = n_rays * len(LIDAR_CHANNELS)
    parts = {"lidar": slice(0, lidar_end)}
    if patch_size:
        parts["coverage_patch"] = slice(lidar_end, lidar_end + patch_size)
    parts["velocity"] = slice(lidar_end + patch_size, lidar_end + patch_size + 2)
    return parts


def observation_size(layout: dict[str, slice]) -> int:
    return max(part.stop for part in layout.values())


def lidar_rays(observation: np.ndarray, layout: dict[str, slice]) -> np.ndarray:
    """The lidar part as an (n_rays, 6) array, columns as ``LIDAR_CHANNELS`` (a view of ``observation``)."""
    return np.asarray(observation)[..., layout["lidar"]].reshape(
        *np.shape(observation)[:-1], -1, len(LIDAR_CHANNELS)
    )


def lidar_channel(observation: np.ndarray, layout: dict[str, slice], channel: str) -> np.ndarray:
    """One channel of every ray, e.g. ``"distance"`` or ``"robot"``: shape (..., n_rays)."""
    return lidar_rays(observation, layout)[..., LIDAR_CHANNELS.index(channel)]


@njit(cache=True)
def write_observation(
    out,
    index,
    poses,
    velocities,
    max_speed,
    max_turn_rate,
    ray_angles,
    max_range,
    segments,
    segment_tags,
    segment_on,
    grid_meta,
    grid_starts,
    grid_items,
    circles,
    circle_tags,
    circle_on,
    noise,
    velocity_at,
):
    """The lidar and velocity parts of robot ``index``'s observation, in one compiled call: its scan
    (``segments`` bucketed by ``grid_*``, a :class:`~cabinbench.sim.lidar.SegmentGrid`; its own disc
    contains the ray origin, so the cast skips it) with range ``noise`` added (empty: none), then its
    velocities (``velocity_at``: where the velocity part starts). The last
    ``len(poses)`` discs of ``circles`` are the robots: they are placed at ``poses`` first."""
    first_robot = circles.shape[0] - poses.shape[0]
    for robot in range(poses.shape[0]):
        circles[first_robot + robot, 0], circles[first_robot + robot, 1] = poses[robot, 0], poses[robot, 1]
    n_rays = ray_angles.shape[0]
    distances, tags = np.empty(n_rays), np.empty(n_rays, dtype=np.int8)
    cast_rays(
        poses[index, 0],
        poses[index, 1],
        poses[index, 2],
        ray_angles,
        max_range,
        segments,
        segment_tags,
        segment_on,
        grid_meta,
        grid_starts,
        grid_items,
        circles,
        circle_tags,
        circle_on,
        distances,
        tags,
    )
    if noise.shape[0] > 0:
        for r in range(n_rays):
            distances[r] = min(max(distances[r] + noise[r], 0.0), max_range)
    encode_scan(distances, tags, max_range, out)
    # contacts can push a robot a little faster than commanded: keep the entries in [-1, 1]
    out[velocity_at] = min(1.0, max(-1.0, velocities[index, 0] / max_speed))
    out[velocity_at + 1] = min(1.0, max(-1.0, velocities[index, 1] / max_turn_rate))
