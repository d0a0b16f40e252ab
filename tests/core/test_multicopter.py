"""The multicopter motion model (velocity_ned): Jacobians, hand-worked steps, hover and crab."""
import dataclasses
import math

import numpy as np
import pytest
from scipy.stats import chi2

from companion.config.scenario import load_scenario
from companion.config.world import StartPose
from companion.core.estimation.ekf_slam import EkfSlam
from companion.core.estimation.slam_types import AssociationGates, Observation, VelocityNoise
from companion.core.geometry import move_velocity, move_velocity_jacobians
from companion.core.estimator_options import EstimatorOptions
from companion.core.navigation.navigator import Navigator
from companion.sim.simulation import make_navigator, pose_nees
from companion.sim.truth import TruthWorld
from tests.core.test_ekf_slam import NOISE
from tests.core.test_geometry import POSES, numeric_jacobian
from tests.core.test_navigator_timing import PARAMS

VEL_NOISE = VelocityNoise(0.1, 0.1, math.radians(0.86))


def test_move_velocity_jacobians_match_central_differences():
    control = np.array([1.5, -3.0, 0.2])
    for pose in POSES:
        jp, ju = move_velocity_jacobians(pose, *control, 0.2)
        assert np.allclose(jp, numeric_jacobian(lambda p: move_velocity(p, *control, 0.2), pose,
                                                angle_rows=(2,)), atol=1e-7)
        assert np.allclose(ju, numeric_jacobian(lambda u: move_velocity(pose, *u, 0.2), control,
                                                angle_rows=(2,)), atol=1e-7)


def test_predict_velocity_matches_hand_worked_step_and_leaves_the_map_alone():
    # From (0, 0, 0) with a landmark: v = (1, 2) m/s, r = 0.1 rad/s, dt = 0.5 s: mean
    # (0.5, 1.0, 0.05); F = I, so only the vehicle diagonal gains sigma^2 dt^2.
    slam = EkfSlam(np.zeros(3), np.eye(3) * 0.01, NOISE)
    slam.update(Observation(10.0, 0.2, 1))
    before = slam.cov.copy()
    slam.predict_velocity(1.0, 2.0, 0.1, 0.5, VelocityNoise(0.2, 0.4, 0.02))
    assert np.allclose(slam.mean[:3], [0.5, 1.0, 0.05])
    gained = slam.cov - before
    assert np.allclose(np.diag(gained)[:3], [0.04 * 0.25, 0.16 * 0.25, 0.0004 * 0.25])
    gained[np.diag_indices(3)] = 0.0
    assert not gained.any()                       # cross-covariances and map untouched


def test_yaw_and_position_updates_match_hand_worked_steps():
    slam = EkfSlam(np.array([0.0, 0.0, 0.1]), np.diag([4.0, 4.0, 0.03]), NOISE)
    report = slam.update_yaw(0.2, math.sqrt(0.01), gate_nis=20.0)
    # scalar update: K = 0.03 / 0.04; yaw 0.1 + 0.75 * 0.1, variance 0.03 * 0.01 / 0.04
    assert report.action == "yaw" and report.nis == pytest.approx(0.01 / 0.04)
    assert slam.mean[2] == pytest.approx(0.175) and slam.cov[2, 2] == pytest.approx(0.0075)
    report = slam.update_position(2.0, -1.0, 2.0, gate_nis=30.0)
    assert report.action == "position" and report.nis == pytest.approx((4 + 1) / 8.0)
    assert np.allclose(slam.mean[:2], [1.0, -0.5]) and np.allclose(np.diag(slam.cov)[:2], 2.0)


def test_a_position_glitch_is_refused_and_a_yaw_jump_resets_the_yaw():
    slam = EkfSlam(np.zeros(3), np.diag([0.01, 0.01, 1e-4]), NOISE)
    slam.update(Observation(10.0, 0.0, 1))
    mean, cov = slam.mean.copy(), slam.cov.copy()
    assert slam.update_position(30.0, 0.0, 0.5, gate_nis=23.0).action == "outlier"
    assert np.array_equal(slam.mean, mean) and np.array_equal(slam.cov, cov)
    # The autopilot's yaw jumped (its own reset): taken, not locked out.
    report = slam.update_yaw(1.0, math.radians(2.0), gate_nis=19.5)
    assert report.action == "yaw_reset" and report.nis > 19.5
    assert slam.mean[2] == pytest.approx(1.0, abs=0.01)
    assert np.linalg.eigvalsh(slam.cov).min() > -1e-12


