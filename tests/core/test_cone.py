import math

import numpy as np
import pytest

from companion.core.avoidance.cone import check_cone, in_cone_by_angle, signed_angle


def random_cases(n, seed=1):
    rng = np.random.default_rng(seed)
    for _ in range(n):
        d = rng.uniform(1.0, 20.0)
        dist = d * rng.uniform(1.01, 10.0)
        angle = rng.uniform(-math.pi, math.pi)
        x = dist * np.array([math.cos(angle), math.sin(angle)])
        v = rng.normal(0.0, 5.0, size=2)
        yield x, v, d


def test_identities_hold_on_random_inputs():
    checked = 0
    for x, v, d in random_cases(2000):
        verdict = check_cone(x, v, d)
        if verdict.tangent_1 is None:
            continue
        p1, p2 = np.array(verdict.tangent_1), np.array(verdict.tangent_2)
        u1, u2 = (p1 - x) / d, (p2 - x) / d
        assert np.linalg.norm(u1) == pytest.approx(1.0, abs=1e-9)
        assert np.linalg.norm(u2) == pytest.approx(1.0, abs=1e-9)
        assert x @ u1 == pytest.approx(-d, abs=1e-8 * np.linalg.norm(x))
        assert x @ u2 == pytest.approx(-d, abs=1e-8 * np.linalg.norm(x))
        assert np.allclose(verdict.a * p1 + verdict.b * p2, v, atol=1e-8 * (1 + np.linalg.norm(v)))
        checked += 1
    assert checked > 1900


def test_cone_test_agrees_with_plain_angle_test():
    inside = 0
    for x, v, d in random_cases(5000, seed=2):
        verdict = check_cone(x, v, d)
        assert verdict.in_cone == in_cone_by_angle(x, v, d)
        inside += verdict.in_cone
    assert 50 < inside < 4950       # both outcomes exercised


def test_hand_worked_case():
    # X = (10, 0), V = (1, 0.1), d = 5: c = sqrt(75); p1 = (7.5, 4.33) on V's side (east).
    verdict = check_cone(np.array([10.0, 0.0]), np.array([1.0, 0.1]), 5.0)
    c = math.sqrt(75.0)
    assert verdict.c == pytest.approx(c)
    assert verdict.a == pytest.approx(0.5 * (10 / 75 + 1 / (5 * c)))
    assert verdict.b == pytest.approx(0.5 * (10 / 75 - 1 / (5 * c)))
    assert np.allclose(verdict.tangent_1, [7.5, 5 * math.sqrt(3) / 2])
    assert verdict.in_cone and np.allclose(verdict.aim, verdict.tangent_1)


def test_head_on_is_in_cone_and_turns_right():
    verdict = check_cone(np.array([30.0, 0.0]), np.array([5.0, 0.0]), 10.0)
    assert verdict.kind == "head_on" and verdict.in_cone
    aim = np.array(verdict.aim)
    assert aim[1] > 0.0                                   # east of north: to the right
    assert np.linalg.norm(aim) == pytest.approx(math.sqrt(800.0))
    # time to go along V to the tangent point: |p| cos(asin(d/|X|)) / |V|
    assert verdict.time_to_go_s == pytest.approx(math.sqrt(800.0) * math.cos(math.asin(1 / 3)) / 5.0)


def test_receding_along_line_of_sight_is_no_threat():
    verdict = check_cone(np.array([30.0, 0.0]), np.array([-5.0, 0.0]), 10.0)
    assert verdict.kind == "receding" and not verdict.in_cone


def test_inside_safety_radius_is_urgent_now():
    verdict = check_cone(np.array([3.0, 4.0]), np.array([1.0, 0.0]), 10.0)
    assert verdict.kind == "inside" and verdict.in_cone and verdict.time_to_go_s == 0.0


def test_zero_speed_is_not_a_threat():
    verdict = check_cone(np.array([20.0, 0.0]), np.zeros(2), 10.0)
    assert verdict.kind == "stationary" and not verdict.in_cone


def test_offset_miss_and_exact_tangency_are_outside():
    assert not check_cone(np.array([30.0, 15.0]), np.array([5.0, 0.0]), 10.0).in_cone
    x = np.array([20.0, 0.0])
    half = math.asin(10.0 / 20.0)
    along_tangent = np.array([math.cos(half), math.sin(half)]) * 5.0
    verdict = check_cone(x, along_tangent * (1 + 1e-9), 10.0)
    assert verdict.b == pytest.approx(0.0, abs=1e-6)       # on the cone's edge
    assert not check_cone(x, np.array([math.cos(half + 1e-4), math.sin(half + 1e-4)]), 10.0).in_cone
    assert check_cone(x, np.array([math.cos(half - 1e-4), math.sin(half - 1e-4)]), 10.0).in_cone


def test_signed_angle_is_clockwise_positive_in_ned():
    north, east = np.array([1.0, 0.0]), np.array([0.0, 1.0])
    assert signed_angle(north, east) == pytest.approx(math.pi / 2)
    assert signed_angle(east, north) == pytest.approx(-math.pi / 2)
