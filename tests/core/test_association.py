"""Frame association without ids: nearest pairs first, one observation per landmark, joint check."""
import math

import numpy as np

from companion.core.association import associate_frame
from companion.core.ekf_slam import EkfSlam, SlamNoise
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
