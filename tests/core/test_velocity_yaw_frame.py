"""EkfSlam.predict_velocity with the velocity in the autopilot's yaw frame (issue 31: the stub's
unicycle odometry turns its body velocity into NED with its own drifting yaw): the mean moves by
R(offset) v dt and the covariance by F P F^T, F the numerical Jacobian of that move, landmarks'
cross terms included; without an offset F is the identity, as before."""
from __future__ import annotations

import math

import numpy as np

from companion.core.estimation.ekf_slam import EkfSlam
from companion.core.estimation.slam_types import SlamNoise, VelocityNoise

QUIET = VelocityNoise(0.0, 0.0, 0.0)


def slam_with_landmarks(rng) -> EkfSlam:
    slam = EkfSlam(np.array([3.0, -2.0, 0.4]), np.eye(3) * 0.01,
                   SlamNoise(0.3, math.radians(0.02), 0.1, 0.1, math.radians(0.5)))
    slam.add_landmark(np.array([12.0, 0.3]), 1)
    slam.add_landmark(np.array([20.0, -0.5]), 2)
    a = rng.normal(size=(slam._dim, slam._dim))
    slam._cov_buf[:slam._dim, :slam._dim] = a @ a.T * 0.1 + np.eye(slam._dim) * 0.05
    return slam


def moved(x: np.ndarray, vel_ne, yaw_rate, dt, reported_yaw) -> np.ndarray:
    out = x.copy()
    offset = x[2] - reported_yaw
    c, s = math.cos(offset), math.sin(offset)
    out[0] += (c * vel_ne[0] - s * vel_ne[1]) * dt
    out[1] += (s * vel_ne[0] + c * vel_ne[1]) * dt
    out[2] += yaw_rate * dt
    return out


def test_the_yaw_frame_predict_is_f_p_f_transpose_with_the_numerical_jacobian():
    slam = slam_with_landmarks(np.random.default_rng(3))
    x0, p0 = slam.mean.copy(), slam.cov.copy()
    vel, rate, dt, reported = (4.0, -1.5), 0.2, 0.1, 0.4 - math.radians(2.0)
    slam.predict_velocity(*vel, rate, dt, QUIET, frame_offset_rad=float(x0[2]) - reported)
    jac = np.zeros((len(x0), len(x0)))
    for k in range(len(x0)):
        step = np.zeros(len(x0))
        step[k] = 1e-6
        jac[:, k] = (moved(x0 + step, vel, rate, dt, reported)
                     - moved(x0 - step, vel, rate, dt, reported)) / 2e-6
    assert np.allclose(slam.mean, moved(x0, vel, rate, dt, reported), atol=1e-12)
    assert np.allclose(slam.cov, jac @ p0 @ jac.T, atol=1e-9)
    assert abs(jac[0, 2]) > 0.1 and abs(jac[1, 2]) > 0.3          # the coupling is there


def test_without_an_offset_the_position_does_not_see_the_yaw():
    slam = slam_with_landmarks(np.random.default_rng(4))
    x0, p0 = slam.mean.copy(), slam.cov.copy()
    slam.predict_velocity(4.0, -1.5, 0.2, 0.1, QUIET)
    assert np.allclose(slam.mean[:2], x0[:2] + np.array([0.4, -0.15]))
    assert np.allclose(slam.cov, p0)
