"""The in-place update paths of EkfSlam (one landmark, its Schmidt variant, a position and a yaw
fix) against a straightforward dense Joseph update written out here: full H over the state,
K = P H^T S^-1 (zero outside the landmark's rows for Schmidt), (I-KH) P (I-KH)^T + K R K^T.
The filter under test exploits H's sparsity and writes P in place; both must agree."""
from __future__ import annotations

import math

import numpy as np
import pytest

from companion.core.estimation.ekf_slam import EkfSlam
from companion.core.estimation.slam_types import AssociationGates, Observation, SlamNoise
from companion.core.geometry import wrap_angle

NOISE = SlamNoise(0.3, math.radians(0.02), 0.1, 0.1, math.radians(0.5))
RANGE_BEARING_R = np.diag([NOISE.range_sigma_m ** 2, NOISE.bearing_sigma_rad ** 2])


def correlated_filter(landmarks: int = 30, seed: int = 4) -> tuple[EkfSlam, np.random.Generator]:
    """A filter whose covariance is dense: landmarks seen from several poses, each move
    correlating the pose with the map."""
    rng = np.random.default_rng(seed)
    slam = EkfSlam(np.array([1.0, -2.0, 0.4]), np.diag([0.3, 0.2, 0.02]), NOISE,
                   AssociationGates(outlier_nis=1e12, pose_correction_nis=1e12))
    for i in range(landmarks):
        slam.update(Observation(rng.uniform(5, 80), rng.uniform(-math.pi, math.pi), i))
        slam.predict(rng.uniform(0, 3), rng.normal(0, 0.05), 0.2)
    for i in rng.choice(landmarks, size=landmarks // 2, replace=False):
        slam.update(Observation(*predicted(slam, int(i), rng), int(i)))
        slam.predict(2.0, 0.02, 0.3)
    return slam, rng


def predicted(slam: EkfSlam, index: int, rng, noise=(0.3, 0.01)) -> tuple[float, float]:
    """An observation of landmark ``index`` near what the filter predicts."""
    mean = slam.mean
    d = mean[3 + 2 * index:5 + 2 * index] - mean[:2]
    return (float(np.hypot(*d) + rng.normal(0, noise[0])),
            wrap_angle(math.atan2(d[1], d[0]) - mean[2] + rng.normal(0, noise[1])))


def range_bearing_jacobian(mean: np.ndarray, index: int) -> tuple[np.ndarray, np.ndarray]:
    s0 = 3 + 2 * index
    dn, de = mean[s0] - mean[0], mean[s0 + 1] - mean[1]
    q = dn * dn + de * de
    r = math.sqrt(q)
    h = np.zeros((2, mean.size))
    h[0, [0, 1, s0, s0 + 1]] = [-dn / r, -de / r, dn / r, de / r]
    h[1, [0, 1, 2, s0, s0 + 1]] = [de / q, -dn / q, -1.0, -de / q, dn / q]
    return h, np.array([r, math.atan2(de, dn) - mean[2]])


def dense_joseph(mean, cov, h, innovation, r, gain_rows=None):
    """Returns (mean, cov, nis); ``gain_rows``: the only state rows the gain may touch."""
    s = h @ cov @ h.T + r
    gain = cov @ h.T @ np.linalg.inv(s)
    if gain_rows is not None:
        mask = np.zeros(mean.size, dtype=bool)
        mask[gain_rows] = True
        gain[~mask] = 0.0
    x = mean + gain @ innovation
    x[2] = wrap_angle(x[2])
    a = np.eye(mean.size) - gain @ h
    return x, a @ cov @ a.T + gain @ r @ gain.T, float(innovation @ np.linalg.solve(s, innovation))


def assert_same_state(slam: EkfSlam, mean, cov):
    scale = np.abs(cov).max()
    assert np.allclose(slam.mean, mean, rtol=0, atol=1e-10)
    assert np.allclose(slam.cov, cov, rtol=0, atol=1e-11 * scale)
    assert np.abs(slam.cov - slam.cov.T).max() <= 1e-12 * scale


@pytest.mark.parametrize("meas_cov", [None, ((0.04, 0.001), (0.001, 4e-4))])
def test_one_landmark_update_equals_the_dense_joseph_update(meas_cov):
    slam, rng = correlated_filter()
    for index in (0, 7, 29, 7):
        z = np.array(predicted(slam, index, rng))
        mean, cov = slam.mean.copy(), slam.cov.copy()
        h, expected_z = range_bearing_jacobian(mean, index)
        innovation = np.array([z[0] - expected_z[0], wrap_angle(z[1] - expected_z[1])])
        r = RANGE_BEARING_R if meas_cov is None else np.array(meas_cov)
        want_mean, want_cov, want_nis = dense_joseph(mean, cov, h, innovation, r)
        report = slam.update(Observation(z[0], z[1], index, meas_cov))
        assert report.action == "updated"
        assert report.nis == pytest.approx(want_nis, rel=1e-9)
        assert np.allclose(report.innovation, innovation, atol=1e-12)
        assert_same_state(slam, want_mean, want_cov)


def test_schmidt_update_equals_the_dense_joseph_update_with_the_gain_on_the_landmark_only():
    slam, rng = correlated_filter()
    index = 12
    z = np.array(predicted(slam, index, rng))
    mean, cov = slam.mean.copy(), slam.cov.copy()
    h, expected_z = range_bearing_jacobian(mean, index)
    innovation = np.array([z[0] - expected_z[0], wrap_angle(z[1] - expected_z[1])])
    want_mean, want_cov, _ = dense_joseph(mean, cov, h, innovation, RANGE_BEARING_R,
                                          gain_rows=[3 + 2 * index, 4 + 2 * index])
    slam.update(Observation(z[0], z[1], index), landmark_only=True)
    assert_same_state(slam, want_mean, want_cov)


def test_position_and_yaw_fixes_equal_the_dense_joseph_update():
    slam, _ = correlated_filter()
    mean, cov = slam.mean.copy(), slam.cov.copy()
    h = np.zeros((2, mean.size))
    h[0, 0] = h[1, 1] = 1.0
    fix = np.array([mean[0] + 0.4, mean[1] - 0.3])
    want_mean, want_cov, _ = dense_joseph(mean, cov, h, fix - mean[:2], np.eye(2) * 0.25)
    assert slam.update_position(fix[0], fix[1], 0.5, 1e9).action == "position"
    assert_same_state(slam, want_mean, want_cov)

    mean, cov = slam.mean.copy(), slam.cov.copy()
    h = np.zeros((1, mean.size))
    h[0, 2] = 1.0
    yaw = wrap_angle(mean[2] + 0.01)
    want_mean, want_cov, _ = dense_joseph(mean, cov, h, np.array([wrap_angle(yaw - mean[2])]),
                                          np.array([[1e-4]]))
    assert slam.update_yaw(yaw, 0.01, 1e9).action == "yaw"
    assert_same_state(slam, want_mean, want_cov)


@pytest.mark.parametrize("meas_cov", [None, ((0.04, 0.001), (0.001, 4e-4))])
def test_update_by_id_is_bit_identical_to_update_landmark(meas_cov):
    """update() of an id-associated observation runs its own copy of the innovation and the
    rank-2 correction (the navigator's hot path); update_landmark() goes through _innovation and
    _correct. Same arithmetic, so the same bits, across landmarks added, removed and copied in
    between (the correction's buffer follows the covariance when it is reallocated)."""
    by_id, rng = correlated_filter()
    by_index = by_id.copy()
    for step in range(60):
        index = int(rng.integers(by_id.landmark_count))
        z = predicted(by_id, index, rng)
        a = by_id.update(Observation(z[0], z[1], by_id.landmark_ids()[index], meas_cov))
        b = by_index.update_landmark(np.array(z), index, meas_cov=meas_cov)
        assert (a.action, a.landmark_index, a.innovation, a.nis) == \
            (b.action, b.landmark_index, b.innovation, b.nis)
        if step % 20 == 5:
            for slam in (by_id, by_index):
                slam.add_landmark(np.array([30.0, 0.1 * step]), obstacle_id=1000 + step)
        if step == 30:
            by_id.remove_landmark(2)
            by_index.remove_landmark(2)
        if step == 40:
            by_id, by_index = by_id.copy(), by_index.copy()
        assert np.array_equal(by_id.mean, by_index.mean)
        assert np.array_equal(by_id.cov, by_index.cov)


def test_gates_replaced_after_construction_govern_the_id_path():
    """The id path reads the gates' thresholds from attributes the ``gates`` setter keeps (not
    through the property, on the hot path): a filter whose gates are replaced must gate by the
    new ones, an outlier refused and the state left as it was."""
    slam, rng = correlated_filter()
    index = 5
    z = predicted(slam, index, rng, noise=(3.0, 0.0))              # 3 m off in range: NIS >> 1
    probe = slam.copy()
    nis = probe.update(Observation(z[0], z[1], slam.landmark_ids()[index])).nis
    assert nis > 2.0
    slam.gates = AssociationGates(accept_nis=1.0, new_landmark_nis=1.0, outlier_nis=1.0)
    mean, cov = slam.mean.copy(), slam.cov.copy()
    report = slam.update(Observation(z[0], z[1], slam.landmark_ids()[index]))
    assert report.action == "outlier" and report.nis == pytest.approx(nis)
    assert np.array_equal(slam.mean, mean) and np.array_equal(slam.cov, cov)
    slam.gates = AssociationGates(outlier_nis=1e12, pose_correction_nis=1.0)
    assert slam.update(Observation(z[0], z[1], slam.landmark_ids()[index])).action == "updated"
    assert np.array_equal(slam.mean[:3], mean[:3])                 # beyond pose_nis: landmark only
