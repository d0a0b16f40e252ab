"""Landmark lifecycle: each transition, the visibility test, and what tentative landmarks may do."""
import dataclasses
import math

import numpy as np
import pytest

from companion.config.scenario import load_scenario
from companion.core.estimation.slam_types import Observation
from companion.core.geometry import observe
from companion.core.estimation.lifecycle import Lifecycle, LifecycleParams, expected_visible
from companion.sim.simulation import make_navigator

VIEW = LifecycleParams(fov_rad=math.radians(90.0), max_range_m=40.0)


def navigator(**estimator):
    """The paper's anonymous scenario, vehicle at (20, 0) looking north; probation off, so that
    only the lifecycle decides what a landmark may do."""
    scenario = load_scenario("config/scenarios/paper-anonymous.yaml")
    est = dataclasses.replace(scenario.estimator_config(), established_sightings=1,
                              mover_probation_s=0.0, **estimator)
    return make_navigator(dataclasses.replace(scenario, estimator=est))


def see(nav, *points):
    """One frame of exact, id-less observations of world points from the estimated pose."""
    frame = [Observation(*observe(nav.slam.pose, np.array(p, dtype=float)), None) for p in points]
    return nav.observe(frame)


def frames(nav, count, *points):
    for _ in range(count):
        see(nav, *points)


# ------------------------------------------------------------------ pure lifecycle
def test_confirmed_after_m_detections_within_n_chances():
    life = Lifecycle(LifecycleParams(confirm_hits=3, confirm_window=5))
    life.add(7, 0.0)
    visible = np.array([True])
    assert life.judge(0.1, [7], visible, detected=set()).confirmed == ()     # chance 2: missed
    assert life.judge(0.2, [7], visible, detected={7}).confirmed == ()      # 2 of 3
    assert life.is_tentative(7)
    assert life.judge(0.3, [7], visible, detected={7}).confirmed == (7,)    # 3 of 4
    assert life.state(7) == "confirmed" and life.counts["confirmed"] == 1


def test_tentative_expires_once_m_of_n_cannot_be_reached():
    life = Lifecycle(LifecycleParams(confirm_hits=3, confirm_window=5))
    life.add(7, 0.0)
    visible = np.array([True])
    assert life.judge(0.1, [7], visible, set()).expired == ()     # 1 of 2: 2 more in 3 left
    assert life.judge(0.2, [7], visible, set()).expired == ()     # 1 of 3: 2 more in 2 left
    assert life.judge(0.3, [7], visible, set()).expired == (7,)   # 1 of 4: out of reach
    assert life.state(7) is None and life.counts == {"confirmed": 0, "deleted": 0, "expired": 1}


def test_tentative_out_of_view_expires_after_its_timeout():
    life = Lifecycle(LifecycleParams(tentative_timeout_s=10.0))
    life.add(7, 0.0)
    hidden = np.array([False])
    assert life.judge(9.9, [7], hidden, set()).expired == ()
    assert life.judge(10.1, [7], hidden, set()).expired == (7,)


def test_confirmed_is_deleted_after_k_misses_in_a_row_and_a_detection_resets_the_count():
    life = Lifecycle(LifecycleParams(confirm_hits=1, confirm_window=1, delete_misses=3))
    life.add(7, 0.0)
    assert life.judge(0.0, [7], np.array([True]), {7}, added={7}).confirmed == (7,)  # 1 of 1
    visible = np.array([True])
    for _ in range(2):
        assert life.judge(1.0, [7], visible, set()).deleted == ()
    life.judge(1.0, [7], visible, {7})                                    # seen again
    for _ in range(2):
        assert life.judge(1.0, [7], visible, set()).deleted == ()
    assert life.judge(100.0, [7], np.array([False]), set()).deleted == ()  # no chance, no miss
    assert life.judge(1.0, [7], visible, set()).deleted == (7,)
    assert life.counts["deleted"] == 1


def test_an_ambiguous_observation_near_a_landmark_is_not_a_miss():
    life = Lifecycle(LifecycleParams(confirm_hits=1, confirm_window=1, delete_misses=1))
    life.add(7, 0.0)
    life.judge(0.0, [7], np.array([True]), {7}, added={7})      # 1 of 1: confirmed at birth
    assert life.state(7) == "confirmed"
    assert life.judge(0.0, [7], np.array([True]), set(), near={7}).deleted == ()
    assert life.judge(0.0, [7], np.array([True]), set()).deleted == (7,)


