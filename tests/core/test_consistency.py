"""The consistency monitor, the arrival rule and the pose gate: an estimator that knows when it is
lost, and says so before it claims an arrival."""
import math

import numpy as np
import pytest
from scipy.stats import chi2

from companion.core.estimation.consistency import (ConsistencyMonitor, MonitorParams, chi2_quantile,
                                        radius_2sigma_m)
from companion.core.estimation.ekf_slam import EkfSlam
from companion.core.estimation.slam_types import AssociationGates, Observation
from companion.core.geometry import observe
from companion.core.estimator_options import EstimatorOptions
from companion.core.navigation.navigator import Navigator
from tests.core.test_ekf_slam import NOISE
from tests.core.test_navigator_timing import PARAMS

SMALL_COV = np.diag([0.01, 0.01, 1e-4])


@pytest.mark.parametrize("dof", [1, 2, 3, 10, 40, 200, 1000])
@pytest.mark.parametrize("p", [0.99, 0.9999])
def test_chi2_quantile_agrees_with_scipy(dof, p):
    exact = chi2.ppf(p, dof)
    if dof <= 2 or dof >= 20:
        assert chi2_quantile(p, dof) == pytest.approx(exact, rel=0.01)
    else:                                    # Wilson-Hilferty errs on the safe (high) side
        assert exact <= chi2_quantile(p, dof) <= 1.04 * exact


def test_radius_is_twice_the_worst_axis_sigma():
    cov = np.array([[4.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    assert radius_2sigma_m(cov) == pytest.approx(4.0)
    rot = np.array([[math.cos(0.7), -math.sin(0.7)], [math.sin(0.7), math.cos(0.7)]])
    cov[:2, :2] = rot @ np.diag([9.0, 1.0]) @ rot.T
    assert radius_2sigma_m(cov) == pytest.approx(6.0)


def test_consistent_innovations_stay_ok_inflated_ones_degrade_then_lose():
    rng = np.random.default_rng(3)
    monitor = ConsistencyMonitor(MonitorParams(window_s=5.0, lost_after_s=4.0))
    states = []
    for k in range(600):                     # 60 s of 10 Hz 2-dof NIS, consistent
        t = 0.1 * k
        monitor.add(t, float(rng.chisquare(2)), 2)
        states.append(monitor.assess(t, SMALL_COV).state)
    assert set(states) == {"ok"}
    states = []
    for k in range(600, 700):                # then 3x too large: the model is wrong
        t = 0.1 * k
        monitor.add(t, 3.0 * float(rng.chisquare(2)), 2)
        states.append(monitor.assess(t, SMALL_COV).state)
    assert "degraded" in states[:30] and states[-1] == "lost"
    assert "innovations" in monitor.last.reason


def test_covariance_growth_degrades_then_loses():
    monitor = ConsistencyMonitor(MonitorParams(degraded_radius_m=5.0, lost_radius_m=20.0))
    cov = SMALL_COV.copy()
    assert monitor.assess(0.0, cov).state == "ok"
    cov[0, 0] = 3.0 ** 2                     # 2-sigma 6 m
    assert monitor.assess(1.0, cov).state == "degraded"
    cov[0, 0] = 11.0 ** 2                    # 2-sigma 22 m
    verdict = monitor.assess(2.0, cov)
    assert verdict.state == "lost" and verdict.radius_2sigma_m == pytest.approx(22.0)


def navigator(pose_cov, **options):
    return Navigator(np.array([0.0, 0.0, 0.0]), pose_cov, NOISE, AssociationGates(), PARAMS,
                     np.array([1.0, 0.0]), "union", options=EstimatorOptions(**options))


def test_arrival_is_declared_only_with_the_pose_known_within_the_tolerance():
    sure = navigator(np.diag([0.25, 0.25, 1e-4]), arrival_tolerance_m=2.0)      # 2-sigma 1 m
    command, _ = sure.decide(0.0)
    assert command.mode == "arrived"
    unsure = navigator(np.diag([4.0, 1.0, 1e-4]), arrival_tolerance_m=2.0)      # 2-sigma 4 m
    command, _ = unsure.decide(0.0)
    assert command.mode == "arrival_uncertain" and command.speed_mps == 0.0
    assert unsure.health.radius_2sigma_m == pytest.approx(4.0)


def test_reactions_slow_down_when_degraded_and_hold_when_lost():
    far = Navigator(np.zeros(3), np.diag([4.0, 4.0, 1e-4]), NOISE, AssociationGates(), PARAMS,
                    np.array([100.0, 0.0]), "union")                  # 2-sigma 4 m: ok
    ok, _ = far.decide(0.0)
    far.slam._cov_buf[0, 0] = 9.0                                     # 6 m: degraded -> slow
    slow, _ = far.decide(0.1)
    assert far.health.state == "degraded" and slow.speed_mps == pytest.approx(0.5 * ok.speed_mps)
    far.slam._cov_buf[0, 0] = 121.0                                   # 22 m: lost -> hold
    held, _ = far.decide(0.2)
    assert held.mode == "hold: estimator lost" and held.speed_mps == 0.0
    assert [h.state for h in far.health_changes] == ["ok", "degraded", "lost"]


def test_an_update_beyond_the_acceptance_gate_never_moves_the_pose():
    slam = EkfSlam(np.zeros(3), SMALL_COV, NOISE)
    slam.update(Observation(20.0, 0.1, 4))
    slam.predict(2.0, 0.0, 0.5)
    pose = slam.pose
    lm = slam.landmarks()[0]
    # NIS between the acceptance gate (9.2) and the outlier gate (23): the landmark only.
    z = observe(pose, lm) + np.array([0.0, 0.0])
    nis0, _ = slam.nis_against(z, 0)
    s_bearing = math.sqrt(slam.nis_against(z + np.array([0.0, 1e-3]), 0)[0] - nis0)
    z_far = z + np.array([0.0, 1e-3 * math.sqrt(15.0) / s_bearing])
    nis, _ = slam.nis_against(z_far, 0)
    assert slam.gates.accept_nis < nis < slam.gates.outlier_nis
    report = slam.update(Observation(z_far[0], z_far[1], 4))
    assert report.action == "updated"
    assert np.array_equal(slam.pose, pose) and not np.array_equal(slam.landmarks()[0], lm)
    # Within the gate it corrects the pose as ever.
    slam.update(Observation(*observe(pose, slam.landmarks()[0] + [0.05, 0.0]), 4))
    assert not np.array_equal(slam.pose, pose)


def test_a_landmark_corrects_the_pose_only_once_established():
    nav = navigator(SMALL_COV, established_sightings=5)
    landmark = np.array([20.0, 3.0])
    for k in range(4):                       # four sightings over 4.5 s: probation past, but few
        nav.on_odometry(1.5 * k, 0.0, 0.0)
        nav.on_observations(1.5 * k, [Observation(*observe(np.zeros(3), landmark), 9)])
    assert 9 in nav.probation.young
    pose = nav.slam.pose
    nav.on_odometry(6.0, 0.0, 0.0)
    nav.on_observations(6.0, [Observation(*(observe(np.zeros(3), landmark) + [0.05, 0.0]), 9)])
    assert np.array_equal(nav.slam.pose, pose)          # still on probation: landmark only
    assert 9 not in nav.probation.young                          # the fifth sighting established it
