import dataclasses
import math

import numpy as np
import pytest

from companion.config.scenario import load_scenario
from companion.config.world import Obstacle
from companion.core.estimation.ekf_slam import EkfSlam
from companion.core.estimation.slam_types import Observation
from companion.core.geometry import observe
from companion.core.avoidance.guidance import GuidanceInputs, GuidanceParams
from companion.core.estimation.movers import MoverParams, MoverTracker, apparent_velocity
from companion.core.avoidance.union import UnionParams, blocking, guide_union
from companion.sim.simulation import make_navigator, run_once
from tests.core.test_ekf_slam import NOISE


def test_remove_landmark_is_the_marginal():
    slam = EkfSlam(np.zeros(3), np.eye(3) * 0.01, NOISE)
    for i, z in enumerate([(10, 0.1), (12, -0.3), (20, 0.5)]):
        slam.update(Observation(*z, obstacle_id=100 + i))
        slam.predict(2.0, 0.01, 0.1)
    mean, cov = slam.mean.copy(), slam.cov.copy()
    slam.remove_landmark(1)
    keep = [0, 1, 2, 3, 4, 7, 8]
    assert np.array_equal(slam.mean, mean[keep])
    assert np.array_equal(slam.cov, cov[np.ix_(keep, keep)])
    assert slam.landmark_ids() == [100, 102]
    report = slam.update(Observation(*observe(slam.pose, slam.landmarks()[1]), obstacle_id=102))
    assert report.action == "updated" and report.landmark_index == 1


def test_constant_velocity_track_learns_the_velocity():
    rng = np.random.default_rng(2)
    tracker = MoverTracker(MoverParams())
    start, velocity = np.array([50.0, 10.0]), np.array([1.2, -0.7])
    cov = np.eye(2) * 0.05 ** 2
    tid = tracker.create(0.0, start + rng.normal(0, 0.05, 2), cov, obstacle_id=9)
    for k in range(1, 40):
        t = 0.2 * k
        tracker.update(tid, t, start + velocity * t + rng.normal(0, 0.05, 2), cov)
    state = tracker.state(tid, 8.0)
    assert np.allclose(state.velocity_ne_mps, velocity, atol=0.1)
    later = tracker.state(tid, 18.0)                       # predicted 10 s ahead
    assert np.allclose(later.position_ne_m, start + velocity * 18.0, atol=1.5)
    assert tracker.prune(8.0 + MoverParams().coast_s + 0.1) == [tid]
    assert 9 not in tracker.by_obstacle_id


def test_apparent_velocity_separates_static_from_slow_movers():
    rng = np.random.default_rng(4)
    t = np.arange(0.0, 4.2, 0.2)           # the slowest movers (0.3 m/s) need about 4 s
    static = np.array([30.0, 5.0]) + rng.normal(0, 0.1, (len(t), 2))
    v, sigma = apparent_velocity(t, static, 0.1, 0.3, 0.1)
    assert np.hypot(*v) < 5 * sigma
    moving = np.array([30.0, 5.0]) + np.outer(t, [0.0, 0.3]) + rng.normal(0, 0.1, (len(t), 2))
    v, sigma = apparent_velocity(t, moving, 0.1, 0.3, 0.1)
    assert np.hypot(*v) > 5 * sigma and v[1] == pytest.approx(0.3, abs=0.1)


def test_relative_velocity_cone_blocks_a_crossing_mover():
    # An obstacle 30 m ahead and 20 m to the left, crossing to the right at 3 m/s: flying straight
    # at 5 m/s meets it. Its static cone does not cover heading 0; the relative one does.
    position, obstacle = np.zeros(2), np.array([[30.0, -20.0]])
    heading0 = np.array([0.0])
    static = blocking(heading0, position, obstacle, np.array([5.0]), 1.0, 60.0)
    moving = blocking(heading0, position, obstacle, np.array([5.0]), 1.0, 60.0, 5.0,
                      np.array([[0.0, 3.33]]), 10.0)
    assert not static[0, 0] and moving[0, 0]
    params = GuidanceParams(5.0, 5.0, 4.0, 1.25, 2.0)
    command = guide_union(GuidanceInputs(np.zeros(3), np.array([200.0, 0.0]), obstacle, None,
                                         None, 0, np.array([[0.0, 3.33]])), params, UnionParams(lookahead_s=10.0))
    assert command.mode == "avoid"


