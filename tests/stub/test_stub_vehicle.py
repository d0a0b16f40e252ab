"""The pure truth model and odometry (no sockets)."""
import math

import numpy as np
import pytest
from hypothesis import given, strategies as st

from sitl_stub.vehicle import (HOLD, Control, Demand, Limits, TruthState, initial_odometry,
                               position_demand, steer, step_odometry, step_truth, velocity_demand)
from sitl_stub.world import wrap_pi

LIMITS = Limits(max_turn_rate_rad_s=math.radians(30.0), max_accel_mps2=2.5)
DT = 0.1


def test_step_truth_follows_the_paper_equations():
    s = TruthState(north_m=20.0, east_m=0.0, yaw_rad=0.0, speed_mps=5.0)
    out = step_truth(s, Control(speed_mps=5.0, yaw_change_rad=0.1), DT)
    assert out.yaw_rad == pytest.approx(0.1)
    assert out.north_m == pytest.approx(20.0 + 5.0 * DT * math.cos(0.1))
    assert out.east_m == pytest.approx(5.0 * DT * math.sin(0.1))
    assert out.speed_mps == 5.0


def test_turn_rate_is_limited():
    # asked to turn 90 degrees right at once: 30 deg/s * 0.1 s = 3 degrees per step
    c = steer(Demand(speed_mps=5.0, yaw_rad=math.pi / 2), 0.0, 5.0, LIMITS, DT)
    assert c.yaw_change_rad == pytest.approx(math.radians(3.0))
    c = steer(Demand(speed_mps=5.0, yaw_rad=-math.pi / 2), 0.0, 5.0, LIMITS, DT)
    assert c.yaw_change_rad == pytest.approx(-math.radians(3.0))
    # a commanded yaw rate tightens the limit
    c = steer(Demand(speed_mps=5.0, yaw_rad=math.pi / 2, turn_rate_limit_rad_s=math.radians(10)),
              0.0, 5.0, LIMITS, DT)
    assert c.yaw_change_rad == pytest.approx(math.radians(1.0))


def test_turn_takes_the_short_way_across_pi():
    c = steer(Demand(speed_mps=0.0, yaw_rad=math.radians(-179)), math.radians(179), 0.0, LIMITS, DT)
    assert c.yaw_change_rad > 0   # 2 degrees clockwise, not 358 anticlockwise
    assert c.yaw_change_rad == pytest.approx(math.radians(2.0))


def test_acceleration_is_limited_both_ways():
    c = steer(Demand(speed_mps=5.0), 0.0, 0.0, LIMITS, DT)
    assert c.speed_mps == pytest.approx(0.25)
    c = steer(HOLD, 0.0, 5.0, LIMITS, DT)
    assert c.speed_mps == pytest.approx(4.75)
    c = steer(HOLD, 0.0, 0.1, LIMITS, DT)
    assert c.speed_mps == 0.0          # never negative


def test_stop_from_cruise_takes_speed_over_accel():
    s = TruthState(0.0, 0.0, 0.0, 5.0)
    steps = 0
    while s.speed_mps > 0:
        s = step_truth(s, steer(HOLD, s.yaw_rad, s.speed_mps, LIMITS, DT), DT)
        steps += 1
    assert steps == round(5.0 / 2.5 / DT)
    assert s.north_m == pytest.approx(sum(5.0 - 0.25 * k for k in range(1, steps + 1)) * DT)


@given(st.floats(-100, 100), st.floats(-100, 100))
def test_wrap_pi_range(a, b):
    w = wrap_pi(a - b)
    assert -math.pi < w <= math.pi
    assert math.isclose(math.cos(w), math.cos(a - b), abs_tol=1e-9)


