"""Frame association without ids: nearest pairs first, one observation per landmark, joint check."""
import dataclasses
import math

import numpy as np

from companion.config.scenario import load_scenario
from companion.core.estimation.association import associate_frame
from companion.core.estimation.ekf_slam import EkfSlam
from companion.core.estimation.slam_types import Observation, SlamNoise
from companion.sim.simulation import make_navigator
from companion.core.geometry import observe
from tests.core.test_lifecycle import navigator, see

NOISE = SlamNoise(0.3, math.radians(0.02), 0.1, 0.1, math.radians(0.05))


def map_with(points, yaw_sigma_deg=0.01, independent=False):
    """A filter at the origin looking north with landmarks at ``points``. ``independent``: each
    landmark known to 1 cm and uncorrelated with the pose, so the yaw's uncertainty is shared by
    every observation of the frame."""
    slam = EkfSlam(np.zeros(3), np.diag([1e-6, 1e-6, math.radians(yaw_sigma_deg) ** 2]), NOISE)
    for p in points:
        slam.add_landmark(observe(slam.pose, np.array(p, dtype=float)))
    if independent:
        cov = slam._cov_buf
        cov[3:, :3] = cov[:3, 3:] = 0.0
        cov[3:, 3:] = np.eye(len(cov) - 3) * 1e-4
    return slam


def test_two_observations_of_one_landmark_the_nearer_takes_it_the_other_is_ambiguous():
    slam = map_with([(20.0, 0.0)])
    near = observe(slam.pose, np.array([20.05, 0.0]))
    far = observe(slam.pose, np.array([20.25, 0.0]))      # gates too (2.5 sigma), but is second
    for frame, nearer in (([near, far], 0), ([far, near], 1)):
        pairings = associate_frame(slam, np.array(frame))
        assert pairings[nearer].action == "update" and pairings[nearer].index == 0
        assert pairings[1 - nearer].action == "ambiguous" and pairings[1 - nearer].index == 0


def test_an_observation_far_from_every_landmark_is_new():
    slam = map_with([(20.0, 0.0)])
    pairings = associate_frame(slam, np.array([observe(slam.pose, np.array([30.0, 8.0]))]))
    assert [p.action for p in pairings] == ["new"]


def test_joint_compatibility_refuses_a_pairing_no_single_yaw_error_explains():
    # Two landmarks 10 deg either side of the heading; the yaw is uncertain by 2 deg, the bearing
    # measured to 0.05 deg. Each observation shifted 1.5 deg gates alone (the yaw could explain
    # it), but shifted in opposite directions they cannot both be right.
    points = [(20.0 * math.cos(math.radians(10)), 20.0 * math.sin(math.radians(10))),
              (20.0 * math.cos(math.radians(-10)), 20.0 * math.sin(math.radians(-10)))]
    slam = map_with(points, yaw_sigma_deg=2.0, independent=True)
    shift = math.radians(1.5)
    same = np.array([[20.0, math.radians(10) + shift], [20.0, math.radians(-10) + shift]])
    apart = np.array([[20.0, math.radians(10) + shift], [20.0, math.radians(-10) - shift]])
    for k in range(2):
        assert slam.nis_all(apart[k])[0][k] < slam.gates.accept_nis
    assert [p.action for p in associate_frame(slam, same)] == ["update", "update"]
    actions = sorted(p.action for p in associate_frame(slam, apart))
    assert actions == ["ambiguous", "update"]
    assert slam.joint_nis(apart, [0, 1]) > 100.0 * slam.joint_nis(same, [0, 1])


def test_joint_nis_of_one_observation_is_its_own_nis():
    slam = map_with([(20.0, 3.0), (25.0, -4.0)], yaw_sigma_deg=1.0)
    z = observe(slam.pose, np.array([20.1, 3.05]))
    assert math.isclose(slam.joint_nis(z[None, :], [0]), slam.nis_all(z)[0][0], rel_tol=1e-9)


def test_navigator_adds_no_landmark_beside_a_taken_one():
    nav = navigator()
    see(nav, (40.0, 0.0))
    see(nav, (40.0, 0.0), (40.2, 0.0))           # a second return from the same post
    assert nav.slam.landmark_count == 1
    see(nav, (40.0, 0.0), (45.0, 12.0))          # a second post is a new landmark
    assert nav.slam.landmark_count == 2


# ------------------------------------------------- at a real stereo camera's noise (realistic.yaml)
REALISTIC_SIGMA_B = math.radians(1.0)


def realistic_sigma_r(range_m):
    return 0.01 + 0.0015 * range_m ** 2          # realistic.yaml: 1.36 m at 30 m


