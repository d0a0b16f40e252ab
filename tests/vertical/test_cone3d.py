"""The 3D collision cone (core/cone3d.py) against brute-force sampling of the straight flight."""
import math

import numpy as np
import pytest

from companion.core.avoidance.cone3d import (closest_approach_m, cylinder_entry_s, in_capped_cylinder,
                                   sphere_cone)


def sampled_min_distance(x, v, t_max=1e3, steps=200_001):
    t = np.linspace(0.0, t_max, steps)
    return float(np.min(np.linalg.norm(x[None, :] - t[:, None] * v[None, :], axis=1)))


def test_sphere_cone_identities_and_the_test_match_sampling():
    rng = np.random.default_rng(3)
    checked = hits = 0
    for _ in range(400):
        d = rng.uniform(1.0, 10.0)
        x = rng.normal(0.0, 30.0, 3)
        v = rng.normal(0.0, 5.0, 3)
        if rng.random() < 0.5:                  # half of them aimed near the centre
            v = 5.0 * (x + rng.normal(0.0, 8.0, 3)) / np.linalg.norm(x)
        if np.linalg.norm(x) <= d * 1.05:
            continue
        cone = sphere_cone(x, v, d)
        p1, p2 = cone.tangents_m
        for p in (p1, p2):
            u = (p - x) / d
            assert abs(np.linalg.norm(u) - 1.0) < 1e-9        # unit
            assert abs(x @ u + d) < 1e-8                        # X.u = -d: a true tangent
            assert abs(p @ u) < 1e-8                            # p perpendicular to u
        assert np.allclose(cone.a * p1 + cone.b * p2, v, atol=1e-8)
        t_max = 4.0 * np.linalg.norm(x) / np.linalg.norm(v)
        sampled = sampled_min_distance(x, v, t_max)
        if abs(sampled - d) < 1e-3 * d:
            continue                                            # tangent within sampling error
        assert cone.in_cone == (sampled < d), (x, v, d)
        assert cone.in_cone == (closest_approach_m(x, v) < d and x @ v > 0)
        checked += 1
        hits += cone.in_cone
    assert checked > 300 and 20 < hits < checked - 20


def test_aiming_point_has_a_z_component_and_lies_on_the_sphere():
    x = np.array([40.0, 0.0, 3.0])          # a point 3 m above the flight, 40 m ahead
    v = np.array([5.0, 0.0, 0.0])
    cone = sphere_cone(x, v, 10.0)
    assert cone.in_cone
    assert abs(np.linalg.norm(cone.aim_m - x) - 10.0) < 1e-9
    assert abs(cone.aim_m[2]) > 1.0 and abs(cone.aim_m[1]) < 1e-9   # in the vertical plane
    # flying straight at it (V parallel to X): a deterministic tangent, over the top
    head_on = sphere_cone(np.array([40.0, 0.0, 0.0]), v, 10.0)
    assert head_on.in_cone and head_on.aim_m[2] > 0.0


def test_sphere_degenerate_cases():
    assert sphere_cone(np.array([5.0, 0, 0]), np.array([1.0, 0, 0]), 10.0).inside
    still = sphere_cone(np.array([50.0, 0, 0]), np.zeros(3), 10.0)
    assert not still.in_cone
    receding = sphere_cone(np.array([50.0, 0, 0]), np.array([-5.0, 0.1, 0]), 10.0)
    assert not receding.in_cone


@pytest.mark.parametrize("seed", range(4))
def test_capped_cylinder_entry_matches_sampling(seed):
    rng = np.random.default_rng(seed)
    agreed = hits = 0
    for _ in range(250):
        d = rng.uniform(2.0, 10.0)
        axis = rng.uniform(-40.0, 40.0, 2)
        base = rng.choice([0.0, rng.uniform(0.0, 20.0)])
        top = rng.choice([math.inf, base + rng.uniform(1.0, 30.0)])
        alt = rng.uniform(1.0, 30.0)
        vel = np.concatenate([rng.normal(0.0, 5.0, 2), [rng.normal(0.0, 1.5)]])
        if rng.random() < 0.5:                  # half of them aimed near the axis
            vel[:2] = (axis + rng.normal(0.0, 6.0, 2)) / 5.0
        horizon = 10.0
        entry = cylinder_entry_s(axis, alt, vel, d, base, top, horizon)
        t = np.linspace(0.0, horizon, 20_001)
        points = np.column_stack([t * vel[0], t * vel[1], alt + t * vel[2]])
        inside = np.array([in_capped_cylinder(p, axis, d, base, top) for p in points[::10]])
        sampled_hit = bool(inside.any())
        if sampled_hit != (entry is not None):
            # only where the flight grazes the surface, within the sampling step
            margin = np.min(np.abs(np.hypot(points[:, 0] - axis[0], points[:, 1] - axis[1]) - d))
            vmargin = np.min(np.abs(np.concatenate([points[:, 2] - (top + d),
                                                    points[:, 2] - (base - d)])))
            assert min(margin, vmargin) < 0.05, (axis, alt, vel, d, base, top, entry)
            continue
        agreed += 1
        if entry is not None:
            hits += 1
            first = t[::10][np.argmax(inside)]
            assert abs(first - entry) <= 0.011
    assert agreed > 230 and hits > 20


def test_over_a_wall_clears_it_and_level_flight_does_not():
    # a 3 m wall 30 m ahead, d = 10: level at 10 m hits its grown top (13 m)
    axis = np.array([30.0, 0.0])
    assert cylinder_entry_s(axis, 10.0, np.array([5.0, 0, 0]), 10.0, 0.0, 3.0) is not None
    # at 14 m it passes over
    assert cylinder_entry_s(axis, 14.0, np.array([5.0, 0, 0]), 10.0, 0.0, 3.0) is None
    # climbing at 2 m/s from 10 m: at 20 m out (t = 4 s) it is at 18 m: over
    assert cylinder_entry_s(axis, 10.0, np.array([5.0, 0, 2.0]), 10.0, 0.0, 3.0) is None
    # an unbounded post is never flown over
    assert cylinder_entry_s(axis, 100.0, np.array([5.0, 0, 0]), 10.0, 0.0, math.inf) is not None