def hover(nav_model: str, seed: int, steps: int = 600):
    """Hover 60 s at 10 Hz: zero-mean velocity noise 0.1 m/s per axis, yaw noise 2 deg, no
    landmarks. Returns the (true) pose error and covariance at every step."""
    rng = np.random.default_rng(seed)
    options = EstimatorOptions(motion_model=nav_model, velocity_noise=VEL_NOISE)
    nav = Navigator(np.zeros(3), np.diag([1e-4, 1e-4, math.radians(2.0) ** 2]), NOISE,
                    gates=AssociationGates(), params=PARAMS, goal=np.array([100.0, 0.0]), options=options)
    nees = []
    for step in range(1, steps + 1):
        vel = rng.normal(0.0, 0.1, 2)
        yaw = rng.normal(0.0, math.radians(2.0))
        rate = rng.normal(0.0, math.radians(0.86))
        if nav_model == "velocity_ned":
            nav.on_velocity(0.1 * step, vel[0], vel[1], yaw, rate)
        else:
            nav.on_odometry(0.1 * step, float(np.hypot(*vel)), yaw)
        nees.append(pose_nees(np.zeros(3), nav.slam.pose, nav.slam.pose_cov))
    return nav, np.array(nees)


def test_hovering_60_s_stays_within_3_sigma_and_nees_in_band():
    runs = 30
    results = [hover("velocity_ned", seed) for seed in range(runs)]
    nees = np.array([n for _, n in results])
    lo, hi = chi2.ppf([0.025, 0.975], runs * 3) / runs
    avg = nees.mean(axis=0)
    assert np.mean((avg > lo) & (avg < hi)) >= 0.9
    for nav, _ in results:
        sigma = np.sqrt(np.diag(nav.slam.pose_cov))
        assert np.all(np.abs(nav.slam.pose) < 3.0 * sigma)      # north, east and yaw
        assert sigma[:2] == pytest.approx(0.1 * 0.1 * math.sqrt(600), rel=0.05)


def test_the_paper_model_hovering_drifts_away_from_its_own_sigma():
    """What the issue measured: |v| of a noisy zero is never negative, so the unicycle walks off."""
    nav, nees = hover("paper", 0)
    assert np.hypot(*nav.slam.pose[:2]) > 3.0 and nees[-1] > 50.0


def crab_flight(motion_model: str, seed: int = 2):
    """Fly east at 5 m/s with the yaw held north (a 90 degree crab) past the paper's obstacles,
    the camera (looking north) reaching 150 m so that both stay in view."""
    base = load_scenario("config/scenarios/copter.yaml")
    world = dataclasses.replace(base.world, start=StartPose(0.0, -80.0, 0.0))
    est = dataclasses.replace(base.estimator_config(), motion_model=motion_model,
                              position_fusion="off")
    scenario = dataclasses.replace(base, world=world, estimator=est,
                                   sensor=dataclasses.replace(base.sensor, max_range_m=150.0))
    truth = TruthWorld(scenario, np.random.default_rng(seed))
    truth.vel_ne_mps = np.array([0.0, 5.0])
    nav = make_navigator(scenario)
    for step in range(1, 321):
        odo = truth.step_copter(np.array([0.0, 5.0]), 0.0)
        nav.on_velocity(0.1 * step, odo.vel_north_mps, odo.vel_east_mps, odo.yaw_rad,
                        odo.yaw_rate_rad_s)
        if step % 2 == 0:
            nav.on_observations(0.1 * step, truth.observe())
    return truth, nav


def test_crabbing_90_degrees_maps_both_obstacles_static_and_keeps_the_pose():
    truth, nav = crab_flight("velocity_ned")
    assert sorted(nav.slam.landmark_ids()) == [1, 2] and nav.movers_detected == 0
    assert np.hypot(*(nav.slam.pose[:2] - truth.pose[:2])) < 1.0
    assert abs(truth.pose[1] - 80.0) < 0.5            # it really flew east, yaw north
    errors = np.hypot(*(nav.slam.landmarks() - truth.obstacle_positions()[[i - 1 for i in nav.slam.landmark_ids()]]).T)
    assert errors.max() < 1.0


def test_a_multicopter_in_the_truth_flies_its_velocity_and_turns_on_its_own():
    scenario = load_scenario("config/scenarios/copter.yaml")
    truth = TruthWorld(scenario, np.random.default_rng(0))
    for _ in range(10):                                   # 1 s: command east, yaw east
        truth.step_copter(np.array([0.0, 5.0]), math.pi / 2)
    # the velocity turns as fast as 2.5 m/s^2 allows; the yaw at 30 deg/s: 30 deg in 1 s
    assert truth.pose[2] == pytest.approx(math.radians(30.0), abs=1e-9)
    assert np.allclose(truth.vel_ne_mps, [5.0 - 2.5 / math.sqrt(2), 2.5 / math.sqrt(2)], atol=0.01)


