import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from companion.core.geometry import (is_visible, move, move_jacobians, observe, observe_jacobians,
                                     place, place_jacobians, wrap_angle)


def numeric_jacobian(fn, x, eps=1e-6, angle_rows=()):
    x = np.asarray(x, dtype=float)
    cols = []
    for i in range(len(x)):
        step = np.zeros_like(x)
        step[i] = eps
        diff = fn(x + step) - fn(x - step)
        for r in angle_rows:
            diff[r] = wrap_angle(diff[r])
        cols.append(diff / (2 * eps))
    return np.stack(cols, axis=1)


POSES = [np.array([3.0, -2.0, 0.4]), np.array([-10.0, 5.0, 2.9]), np.array([0.0, 0.0, -3.1])]


def test_move_jacobians_match_central_differences():
    for pose in POSES:
        v, g, dt = 4.0, 0.05, 0.2
        jp, ju = move_jacobians(pose, v, g, dt)
        assert np.allclose(jp, numeric_jacobian(lambda p: move(p, v, g, dt), pose, angle_rows=(2,)), atol=1e-7)
        assert np.allclose(ju, numeric_jacobian(lambda u: move(pose, u[0], u[1], dt), [v, g], angle_rows=(2,)), atol=1e-7)


def test_observe_jacobians_match_central_differences():
    landmark = np.array([12.0, 7.0])
    for pose in POSES:
        jp, jm = observe_jacobians(pose, landmark)
        assert np.allclose(jp, numeric_jacobian(lambda p: observe(p, landmark), pose, angle_rows=(1,)), atol=1e-7)
        assert np.allclose(jm, numeric_jacobian(lambda m: observe(pose, m), landmark, angle_rows=(1,)), atol=1e-7)


def test_place_jacobians_match_central_differences_and_invert_observe():
    z = np.array([15.0, -0.3])
    for pose in POSES:
        jp, jz = place_jacobians(pose, z)
        assert np.allclose(jp, numeric_jacobian(lambda p: place(p, z), pose), atol=1e-7)
        assert np.allclose(jz, numeric_jacobian(lambda zz: place(pose, zz), z), atol=1e-7)
        assert np.allclose(observe(pose, place(pose, z)), z)


def test_bearing_is_clockwise_from_heading_in_ned():
    # Heading north, a landmark due east is 90 degrees to the right.
    assert np.allclose(observe(np.array([0.0, 0.0, 0.0]), np.array([0.0, 10.0])), [10.0, math.pi / 2])
    # Heading east, the same landmark is dead ahead.
    assert np.allclose(observe(np.array([0.0, 0.0, math.pi / 2]), np.array([0.0, 10.0])), [10.0, 0.0])


@settings(max_examples=300, deadline=None)
@given(st.floats(-1e4, 1e4, allow_nan=False))
def test_wrap_angle_stays_in_half_open_interval(angle):
    wrapped = wrap_angle(angle)
    assert -math.pi <= wrapped < math.pi
    assert math.isclose(math.cos(wrapped), math.cos(angle), abs_tol=1e-9)
    assert math.isclose(math.sin(wrapped), math.sin(angle), abs_tol=1e-9)


def test_visibility_respects_fov_and_range():
    fov = math.radians(90)
    assert is_visible(39.9, math.radians(44.9), fov, 40.0)
    assert not is_visible(40.1, 0.0, fov, 40.0)
    assert not is_visible(10.0, math.radians(45.1), fov, 40.0)
    assert not is_visible(10.0, math.radians(-45.1), fov, 40.0)
