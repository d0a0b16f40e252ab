"""The pure multicopter truth model and odometry (no sockets)."""
import math

import numpy as np
import pytest
from hypothesis import given, strategies as st

from sitl_stub.vehicle import (GROUNDED, HOLD, Demand, Limits, TruthState, desired_climb_mps,
                               initial_odometry, position_demand, step_odometry, step_truth,
                               velocity_demand)
from sitl_stub.world import wrap_pi

LIMITS = Limits(max_turn_rate_rad_s=math.radians(30.0), max_accel_mps2=2.5)
DT = 0.1


def step(s, d, climb=0.0):
    return step_truth(s, d, LIMITS, DT, s.yaw_rad, climb)


def test_velocity_along_heading_is_the_paper_model():
    s = TruthState(north_m=20.0, east_m=0.0, yaw_rad=0.0, vel_north_mps=5.0)
    out = step(s, Demand(vel_north_mps=5.0, vel_east_mps=0.0, yaw_rad=0.0))
    assert out.north_m == pytest.approx(20.5) and out.east_m == 0.0 and out.yaw_rad == 0.0
    assert out.speed_mps == pytest.approx(5.0)


def test_velocity_vector_change_is_acceleration_limited():
    # asked to turn a 5 m/s velocity by 90 degrees at once: the vector moves by 0.25 m/s a step
    s = TruthState(0.0, 0.0, 0.0, vel_north_mps=5.0)
    out = step(s, Demand(vel_east_mps=5.0, yaw_rad=0.0))
    dv = math.hypot(out.vel_north_mps - 5.0, out.vel_east_mps)
    assert dv == pytest.approx(0.25)
    assert out.vel_east_mps > 0 and out.vel_north_mps < 5.0


def test_turn_rate_is_limited_and_a_yaw_rate_tightens_it():
    s = TruthState(0.0, 0.0, 0.0)
    assert step(s, Demand(yaw_rad=math.pi / 2)).yaw_rad == pytest.approx(math.radians(3.0))
    assert step(s, Demand(yaw_rad=-math.pi / 2)).yaw_rad == pytest.approx(-math.radians(3.0))
    tight = Demand(yaw_rad=math.pi / 2, turn_rate_limit_rad_s=math.radians(10))
    assert step(s, tight).yaw_rad == pytest.approx(math.radians(1.0))


def test_turn_takes_the_short_way_across_pi():
    s = TruthState(0.0, 0.0, math.radians(179))
    out = step(s, Demand(yaw_rad=math.radians(-179)))
    assert wrap_pi(out.yaw_rad - math.radians(179)) == pytest.approx(math.radians(2.0))


def test_stop_from_cruise_takes_speed_over_accel():
    s = TruthState(0.0, 0.0, 0.0, vel_north_mps=5.0)
    steps = 0
    while s.speed_mps > 0:
        s = step(s, HOLD)
        steps += 1
    assert steps == round(5.0 / 2.5 / DT)
    assert s.north_m == pytest.approx(sum(5.0 - 0.25 * k for k in range(1, steps + 1)) * DT)


def test_crab_course_east_heading_north():
    """ArduCopter's velocity + yaw: it flies the velocity and keeps the commanded yaw."""
    s = TruthState(0.0, 0.0, 0.0)
    d = velocity_demand(0.0, 5.0, yaw_rad=0.0, yaw_rate_rad_s=None)
    for _ in range(100):
        s = step(s, d)
    assert s.vel_east_mps == pytest.approx(5.0) and s.vel_north_mps == pytest.approx(0.0)
    assert s.yaw_rad == 0.0
    assert s.east_m > 45.0 and s.north_m == pytest.approx(0.0)


def test_velocity_without_yaw_faces_the_velocity():
    s = TruthState(0.0, 0.0, 0.0)
    d = velocity_demand(0.0, 5.0, yaw_rad=None, yaw_rate_rad_s=None)
    for _ in range(60):
        s = step(s, d)
    assert s.yaw_rad == pytest.approx(math.pi / 2)


def test_yaw_turns_independently_of_the_velocity():
    s = TruthState(0.0, 0.0, 0.0, vel_north_mps=5.0)
    d = velocity_demand(5.0, 0.0, yaw_rad=math.pi / 2, yaw_rate_rad_s=None)
    s = step(s, d)
    assert s.vel_north_mps == pytest.approx(5.0) and s.vel_east_mps == 0.0   # course unchanged
    assert s.yaw_rad == pytest.approx(math.radians(3.0))                     # heading turning
    spin = velocity_demand(0.0, 0.0, yaw_rad=None, yaw_rate_rad_s=0.2)
    assert spin.yaw_rate_rad_s == 0.2 and spin.speed_mps == 0.0


