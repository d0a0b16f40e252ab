import math

import numpy as np
import pytest

from companion.core.estimation.ekf_slam import EkfSlam
from companion.core.estimation.slam_types import AssociationGates, Observation, SlamNoise
from companion.core.geometry import observe
from tests.core.dense_reference import DenseEkfSlam

NOISE = SlamNoise(0.3, math.radians(0.02), 0.1, 0.1, math.radians(0.5))


def make(pose=(0.0, 0.0, 0.0), sigma=0.01, noise=NOISE, gates=AssociationGates()):
    return EkfSlam(np.array(pose), np.eye(3) * sigma ** 2, noise, gates)


def test_predict_matches_hand_worked_step():
    # From pose (0,0,0) with zero covariance, v = 1 m/s, gamma = 0, dt = 1 s:
    # mean (1, 0, 0); F_u = [[1,0],[0,1],[0,1]] so P = F_u Q F_u^T.
    slam = EkfSlam(np.zeros(3), np.zeros((3, 3)), SlamNoise(0.5, 0.1, 1.0, 0.1, 0.1))
    slam.predict(1.0, 0.0, 1.0)
    assert np.allclose(slam.mean, [1.0, 0.0, 0.0])
    expected = np.array([[0.25, 0, 0], [0, 0.01, 0.01], [0, 0.01, 0.01]])
    assert np.allclose(slam.cov, expected, atol=1e-15)


def test_update_matches_hand_worked_step():
    # Vehicle at the origin, perfectly known; landmark 10 m north with covariance I.
    # Range observation 10.5 m, bearing 0: H_m = [[1, 0], [0, 0.1]], S = diag(1 + 0.01, 0.01 + rb),
    # so the north coordinate moves by 0.5 / 1.01 and its variance becomes 1 - 1/1.01.
    slam = EkfSlam(np.zeros(3), np.zeros((3, 3)), SlamNoise(0.1, 0.1, 1.0, 0.1, 0.1))
    slam._add(np.array([10.0, 0.0]), obstacle_id=7)
    slam._cov_buf[3:5, 3:5] = np.eye(2)
    report = slam.update(Observation(10.5, 0.0, 7))
    assert report.action == "updated"
    assert slam.landmarks()[0, 0] == pytest.approx(10.0 + 0.5 / 1.01, abs=1e-12)
    assert slam.cov[3, 3] == pytest.approx(1.0 - 1.0 / 1.01, abs=1e-12)
    assert report.nis == pytest.approx(0.25 / 1.01, abs=1e-12)


def test_matches_dense_textbook_filter_to_1e9():
    rng = np.random.default_rng(3)
    pose0, cov0 = np.array([1.0, 2.0, 0.3]), np.diag([0.2, 0.3, 0.01])
    fast = EkfSlam(pose0, cov0, NOISE, AssociationGates(outlier_nis=1e12, pose_correction_nis=1e12))
    dense = DenseEkfSlam(pose0, cov0, NOISE.speed_sigma_mps, NOISE.heading_change_sigma_rad,
                         NOISE.reference_dt_s, NOISE.range_sigma_m, NOISE.bearing_sigma_rad)
    landmarks = rng.uniform(-30, 30, size=(12, 2))
    for step in range(60):
        v, g, dt = rng.uniform(0, 5), rng.normal(0, 0.05), rng.uniform(0.05, 0.2)
        fast.predict(v, g, dt)
        dense.predict(v, g, dt)
        for j in rng.choice(12, size=3, replace=False):
            z = observe(dense.x[:3], landmarks[j]) + rng.normal(0, [0.1, 0.01])
            report = fast.update(Observation(z[0], z[1], int(j)))
            if report.action == "added":
                dense.add(z)
            else:
                assert report.action == "updated"
                dense.update(z, report.landmark_index)
        assert fast.mean.shape == dense.x.shape
        assert np.max(np.abs(fast.mean - dense.x)) < 1e-9
        assert np.max(np.abs(fast.cov - dense.P)) < 1e-9