def test_the_truths_ahrs_yaw_carries_its_bias_and_the_vehicle_steers_by_it():
    base = load_scenario("config/scenarios/copter.yaml")
    noise = dataclasses.replace(base.noise, yaw_sigma_deg=0.5, yaw_bias_sigma_deg=1.5,
                                yaw_bias_tau_s=3600.0)
    truth = TruthWorld(dataclasses.replace(base, noise=noise), np.random.default_rng(3))
    assert abs(math.degrees(truth.yaw_bias_rad)) > 0.5           # this seed's draw
    errors = [truth.step_copter(np.zeros(2), 0.0).yaw_rad - truth.pose[2] for _ in range(600)]
    assert np.mean(errors) == pytest.approx(truth.yaw_bias_rad, abs=math.radians(0.1))
    assert truth.pose[2] == pytest.approx(-truth.yaw_bias_rad, abs=1e-3)   # turned by its AHRS
    # without a bias sigma nothing is drawn: the random stream (and every flight) as before
    unbiased = dataclasses.replace(base, noise=dataclasses.replace(noise, yaw_bias_sigma_deg=0.0))
    rng = np.random.default_rng(3)
    world = TruthWorld(unbiased, rng)
    odo = world.step_copter(np.zeros(2), 0.0)
    rng = np.random.default_rng(3)               # copter_odometry's draws: GPS bias, velocity
    rng.normal(0.0, base.noise.position_bias_sigma_m, 2)
    vel = rng.normal(0.0, base.noise.velocity_sigma_mps, 2)
    assert odo.vel_north_mps - world.vel_ne_mps[0] == pytest.approx(float(vel[0]), abs=1e-12)
    assert TruthWorld(unbiased, np.random.default_rng(3)).yaw_bias_rad == 0.0


def biased_yaw_hover(options: EstimatorOptions, seed: int, steps: int = 600):
    """Hover 60 s at 10 Hz with the true yaw 0: the autopilot's yaw is off by a bias of 1.5 deg
    (drawn per run, constant, as ArduCopter SITL's 1.3-1.5 deg) plus 0.5 deg of white noise; the
    gyro's yaw rate is white (0.86 deg/s). Returns the yaw NEES at every step."""
    rng = np.random.default_rng([seed, 7])
    bias = rng.normal(0.0, math.radians(1.5))
    nav = Navigator(np.zeros(3), np.diag([1e-4, 1e-4, math.radians(2.0) ** 2]), NOISE,
                    gates=AssociationGates(), params=PARAMS, goal=np.array([100.0, 0.0]),
                    options=options)
    nees = []
    for step in range(steps):
        nav.on_velocity(0.1 * step, 0.0, 0.0, bias + rng.normal(0.0, math.radians(0.5)),
                        rng.normal(0.0, math.radians(0.86)))
        nees.append(nav.slam.pose[2] ** 2 / nav.slam.pose_cov[2, 2])
    return np.array(nees)


def test_a_biased_autopilot_yaw_is_fused_as_correlated_and_the_yaw_nees_stays_near_1():
    runs = 100
    white = EstimatorOptions(motion_model="velocity_ned", velocity_noise=VEL_NOISE,
                             yaw_sigma_rad=math.radians(0.5))
    biased = dataclasses.replace(white, yaw_bias_sigma_rad=math.radians(1.5))
    # the yaw NEES averaged over the runs and the last 50 s (the gyro's drift is slow, so single
    # steps of a 100-run average still wander: 0.8 to 1.5 measured)
    nees = {name: float(np.mean([biased_yaw_hover(options, seed) for seed in range(runs)],
                                axis=0)[100:].mean())
            for name, options in (("biased", biased), ("white", white))}
    assert 0.6 < nees["biased"] < 1.6, nees
    # fused as white 0.5 deg samples the filter claims about 0.2 deg of a 1.5 deg error
    assert nees["white"] > 20.0, nees


def test_yaw_fix_sigma_is_white_without_a_bias_and_shares_the_bias_over_the_filter_memory():
    white = EstimatorOptions(velocity_noise=VEL_NOISE, yaw_sigma_rad=0.01)
    assert white.yaw_fix_sigma_rad(0.1) == white.yaw_fix_sigma_rad(None) == 0.01
    b = 0.03
    biased = dataclasses.replace(white, yaw_bias_sigma_rad=b, yaw_bias_tau_s=5.0)
    assert biased.yaw_fix_sigma_rad(None) == pytest.approx(math.hypot(0.01, b))
    # a bias decorrelated within 5 s, shorter than the filter's memory: 50 samples share it
    assert biased.yaw_fix_sigma_rad(0.1) == pytest.approx(math.sqrt(1e-4 + b * b * 50))
    # a bias of 600 s: the gyro makes the filter forget sooner; a scalar random walk fused with
    # that sigma settles at about twice the bias's variance (the docstring's P = 2 bias^2)
    slow = dataclasses.replace(biased, yaw_bias_tau_s=600.0)
    q = (VEL_NOISE.yaw_rate_sigma_rad_s * 0.1) ** 2
    r = slow.yaw_fix_sigma_rad(0.1) ** 2
    assert r == pytest.approx(1e-4 + 4 * b ** 4 / q) and r < 1e-4 + b * b * 6000
    p = 0.0
    for _ in range(20_000):
        p += q
        p = p * r / (p + r)
    assert p + q == pytest.approx(2 * b * b, rel=0.05)
