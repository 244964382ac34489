"""The one point-to-segment definition in cabinbench.geometry: its numpy form (layouts, planners)
and its compiled form (lidar, footprints) find the same nearest points."""

import numpy as np

from cabinbench.geometry import distances_to_segments, segment_offset, segment_projections


def test_distances_to_segments_measure_to_the_nearest_point():
    starts = np.array([[0.0, 0.0], [0.0, 0.0], [2.0, 2.0]])
    ends = np.array([[2.0, 0.0], [0.0, 2.0], [2.0, 2.0]])  # the last one has zero length
    points = np.array([[1.0, 1.0], [3.0, 0.0], [-1.0, -1.0]])
    expected = [
        [1.0, 1.0, np.sqrt(2.0)],  # above the middle of the first two
        [1.0, 3.0, np.sqrt(5.0)],  # past the first one's end
        [np.sqrt(2.0), np.sqrt(2.0), np.sqrt(18.0)],  # before both starts
    ]
    assert np.allclose(distances_to_segments(points, starts, ends), expected, rtol=0, atol=1e-15)
    t, offsets = segment_projections(points, starts, ends)
    assert t[0].tolist() == [0.5, 0.5, 0.0] and t[1, 0] == 1.0 and t[2, :2].tolist() == [0.0, 0.0]
    assert offsets[1, 0].tolist() == [1.0, 0.0]


def test_one_point_gives_one_row():
    walls = np.array([[0.0, 0.0, 4.0, 0.0], [4.0, 0.0, 4.0, 3.0]])
    assert distances_to_segments(np.array([1.0, 2.0]), walls[:, :2], walls[:, 2:]).tolist() == [[2.0, 3.0]]


def test_the_compiled_offset_agrees_with_the_numpy_one():
    rng = np.random.default_rng(7)
    points = rng.uniform(-5, 5, (200, 2))
    starts, ends = rng.uniform(-5, 5, (30, 2)), rng.uniform(-5, 5, (30, 2))
    ends[:5] = np.round(ends[:5] * 4) / 4  # and some on a grid, as raster paths are
    starts[:5] = np.round(starts[:5] * 4) / 4
    _, offsets = segment_projections(points, starts, ends)
    compiled = np.array(
        [[segment_offset(*point, *start, *end) for start, end in zip(starts, ends)] for point in points]
    )
    assert np.allclose(compiled, offsets, rtol=0, atol=1e-12)  # the same nearest point, to rounding