def realistic_navigator():
    """realistic.yaml's filter (R = diag((0.01 + 0.0015 r^2)^2, (1 deg)^2)), vehicle at (20, 0)
    looking north, probation off (only association and the lifecycle decide)."""
    scenario = load_scenario("config/scenarios/realistic.yaml")
    est = dataclasses.replace(scenario.estimator_config(), established_sightings=1, mover_probation_s=0.0)
    return make_navigator(dataclasses.replace(scenario, estimator=est))


def noisy_frame(nav, rng, *points):
    """One frame of id-less observations of world points from the true (= start) pose, with the
    realistic camera's noise."""
    frame = []
    for p in points:
        r, b = observe(np.array([20.0, 0.0, 0.0]), np.array(p, dtype=float))
        frame.append(Observation(r + rng.normal(0.0, realistic_sigma_r(r)),
                                 b + rng.normal(0.0, REALISTIC_SIGMA_B), None))
    return frame


def test_realistic_noise_two_returns_of_one_post_make_one_landmark():
    # A post 30 m ahead answers twice in every frame (two detector boxes on one post), each
    # with the range noise of 30 m (1.36 m): one updates it, the other is ambiguous, never new.
    nav, rng = realistic_navigator(), np.random.default_rng(5)
    actions = []
    for _ in range(150):
        actions += [r.action for r in nav.observe(noisy_frame(nav, rng, (50.0, 0.0), (50.0, 0.0)))]
    assert nav.slam.landmark_count == 1
    assert actions.count("added") == 1
    assert actions.count("ambiguous") >= 140
    assert np.hypot(*(nav.slam.landmarks()[0] - [50.0, 0.0])) < 1.0


def test_realistic_noise_two_posts_close_together_keep_their_own_landmarks():
    # Two posts 4 m apart across the line of sight at 30 m (7.6 deg apart: 7.6 bearing sigmas),
    # their range errors 1.36 m each: each keeps one landmark, none merges or swaps.
    nav, rng = realistic_navigator(), np.random.default_rng(6)
    posts = [(50.0, -2.0), (50.0, 2.0)]
    for _ in range(150):
        nav.observe(noisy_frame(nav, rng, *posts))
    landmarks = nav.slam.landmarks()
    assert nav.slam.landmark_count == 2
    for post in posts:
        assert np.hypot(*(landmarks - post).T).min() < 1.0


def test_realistic_noise_a_far_return_that_gates_on_a_taken_landmark_is_ambiguous():
    # The range sigma at 35 m is 1.85 m: a second return 2.5 m behind the first gates on the
    # landmark the first took. It is ambiguous, not a new landmark just behind the post.
    nav = realistic_navigator()
    nav.observe([Observation(35.0, 0.0, None)])
    slam = nav.slam
    near, behind = np.array([35.2, 0.0]), np.array([37.5, 0.0])
    covs = [np.diag([realistic_sigma_r(z[0]) ** 2, REALISTIC_SIGMA_B ** 2]) for z in (near, behind)]
    assert slam.nis_all(behind, covs[1])[0][0] < slam.gates.new_landmark_nis
    pairings = associate_frame(slam, np.array([near, behind]), meas_covs=covs)
    assert [(p.action, p.index) for p in pairings] == [("update", 0), ("ambiguous", 0)]
    # And through the navigator: one landmark, the far return counted near it, not new.
    reports = nav.observe([Observation(*near), Observation(*behind)])
    assert [r.action for r in reports[:2]] == ["updated", "ambiguous"]
    assert nav.slam.landmark_count == 1


def test_two_returns_of_a_post_seen_first_in_one_frame_make_one_landmark():
    # An empty map: both returns are 'new' against it; the second gates on the landmark the
    # first has just started, so it is ambiguous, not a second landmark 2 m behind.
    nav = realistic_navigator()
    reports = nav.observe([Observation(30.0, 0.0, None), Observation(32.0, 0.01, None)])
    assert [r.action for r in reports[:2]] == ["added", "ambiguous"]
    assert nav.slam.landmark_count == 1
    # Two posts 10 m apart seen first in one frame are two landmarks.
    nav = realistic_navigator()
    nav.observe([Observation(30.0, 0.0, None), Observation(30.0, math.radians(20.0), None)])
    assert nav.slam.landmark_count == 2


def test_an_ambiguous_observation_never_updates_the_landmark_another_one_took():
    # The frame's first observation is ambiguous on the landmark its second takes: the first must
    # not fall through to a nearest-neighbour update of it (two updates of one landmark).
    nav = realistic_navigator()
    nav.observe([Observation(30.0, 0.0, None)])
    before = nav.slam.cov.copy()
    reports = nav.observe([Observation(32.5, 0.0, None), Observation(30.1, 0.0, None)])
    assert [r.action for r in reports[:2]] == ["ambiguous", "updated"]
    single = realistic_navigator()
    single.observe([Observation(30.0, 0.0, None)])
    single.observe([Observation(30.1, 0.0, None)])
    assert np.allclose(nav.slam.cov, single.slam.cov) and not np.allclose(nav.slam.cov, before)
