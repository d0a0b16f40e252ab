"""expected_visible tests every landmark in view against every other at once: the same answer
as testing them one at a time (as it did), on random maps, landmarks in line included."""
import math

import numpy as np

from companion.core.estimation.lifecycle import LifecycleParams, expected_visible
from companion.core.geometry import wrap_angle


def one_at_a_time(pose, points, params):
    d = points - pose[:2]
    range_m = np.hypot(d[:, 0], d[:, 1])
    bearing = np.array([wrap_angle(a) for a in np.arctan2(d[:, 1], d[:, 0]) - pose[2]])
    inside = ((range_m >= params.min_range_m)
              & (range_m <= params.max_range_m - params.range_margin_m)
              & (np.abs(bearing) <= 0.5 * params.fov_rad - params.edge_margin_rad))
    half = np.arcsin(np.minimum(1.0, params.occluder_radius_m / np.maximum(range_m, 1e-9)))
    for i in np.flatnonzero(inside):
        gap = np.abs(np.angle(np.exp(1j * (bearing[i] - bearing))))
        hidden = (range_m < range_m[i]) & (gap <= half)
        hidden[i] = False
        inside[i] = not hidden.any()
    return inside


def test_every_landmark_at_once_is_one_at_a_time():
    rng = np.random.default_rng(23)
    params = LifecycleParams(fov_rad=math.radians(90.0), max_range_m=40.0)
    hidden_seen = 0
    for case in range(400):
        n = int(rng.integers(1, 30))
        pose = np.array([*rng.uniform(-50.0, 50.0, 2), rng.uniform(-7.0, 7.0)])
        points = pose[:2] + rng.uniform(-45.0, 45.0, (n, 2))
        if case % 4 == 0:                     # a row along a ray: the far ones hidden
            direction = np.array([math.cos(pose[2]), math.sin(pose[2])])
            points[: n // 2 + 1] = pose[:2] + np.outer(rng.uniform(2.0, 38.0, n // 2 + 1),
                                                       direction)
        expected = one_at_a_time(pose, points, params)
        assert np.array_equal(expected_visible(pose, points, params), expected)
        hidden_seen += int(expected.sum() < one_at_a_time(pose, points, LifecycleParams(
            fov_rad=params.fov_rad, max_range_m=40.0, occluder_radius_m=0.0)).sum())
    assert hidden_seen > 50                   # the occlusion test was exercised
