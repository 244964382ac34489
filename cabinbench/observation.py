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
their own.
"""

from __future__ import annotations

import numpy as np

from .lidar import TAGS

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