# ------------------------------------------------------------------ visibility
def test_expected_visible_needs_view_range_and_a_clear_line():
    pose = np.array([0.0, 0.0, 0.0])
    points = np.array([[20.0, 0.0],      # in view
                       [35.0, 1.0],      # behind the first (3 m of its ray at 20 m: 8.6 deg)
                       [35.0, 12.0],     # beside it: 19 deg off its ray
                       [39.0, 0.0 + 30.0],   # beyond max range less its margin (49 m)
                       [10.0, 9.8],      # 44.4 deg: inside the 45 deg half view, not its margin
                       [-10.0, 0.0]])    # behind the vehicle
    assert expected_visible(pose, points, VIEW).tolist() == [True, False, True, False, False, False]
    unknown = LifecycleParams()                       # no sensor view known: never a chance
    assert not expected_visible(pose, points, unknown).any()


# ------------------------------------------------------------------ in the navigator
def test_navigator_confirms_then_deletes_an_unseen_landmark_by_marginalising_it():
    nav = navigator(confirm_hits=3, confirm_window=5, delete_misses=8)
    frames(nav, 3, (40.0, 0.0), (50.0, -15.0))
    assert nav.lifecycle.counts["confirmed"] == 2
    keys = nav.slam.landmark_ids()
    kept = nav.slam.landmarks()[1].copy()
    kept_cov = nav.slam.landmark_covs()[1].copy()
    pose_cov = nav.slam.pose_cov
    frames(nav, 7, (50.0, -15.0))                       # the first one is gone: missed 7 times
    assert nav.slam.landmark_count == 2
    reports = see(nav, (50.0, -15.0))                   # the 8th miss
    assert [r.action for r in reports if r.action == "deleted"] == ["deleted"]
    assert nav.slam.landmark_ids() == [keys[1]] and nav.slam.cov.shape == (5, 5)
    # Marginalised, not zeroed: what was left keeps its estimate (the last frame updated it
    # only by exact observations, so the landmark moves by rounding at most)
    assert np.allclose(nav.slam.landmarks()[0], kept, atol=1e-6)
    assert np.all(np.diag(nav.slam.landmark_covs()[0]) <= np.diag(kept_cov) + 1e-12)
    assert np.all(np.diag(nav.slam.pose_cov) <= np.diag(pose_cov) + 1e-12)
    assert nav.lifecycle.counts == {"confirmed": 2, "deleted": 1, "expired": 0}


def test_hidden_behind_a_nearer_landmark_is_not_a_miss():
    nav = navigator(delete_misses=3)
    frames(nav, 3, (40.0, 0.0), (55.0, 1.0))
    assert nav.slam.landmark_count == 2 and nav.lifecycle.counts["confirmed"] == 2
    frames(nav, 20, (40.0, 0.0))                 # the far one is behind the near one: no chance
    assert nav.slam.landmark_count == 2 and nav.lifecycle.counts["deleted"] == 0
    # the same far landmark moved clear of the near one's ray is deleted by the same frames
    nav = navigator(delete_misses=3)
    frames(nav, 3, (40.0, 0.0), (55.0, 12.0))
    frames(nav, 20, (40.0, 0.0))
    assert nav.slam.landmark_count == 1 and nav.lifecycle.counts["deleted"] == 1


def test_a_false_alarm_expires():
    nav = navigator()
    see(nav, (45.0, 5.0))
    assert nav.slam.landmark_count == 1 and nav.lifecycle.is_tentative(nav.slam.landmark_ids()[0])
    frames(nav, 3)
    assert nav.slam.landmark_count == 0
    assert nav.lifecycle.counts == {"confirmed": 0, "deleted": 0, "expired": 1}


@pytest.mark.parametrize("confirm_hits, moves", [(10, False), (1, True)])
def test_tentative_landmarks_never_correct_the_pose(confirm_hits, moves):
    nav = navigator(confirm_hits=confirm_hits, confirm_window=10,
                    initial_position_sigma_m=1.0, initial_yaw_sigma_deg=2.0)
    see(nav, (40.0, 0.0))
    nav.predict(0.0, 0.0, 0.2)                   # probation over (mover_probation_s = 0)
    see(nav, (40.0, 0.0))
    assert not nav.probation.young
    before = nav.slam.pose
    shifted = nav.slam.landmarks()[0] + (0.1, 0.0)
    see(nav, shifted)                            # 0.1 m further than the map has it (1 sigma)
    assert nav.lifecycle.is_tentative(nav.slam.landmark_ids()[0]) is not moves
    assert (not np.allclose(nav.slam.pose, before, atol=1e-9)) is moves


def test_tentative_landmarks_may_be_left_out_of_guidance():
    for in_guidance, rows in ((True, 1), (False, 0)):
        nav = navigator(tentative_in_guidance=in_guidance)
        see(nav, (40.0, 0.0))
        assert len(nav.obstacles()[0]) == rows
        frames(nav, 2, (40.0, 0.0))               # confirmed: avoided either way
        assert len(nav.obstacles()[0]) == 1