def test_odometry_equals_truth_without_noise():
    s = TruthState(20.0, 0.0, 0.3, 0.0)
    o = initial_odometry(s)
    for k in range(200):
        d = Demand(speed_mps=5.0, yaw_rad=math.sin(k / 20.0))
        c = steer(d, o.yaw_rad, s.speed_mps, LIMITS, DT)
        s = step_truth(s, c, DT)
        o = step_odometry(o, c.yaw_change_rad, c.speed_mps, 0.0, 0.0, DT)
    assert o.north_m == pytest.approx(s.north_m, abs=1e-9)
    assert o.east_m == pytest.approx(s.east_m, abs=1e-9)
    assert o.yaw_rad == pytest.approx(s.yaw_rad, abs=1e-12)


def test_odometry_reports_noisy_rates_and_velocity_along_reported_yaw():
    o = initial_odometry(TruthState(0.0, 0.0, 0.0, 0.0))
    o = step_odometry(o, 0.01, 5.0, 0.2, 0.002, DT)
    assert o.speed_mps == pytest.approx(5.2)
    assert o.yaw_rate_rad_s == pytest.approx(0.012 / DT)
    assert o.yaw_rad == pytest.approx(0.012)
    assert o.vel_north_mps == pytest.approx(5.2 * math.cos(0.012))
    assert o.vel_east_mps == pytest.approx(5.2 * math.sin(0.012))
    assert o.north_m == pytest.approx(5.2 * math.cos(0.012) * DT)


def test_odometry_drift_statistics_match_q():
    """Straight flight: after N steps the heading error is a sum of N N(0, sh^2) draws and the
    along-track error a sum of N N(0, ss^2) draws times dt. Check both variances (Monte Carlo)."""
    rng = np.random.default_rng(3)
    runs, steps = 400, 100
    ss, sh = 0.3, math.radians(0.5)
    yaw_err = np.empty(runs)
    along_err = np.empty(runs)
    for r in range(runs):
        o = initial_odometry(TruthState(0.0, 0.0, 0.0, 0.0))
        for _ in range(steps):
            o = step_odometry(o, 0.0, 5.0, rng.normal(0, ss), rng.normal(0, sh), DT)
        yaw_err[r] = o.yaw_rad
        along_err[r] = o.north_m - 5.0 * DT * steps
    # sample variance / true variance ~ chi2(runs-1)/(runs-1): +-25% is > 3.5 sigma for 400 runs
    assert np.var(yaw_err, ddof=1) / (steps * sh**2) == pytest.approx(1.0, abs=0.25)
    assert np.var(along_err, ddof=1) / (steps * (ss * DT) ** 2) == pytest.approx(1.0, abs=0.25)
    assert abs(np.mean(yaw_err)) < 4 * math.sqrt(steps) * sh / math.sqrt(runs)


def test_velocity_demand_follows_velocity_direction_not_yaw():
    d = velocity_demand(0.0, 5.0, yaw_rad=0.0, yaw_rate_rad_s=None)
    assert d.speed_mps == pytest.approx(5.0)
    assert d.yaw_rad == pytest.approx(math.pi / 2)
    hover = velocity_demand(0.0, 0.0, yaw_rad=1.0, yaw_rate_rad_s=None)
    assert hover.speed_mps == 0.0 and hover.yaw_rad == 1.0
    spin = velocity_demand(0.0, 0.0, yaw_rad=None, yaw_rate_rad_s=0.2)
    assert spin.yaw_rate_rad_s == 0.2


def test_position_demand_flies_to_the_point_and_stops():
    s = TruthState(0.0, 0.0, 0.0, 0.0)
    o = initial_odometry(s)
    for _ in range(600):
        d = position_demand(o.north_m, o.east_m, 30.0, 20.0, o.yaw_rad, 10.0, 2.5)
        c = steer(d, o.yaw_rad, s.speed_mps, LIMITS, DT)
        s = step_truth(s, c, DT)
        o = step_odometry(o, c.yaw_change_rad, c.speed_mps, 0.0, 0.0, DT)
    assert math.hypot(s.north_m - 30.0, s.east_m - 20.0) < 0.5
    assert s.speed_mps == 0.0