def world_with_a_mover(mover_velocity):
    base = load_scenario("config/scenarios/paper.yaml")
    obstacles = (Obstacle(1, 60.0, 5.0, 2.0),
                 Obstacle(2, 110.0, -25.0, 2.0, *mover_velocity),
                 Obstacle(3, 120.0, 20.0, 2.0))
    return dataclasses.replace(base, world=dataclasses.replace(base.world, obstacles=obstacles))


def test_mover_is_tracked_not_mapped_and_flight_stays_safe():
    scenario = world_with_a_mover((0.0, 0.5))
    outcome = run_once(scenario, seed=3)
    assert outcome.summary["reached_goal"] and not outcome.summary["collided"]
    assert outcome.summary["min_clearance_m"] >= 9.5
    assert outcome.summary["final_position_error_m"] < 2.0


def fly_north(scenario, steps: int = 250):
    """Fly straight north at 5 m/s for ``steps`` steps of 0.1 s, camera at 5 Hz."""
    from companion.sim.truth import TruthWorld
    truth = TruthWorld(scenario, np.random.default_rng(1))
    nav = make_navigator(scenario)
    for step in range(1, steps):
        odo = truth.step(5.0, 0.0)
        nav.predict(odo.speed_mps, odo.heading_change_rad, 0.1)
        if step % 2 == 0:
            nav.observe(truth.observe())
    return truth, nav


def test_young_mover_is_taken_out_of_the_map_without_touching_the_pose():
    scenario = world_with_a_mover((0.0, 0.5))
    truth, nav = fly_north(scenario)
    assert 2 in nav.movers.by_obstacle_id
    assert 2 not in nav.slam.landmark_ids() and {1, 3} <= set(nav.slam.landmark_ids())
    assert nav.movers_detected >= 1
    state = nav.movers.state(nav.movers.by_obstacle_id[2], nav.clock_s)
    assert np.allclose(state.velocity_ne_mps, [0.0, 0.5], atol=0.15)
    assert np.hypot(*(nav.slam.pose[:2] - truth.pose[:2])) < 1.5


def test_schmidt_update_leaves_pose_and_other_landmarks_untouched():
    slam = EkfSlam(np.array([0.0, 0.0, 0.1]), np.eye(3) * 0.04, NOISE)
    slam.update(Observation(20.0, 0.2, 1))
    slam.update(Observation(25.0, -0.3, 2))
    slam.predict(3.0, 0.01, 0.1)
    mean, cov = slam.mean.copy(), slam.cov.copy()
    report = slam.update(Observation(25.2, -0.29, 2), landmark_only=True)
    assert report.action == "updated"
    others = [0, 1, 2, 3, 4]
    assert np.array_equal(slam.mean[others], mean[others])
    assert np.array_equal(slam.cov[np.ix_(others, others)], cov[np.ix_(others, others)])
    assert not np.array_equal(slam.mean[5:7], mean[5:7])
    assert np.linalg.eigvalsh(slam.cov).min() > -1e-12
    # The landmark's own variance shrinks, but less than the full (optimal) update would make it.
    full = EkfSlam(np.array([0.0, 0.0, 0.1]), np.eye(3) * 0.04, NOISE)
    full.update(Observation(20.0, 0.2, 1))
    full.update(Observation(25.0, -0.3, 2))
    full.predict(3.0, 0.01, 0.1)
    full.update(Observation(25.2, -0.29, 2))
    assert np.trace(full.cov[5:7, 5:7]) <= np.trace(slam.cov[5:7, 5:7]) < np.trace(cov[5:7, 5:7])


