"""The depth camera's frames: a point right of the image centre lies to the body's right, below it
lies below, and a mount's pitch and yaw turn the view the way their signs say."""
import math

import numpy as np

from companion.core.perception.depth_frame import (CameraMount, DepthFrame, DepthIntrinsics,
                                                   rotation_zyx)

D455 = DepthIntrinsics.from_fov(848, 480, 87.0, 58.0, 0.4, 20.0)


def test_fov_round_trips_through_focal_lengths():
    assert math.isclose(math.degrees(D455.hfov_rad), 87.0, rel_tol=1e-12)
    assert math.isclose(math.degrees(D455.vfov_rad), 58.0, rel_tol=1e-12)
    assert 446.0 < D455.fx_px < 448.0          # ALGORITHM-NOTES: f_px ~447 at 848 px, 87 deg


def test_right_and_down_in_the_image_are_right_and_down_on_the_body():
    rays = D455.rays_optical()
    frd = CameraMount().frd_from_optical()
    right = frd @ rays[240, 847]
    below = frd @ rays[479, 424]
    assert right[0] == 1.0 and right[1] > 0.9 and abs(right[2]) < 0.01
    assert below[0] == 1.0 and below[2] > 0.5 and abs(below[1]) < 0.01


def test_a_camera_pitched_down_sees_its_centre_ray_below_the_horizon():
    centre = np.array([0.0, 0.0, 1.0])
    looks_down = CameraMount(pitch_rad=math.radians(-20))
    ray = looks_down.frd_from_optical() @ centre
    assert math.isclose(math.degrees(math.atan2(ray[2], ray[0])), 20.0, abs_tol=1e-9)


def test_a_camera_yawed_right_looks_right():
    ray = CameraMount(yaw_rad=math.radians(90)).frd_from_optical() @ np.array([0.0, 0.0, 1.0])
    assert np.allclose(ray, [0.0, 1.0, 0.0], atol=1e-12)


def test_rotation_is_orthonormal():
    r = rotation_zyx(0.3, -0.2, 1.1)
    assert np.allclose(r @ r.T, np.eye(3), atol=1e-12)


def test_depth_m_marks_holes_as_nan():
    pix = np.array([[0, 1000], [2500, 0]], dtype=np.uint16)
    intr = DepthIntrinsics(2, 2, 1.0, 1.0, 0.5, 0.5, 0.1, 10.0)
    z = DepthFrame(0, 0, 0, intr, pix).depth_m()
    assert np.isnan(z[0, 0]) and np.isnan(z[1, 1]) and z[0, 1] == 1.0 and z[1, 0] == 2.5