def test_climb_limits_and_altitude_hold():
    assert desired_climb_mps(Demand(climb_mps=5.0), 0.0, 2.5, 1.5, 1.0) == 2.5
    assert desired_climb_mps(Demand(climb_mps=-5.0), 10.0, 2.5, 1.5, 1.0) == -1.5
    assert desired_climb_mps(Demand(climb_mps=0.0), 10.0, 2.5, 1.5, 1.0) == 0.0
    assert desired_climb_mps(Demand(target_up_m=10.0), 10.0, 2.5, 1.5, 1.0) == 0.0
    assert desired_climb_mps(Demand(target_up_m=20.0), 10.0, 2.5, 1.5, 1.0) == 2.5
    assert desired_climb_mps(Demand(target_up_m=10.5), 10.0, 2.5, 1.5, 1.0) == pytest.approx(0.5)
    s = TruthState(0.0, 0.0, 0.0, up_m=0.05, vel_up_mps=-1.0)
    out = step(s, Demand(climb_mps=-1.0), climb=-1.0)
    assert out.up_m == 0.0 and out.vel_up_mps == 0.0                  # the ground stops it


def test_grounded_does_not_move():
    s = TruthState(1.0, 2.0, 0.3, vel_north_mps=3.0, up_m=0.0)
    out = step(s, GROUNDED)
    assert (out.north_m, out.east_m, out.yaw_rad, out.speed_mps) == (1.0, 2.0, 0.3, 0.0)


@given(st.floats(-100, 100), st.floats(-100, 100))
def test_wrap_pi_range(a, b):
    w = wrap_pi(a - b)
    assert -math.pi < w <= math.pi
    assert math.isclose(math.cos(w), math.cos(a - b), abs_tol=1e-9)


def test_odometry_equals_truth_without_noise_even_crabbing():
    s = TruthState(20.0, 0.0, 0.3)
    o = initial_odometry(s)
    for k in range(200):
        d = velocity_demand(5.0 * math.cos(k / 30.0), 5.0 * math.sin(k / 30.0),
                            yaw_rad=math.sin(k / 20.0), yaw_rate_rad_s=None)
        before = s
        s = step_truth(s, d, LIMITS, DT, o.yaw_rad, 0.0)
        o = step_odometry(o, before, s, 0.0, 0.0, (0.0, 0.0), DT)
    assert o.north_m == pytest.approx(s.north_m, abs=1e-9)
    assert o.east_m == pytest.approx(s.east_m, abs=1e-9)
    assert o.yaw_rad == pytest.approx(s.yaw_rad, abs=1e-12)


def test_odometry_reports_noisy_rates_and_velocity_along_reported_yaw():
    before = TruthState(0.0, 0.0, 0.0, vel_north_mps=5.0)
    after = TruthState(0.5, 0.0, 0.01, vel_north_mps=5.0 * math.cos(0.01),
                       vel_east_mps=5.0 * math.sin(0.01))
    o = step_odometry(initial_odometry(before), before, after, 0.2, 0.002, (0.0, 0.0), DT)
    assert o.speed_mps == pytest.approx(5.2)
    assert o.yaw_rate_rad_s == pytest.approx(0.012 / DT)
    assert o.yaw_rad == pytest.approx(0.012)
    assert o.vel_north_mps == pytest.approx(5.2 * math.cos(0.012))
    assert o.vel_east_mps == pytest.approx(5.2 * math.sin(0.012))
    assert o.north_m == pytest.approx(5.2 * math.cos(0.012) * DT)


def test_odometry_per_axis_velocity_noise_is_added():
    s = TruthState(0.0, 0.0, 0.0)
    o = step_odometry(initial_odometry(s), s, s, 0.0, 0.0, (0.1, -0.2), DT)
    assert (o.vel_north_mps, o.vel_east_mps) == pytest.approx((0.1, -0.2))


def test_odometry_drift_statistics_match_q():
    """Straight flight: after N steps the heading error is a sum of N N(0, sh^2) draws and the
    along-track error a sum of N N(0, ss^2) draws times dt. Check both variances (Monte Carlo)."""
    rng = np.random.default_rng(3)
    runs, steps = 400, 100
    ss, sh = 0.3, math.radians(0.5)
    yaw_err = np.empty(runs)
    along_err = np.empty(runs)
    s = TruthState(0.0, 0.0, 0.0, vel_north_mps=5.0)
    for r in range(runs):
        o = initial_odometry(s)
        for _ in range(steps):
            o = step_odometry(o, s, s, rng.normal(0, ss), rng.normal(0, sh), (0.0, 0.0), DT)
        yaw_err[r] = o.yaw_rad
        along_err[r] = o.north_m - 5.0 * DT * steps
    # sample variance / true variance ~ chi2(runs-1)/(runs-1): +-25% is > 3.5 sigma for 400 runs
    assert np.var(yaw_err, ddof=1) / (steps * sh**2) == pytest.approx(1.0, abs=0.25)
    assert np.var(along_err, ddof=1) / (steps * (ss * DT) ** 2) == pytest.approx(1.0, abs=0.25)
    assert abs(np.mean(yaw_err)) < 4 * math.sqrt(steps) * sh / math.sqrt(runs)


def test_position_demand_flies_to_the_point_and_stops():
    s = TruthState(0.0, 0.0, 0.0)
    for _ in range(600):
        d = position_demand(s.north_m, s.east_m, 30.0, 20.0, 10.0, 2.5, None)
        s = step(s, d)
    assert math.hypot(s.north_m - 30.0, s.east_m - 20.0) < 0.5
    assert s.speed_mps < 0.05