def test_predict_touches_only_vehicle_rows_and_columns():
    slam = make()
    for i, (r, b) in enumerate([(10, 0.1), (20, -0.2), (15, 0.3)]):
        slam.update(Observation(r, b, i))
    before = slam.cov.copy()
    slam.predict(5.0, 0.01, 0.1)
    assert np.array_equal(slam.cov[3:, 3:], before[3:, 3:])
    assert not np.array_equal(slam.cov[:3, 3:], before[:3, 3:])


def test_covariance_stays_symmetric_psd_through_a_simulated_run():
    from companion.config.scenario import load_scenario
    from companion.sim.simulation import make_navigator
    from companion.sim.truth import TruthWorld
    scenario = load_scenario("config/scenarios/paper.yaml")
    truth = TruthWorld(scenario, np.random.default_rng(11))
    nav = make_navigator(scenario)
    for step in range(300):
        odo = truth.step(5.0, 0.002)
        nav.predict(odo.speed_mps, odo.heading_change_rad, 0.1)
        if step % 2 == 0:
            nav.observe(truth.observe())
        cov = nav.slam.cov
        scale = np.max(np.abs(cov))
        assert np.max(np.abs(cov - cov.T)) <= 1e-12 * scale
        assert np.linalg.eigvalsh(0.5 * (cov + cov.T)).min() >= -1e-12 * scale
    assert nav.slam.landmark_count == 2


def test_landmark_initialisation_has_full_cross_covariance():
    slam = make(sigma=0.5)
    slam.update(Observation(10.0, 0.0, 1))
    cross = slam.cov[:3, 3:5]
    # The new landmark is correlated with the pose it was seen from: d m / d pose = G_v.
    expected = np.array([[0.25, 0.0, 0.0], [0.0, 0.25, 10.0 * 0.25]])
    assert np.allclose(cross.T, expected)


def test_association_without_ids_accepts_creates_and_drops():
    slam = make(noise=SlamNoise(0.3, 0.001, 0.1, 0.1, math.radians(0.5)))
    slam.update(Observation(20.0, 0.0))                      # landmark 0 at (20, 0)
    slam.update(Observation(20.0, math.radians(20.0)))       # landmark 1 about 6.9 m east of it
    assert slam.landmark_count == 2
    near = slam.update(Observation(20.05, 0.001))
    assert near.action == "updated" and near.landmark_index == 0
    far = slam.update(Observation(35.0, math.radians(-30.0)))
    assert far.action == "added" and slam.landmark_count == 3
    # Between landmark 0 and 1: too far from both to update, too close to be new.
    between = slam.update(Observation(20.0, math.radians(2.0)))
    assert between.action == "ambiguous" and slam.landmark_count == 3


def test_each_landmark_takes_at_most_one_observation_per_frame():
    slam = make()
    slam.update(Observation(20.0, 0.0))
    slam.update(Observation(20.0, math.radians(30.0)))
    reports = slam.update_frame([Observation(20.01, 0.0), Observation(20.02, 0.0)])
    assert reports[0].action == "updated" and reports[0].landmark_index == 0
    assert reports[1].landmark_index != 0


def test_outlier_with_known_id_is_rejected_and_state_untouched():
    slam = make()
    slam.update(Observation(20.0, 0.0, 5))
    mean = slam.mean.copy()
    report = slam.update(Observation(28.0, 0.4, 5))
    assert report.action == "outlier"
    assert np.array_equal(slam.mean, mean)


def test_nis_all_agrees_with_single_landmark_nis():
    rng = np.random.default_rng(5)
    slam = make(sigma=0.3)
    for i in range(6):
        slam.update(Observation(rng.uniform(5, 30), rng.uniform(-0.7, 0.7), i))
        slam.predict(3.0, 0.02, 0.1)
    z = np.array([18.0, 0.2])
    nis, _ = slam.nis_all(z)
    for i in range(6):
        assert nis[i] == pytest.approx(slam.nis_against(z, i)[0], rel=1e-9)


def test_growing_the_map_keeps_state():
    slam = make()
    for i in range(20):
        slam.update(Observation(10.0 + i, 0.01 * i, i))
    assert slam.landmark_count == 20
    assert slam.landmark_ids() == list(range(20))
    assert np.all(np.isfinite(slam.cov)) and slam.is_healthy()
