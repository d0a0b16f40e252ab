"""EkfSlam.update_batch: one joint update per camera frame, checked against the textbook dense
joint update written out here, against the sequential path, and for its gating and refusals."""
from __future__ import annotations

import math

import numpy as np
import pytest

from companion.core.estimation.ekf_slam import EkfSlam
from companion.core.estimation.slam_types import AssociationGates, Observation, SlamNoise
from companion.core.geometry import observe, wrap_angle

NOISE = SlamNoise(0.3, math.radians(0.02), 0.1, 0.1, math.radians(0.5))


def mapped(landmarks: int, seed: int = 0, outlier_nis: float = 1e12,
           pose_var=(0.5, 0.5, 0.01)) -> tuple[EkfSlam, np.ndarray]:
    rng = np.random.default_rng(seed)
    slam = EkfSlam(np.zeros(3), np.diag(pose_var), NOISE,
                   AssociationGates(outlier_nis=outlier_nis))
    for i in range(landmarks):
        slam.update(Observation(rng.uniform(5, 60), rng.uniform(-math.pi, math.pi), i))
    slam.predict(2.0, 0.05, 0.5)                  # correlate everything with the pose
    return slam, rng


def frame(slam: EkfSlam, rng, ids, noise=(0.3, 0.02), offset_m=0.5) -> list[Observation]:
    truth = slam.landmarks() + rng.normal(0.0, offset_m, slam.landmarks().shape)
    out = []
    for i in ids:
        z = observe(slam.pose, truth[i]) + rng.normal(0.0, noise)
        out.append(Observation(float(z[0]), float(z[1]), int(i)))
    return out


def dense_joint_update(mean, cov, observations, range_sigma, bearing_sigma):
    """x += K y, P = (I-KH) P (I-KH)^T + K R K^T, H (2K, N) dense, all at the prior mean."""
    n = mean.size
    rows, residuals = [], []
    for obs in observations:
        s0 = 3 + 2 * obs.obstacle_id
        dn, de = mean[s0] - mean[0], mean[s0 + 1] - mean[1]
        q = dn * dn + de * de
        r = math.sqrt(q)
        h = np.zeros((2, n))
        h[0, [0, 1, s0, s0 + 1]] = [-dn / r, -de / r, dn / r, de / r]
        h[1, [0, 1, 2, s0, s0 + 1]] = [de / q, -dn / q, -1.0, -de / q, dn / q]
        rows.append(h)
        residuals += [obs.range_m - r, wrap_angle(obs.bearing_rad - (math.atan2(de, dn) - mean[2]))]
    big_h, y = np.vstack(rows), np.array(residuals)
    big_r = np.kron(np.eye(len(observations)), np.diag([range_sigma ** 2, bearing_sigma ** 2]))
    s = big_h @ cov @ big_h.T + big_r
    gain = cov @ big_h.T @ np.linalg.inv(s)
    x = mean + gain @ y
    x[2] = wrap_angle(x[2])
    a = np.eye(n) - gain @ big_h
    return x, a @ cov @ a.T + gain @ big_r @ gain.T


def test_batch_equals_the_dense_joint_update():
    slam, rng = mapped(30)
    obs = frame(slam, rng, [3, 17, 8, 25, 0, 11, 29, 4, 20, 14])
    want_x, want_p = dense_joint_update(slam.mean, slam.cov, obs, NOISE.range_sigma_m,
                                        NOISE.bearing_sigma_rad)
    reports = slam.update_batch(obs)
    assert [r.action for r in reports] == ["updated"] * 10
    assert [r.obstacle_id for r in reports] == [o.obstacle_id for o in obs]
    np.testing.assert_allclose(slam.mean, want_x, atol=1e-9)
    np.testing.assert_allclose(slam.cov, want_p, atol=1e-9)
    assert np.abs(slam.cov - slam.cov.T).max() < 1e-12
    assert np.linalg.eigvalsh(slam.cov).min() > 0.0


def test_batch_is_close_to_the_sequential_path_and_leaves_it_alone():
    slam, rng = mapped(30, seed=4, pose_var=(0.01, 0.01, 1e-5))
    obs = frame(slam, rng, [1, 5, 9, 13, 21], noise=(0.05, 0.002), offset_m=0.05)
    sequential, batch = slam.copy(), slam.copy()
    sequential.update_frame(obs)
    batch.update_batch(obs)
    # Relinearisation is the only difference: second order, small next to the uncertainty.
    assert np.abs(sequential.mean - batch.mean).max() < 1e-3
    assert np.abs(sequential.cov - batch.cov).max() < 1e-3 * np.abs(sequential.cov).max()
    again = slam.copy()
    again.update_frame(obs)
    np.testing.assert_array_equal(again.mean, sequential.mean)   # the old path is untouched


def test_outliers_are_gated_one_by_one_and_the_rest_is_applied():
    slam, rng = mapped(20, seed=2, outlier_nis=30.0)
    obs = frame(slam, rng, [2, 6, 10], noise=(0.05, 0.002))
    bad = Observation(obs[1].range_m + 25.0, obs[1].bearing_rad, obs[1].obstacle_id)
    without = slam.copy()
    without.update_batch([obs[0], obs[2]])
    reports = slam.update_batch([obs[0], bad, obs[2]])
    assert [r.action for r in reports] == ["updated", "outlier", "updated"]
    assert reports[1].nis > 30.0
    np.testing.assert_allclose(slam.mean, without.mean, atol=1e-12)
    np.testing.assert_allclose(slam.cov, without.cov, atol=1e-12)


def test_unknown_ids_are_added_and_bad_frames_refused():
    slam, rng = mapped(5)
    obs = frame(slam, rng, [0, 3])
    reports = slam.update_batch([obs[0], Observation(12.0, 0.3, 77), obs[1]])
    assert [r.action for r in reports] == ["updated", "added", "updated"]
    assert slam.landmark_count == 6 and slam.landmark_ids()[5] == 77
    with pytest.raises(ValueError, match="ids"):
        slam.update_batch([Observation(10.0, 0.1, None)])
    with pytest.raises(ValueError, match="one landmark"):
        slam.update_batch([obs[0], obs[0]])


def test_the_frame_inverse_is_the_inverse_for_definite_and_indefinite_s():
    from companion.core.estimation.ekf.kernels import _spd_inverse
    rng = np.random.default_rng(3)
    a = rng.normal(size=(6, 6))
    for s in (a @ a.T + 6.0 * np.eye(6), a + a.T):       # positive definite, then indefinite
        assert np.allclose(_spd_inverse(s) @ s, np.eye(6), atol=1e-9)