def test_anonymous_mover_is_found_from_the_stream_and_leaves_no_trail():
    scenario = world_with_a_mover((0.0, 0.8))
    scenario = dataclasses.replace(scenario, sensor=dataclasses.replace(scenario.sensor, report_ids=False))
    truth, nav = fly_north(scenario)
    assert nav.movers_detected >= 1 and len(nav.movers) == 1
    (mover,) = nav.movers.states(nav.clock_s)
    assert mover.obstacle_id is None                       # internal ids are never published
    assert np.allclose(mover.velocity_ne_mps, [0.0, 0.8], atol=0.2)
    assert np.hypot(*(mover.position_ne_m - truth.obstacle_positions()[1])) < 1.5
    # The static map holds the two static obstacles and no trail of ghosts along the mover's path.
    assert nav.slam.landmark_count == 2
    static = truth.obstacle_positions()[[0, 2]]
    assert all(np.min(np.hypot(*(static - lm).T)) < 1.5 for lm in nav.slam.landmarks())


def test_static_worlds_only_differ_by_the_probation_of_new_landmarks(monkeypatch):
    """Mover handling costs static worlds little: the same successes, clearance within
    centimetres, the median final error within 0.2 m."""
    scenario = load_scenario("config/scenarios/paper.yaml")
    with_probation = [run_once(scenario, seed).summary for seed in range(6)]
    import companion.sim.simulation as simulation
    original = simulation.Navigator

    def without(*args, **kwargs):
        kwargs["mover_params"] = MoverParams(probation_s=-1.0, strikes_to_mover=10 ** 9)
        return original(*args, **kwargs)
    monkeypatch.setattr(simulation, "Navigator", without)
    plain = [run_once(scenario, seed).summary for seed in range(6)]
    for a, b in zip(with_probation, plain):
        assert a["reached_goal"] and b["reached_goal"]
        assert abs(a["min_clearance_m"] - b["min_clearance_m"]) < 0.2
    errors = [np.median([r["final_position_error_m"] for r in runs]) for runs in (with_probation, plain)]
    assert abs(errors[0] - errors[1]) < 0.2


def paper_crab_probation(course_known: bool, crab_deg: float = 12.0):
    """The paper's unicycle on a multicopter crabbing crab_deg, through the probation window only:
    its dead reckoning flies along the yaw, so static obstacles seem to drift sideways."""
    import math
    base = load_scenario("config/scenarios/copter.yaml")
    est = dataclasses.replace(base.estimator_config(), motion_model="paper", position_fusion="off")
    noise = dataclasses.replace(base.noise, yaw_sigma_deg=0.01)      # a clean yaw, as the stub's
    scenario = dataclasses.replace(base, estimator=est, noise=noise)
    from companion.sim.truth import TruthWorld
    truth = TruthWorld(scenario, np.random.default_rng(5))
    crab = math.radians(crab_deg)
    velocity = 5.0 * np.array([math.cos(crab), math.sin(crab)])
    truth.vel_ne_mps = velocity.copy()
    nav = make_navigator(scenario)
    for step in range(1, 29):                                        # 2.8 s < probation
        odo = truth.step_copter(velocity, 0.0)
        speed = math.hypot(odo.vel_north_mps, odo.vel_east_mps)
        course = math.atan2(odo.vel_east_mps, odo.vel_north_mps) if course_known else None
        nav.on_odometry(0.1 * step, speed, odo.yaw_rad, course)
        if step % 2 == 0:
            nav.on_observations(0.1 * step, truth.observe())
    return nav


def test_mover_test_allows_for_the_course_heading_difference():
    assert paper_crab_probation(course_known=False).movers_detected >= 1
    assert paper_crab_probation(course_known=True).movers_detected == 0


def test_mover_thresholds_are_config_keys(tmp_path):
    from companion.config.service import load_config
    from companion.errors import ConfigError
    text = open("config/companion.yaml").read().replace(
        "  slow_factor: 0.5\n", "  slow_factor: 0.5\n  mover_speed_threshold_mps: 0.4\n"
        "  mover_probation_s: 5.0\n  mover_strikes: 4\n")
    path = tmp_path / "c.yaml"
    path.write_text(text)
    params = load_config(path).estimator.mover_params()
    assert (params.speed_threshold_mps, params.probation_s, params.strikes_to_mover) == (0.4, 5.0, 4)
    path.write_text(text.replace("mover_strikes: 4", "mover_strikes: 0"))
    with pytest.raises(ConfigError, match=r"c\.yaml: estimator\.mover_strikes: expected an integer >= 1, got 0"):
        load_config(path)
