import math

import numpy as np
import pytest

from companion.core.avoidance.cone import check_cone, signed_angle
from companion.core.avoidance.guidance import (GuidanceParams, assess, escape_heading, guide_apf, guide_cone,
                                     inflated_radius, is_urgent, limit_turn, most_urgent)

PARAMS = GuidanceParams(cruise_speed_mps=5.0, safety_distance_m=10.0, horizon_s=4.0, eta=1.25,
                        goal_radius_m=2.0, mission_time_s=120.0)
GOAL = np.array([200.0, 0.0])


def test_far_obstacle_in_cone_is_not_urgent_until_within_horizon():
    pose = np.array([0.0, 0.0, 0.0])
    far = guide_cone(pose, GOAL, np.array([[60.0, 2.0]]), None, PARAMS, 0.0)
    assert far.mode == "goal" and far.threats[0].verdict.in_cone and not far.threats[0].urgent
    near = guide_cone(pose, GOAL, np.array([[20.0, 2.0]]), None, PARAMS, 0.0)
    assert near.mode == "avoid" and near.urgent_index == 0
    assert 0.0 < near.time_to_go_s < PARAMS.horizon_s


def test_mission_end_time_suppresses_urgency():
    verdict = check_cone(np.array([20.0, 2.0]), np.array([5.0, 0.0]), 10.0)
    assert is_urgent(verdict, 4.0, 0.0, 120.0)
    assert not is_urgent(verdict, 4.0, 118.0, 120.0)     # t + t_go beyond t_f


def test_deflection_is_eta_times_angle_to_near_tangent_and_away_from_obstacle():
    pose = np.array([0.0, 0.0, 0.0])
    obstacle = np.array([[20.0, 2.0]])                     # slightly right: turn left (negative)
    command = guide_cone(pose, GOAL, obstacle, None, PARAMS, 0.0)
    verdict = command.threats[0].verdict
    expected = 1.25 * signed_angle(np.array([1.0, 0.0]), np.array(verdict.aim))
    assert command.heading_rad == pytest.approx(expected)
    assert command.heading_rad < 0.0
    # After the deflection the new velocity is outside the cone.
    v_new = 5.0 * np.array([math.cos(command.heading_rad), math.sin(command.heading_rad)])
    assert not check_cone(obstacle[0], v_new, 10.0).in_cone


def test_most_urgent_is_the_smallest_time_to_go():
    pose = np.array([0.0, 0.0, 0.0])
    obstacles = np.array([[21.0, -1.0], [18.0, 1.0], [200.0, 0.0]])
    threats = assess(pose[:2], np.array([5.0, 0.0]), obstacles, None, PARAMS, 0.0)
    assert [t.urgent for t in threats] == [True, True, False]
    assert most_urgent(threats).index == 1


def test_inside_the_safety_circle_escapes_outward_toward_goal_side():
    pose = np.array([100.0, 0.0, 0.0])
    command = guide_cone(pose, GOAL, np.array([[104.0, 3.0]]), None, PARAMS, 0.0)
    assert command.mode == "escape"
    heading = np.array([math.cos(command.heading_rad), math.sin(command.heading_rad)])
    assert heading @ np.array([4.0, 3.0]) < 0.0            # away from the obstacle
    assert escape_heading(np.array([0.0, 5.0]), np.array([1.0, 0.0])) == pytest.approx(-math.pi / 4)


def test_arrival_and_approach_slow_down():
    assert guide_cone(np.array([199.0, 0.5, 0.0]), GOAL, np.empty((0, 2)), None, PARAMS, 0.0).mode == "arrived"
    slow = guide_cone(np.array([196.0, 0.0, 0.0]), GOAL, np.empty((0, 2)), None, PARAMS, 0.0)
    assert slow.speed_mps == pytest.approx(math.sqrt(2 * 1.0 * 4.0))


def test_turn_rate_limit():
    assert limit_turn(0.0, 1.0, math.radians(30), 0.1) == pytest.approx(math.radians(3))
    assert limit_turn(0.0, -1.0, math.radians(30), 0.1) == pytest.approx(-math.radians(3))
    assert limit_turn(3.1, -3.1, math.radians(30), 0.1) == pytest.approx(math.radians(3))  # short way, across pi
    assert limit_turn(3.1, -3.1, math.radians(60), 0.1) == pytest.approx(2 * math.pi - 6.2)


def test_inflation_uses_worst_axis_of_relative_covariance():
    assert inflated_radius(10.0, np.diag([4.0, 1.0]), 2.0) == pytest.approx(14.0)
    assert inflated_radius(10.0, np.diag([4.0, 1.0]), 0.0) == 10.0


def test_apf_repels_and_attracts():
    pose = np.array([0.0, 0.0, 0.0])
    free = guide_apf(pose, GOAL, np.empty((0, 2)), PARAMS)
    assert free.heading_rad == pytest.approx(0.0)
    pushed = guide_apf(pose, GOAL, np.array([[8.0, 3.0]]), PARAMS)
    assert pushed.heading_rad < 0.0                        # obstacle right-ahead: pushed left
