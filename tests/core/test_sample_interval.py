"""The interval the link delivers where a rate was assumed (issue 32: a ground station sets the
streams to 4 or 2 Hz): core/sample_interval.py, and the navigator's multicopter turn over a long
interval (the autopilot's yaw difference, not the yaw rate at its end)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from companion.core.estimation.slam_types import AssociationGates, VelocityNoise
from companion.core.estimator_options import EstimatorOptions
from companion.core.navigation.navigator import Navigator
from companion.core.sample_interval import (MeanInterval, at_least_reference_s,
                                            interval_turn_rate, long_interval,
                                            setpoint_interval_s)
from tests.core.test_ekf_slam import NOISE          # reference_dt_s 0.1
from tests.core.test_navigator_timing import PARAMS


def test_the_reference_stays_unless_the_measured_interval_is_clearly_longer():
    assert at_least_reference_s(None, 0.1) == 0.1
    assert at_least_reference_s(0.3 - 0.2, 0.1) == 0.1         # 0.09999999999999998
    assert at_least_reference_s(0.1000000000000001, 0.1) == 0.1  # the same floats at 10 Hz
    assert at_least_reference_s(0.05, 0.1) == 0.1
    assert at_least_reference_s(0.25, 0.1) == 0.25
    assert not long_interval(0.2 - 0.1, 0.1) and long_interval(0.2, 0.1)


def test_a_setpoint_stands_for_the_time_since_the_last_one_within_bounds():
    assert setpoint_interval_s(5.0, None, 0.1, 0.5) == 0.1
    assert setpoint_interval_s(5.1, 5.0, 0.1, 0.5) == 0.1
    assert setpoint_interval_s(5.25, 5.0, 0.1, 0.5) == pytest.approx(0.25)
    assert setpoint_interval_s(9.0, 5.0, 0.1, 0.5) == 0.5          # after a gap: capped
    assert setpoint_interval_s(9.0, 5.0, 0.1, 0.05) == 0.1         # the cap is never below


def test_the_mean_interval_of_a_4_hz_stream_on_a_10_hz_clock():
    mean = MeanInterval(samples=4)
    assert mean.mean_s is None
    for dt in (0.1, 0.1, 0.2, 0.3, 0.2, 0.3, 0.0, -1.0, math.nan):
        mean.add(dt)
    assert mean.mean_s == pytest.approx(0.25)                      # the last four, bad ones out
    with pytest.raises(ValueError):
        MeanInterval(samples=0)


def test_the_turn_over_a_long_interval_is_the_yaw_difference_wrapped():
    rate, var = interval_turn_rate(math.radians(179.0), math.radians(-177.0), 0.25,
                                   math.radians(2.0))
    assert rate == pytest.approx(math.radians(4.0) / 0.25)
    assert var == pytest.approx(2.0 * math.radians(2.0) ** 2)


def stop_go_turn(rate_hz: float, seconds: float = 6.0) -> tuple[float, float]:
    """A multicopter turning at 24 deg/s in the autopilot's yaw but whose yaw rate samples read
    0 (it reaches each setpoint's yaw and stops before the sample, as the stub did at 4 Hz
    behind MAVProxy). Returns the navigator's final yaw error (deg) and its yaw sigma (deg)."""
    nav = Navigator(np.zeros(3), np.diag([1e-4, 1e-4, math.radians(2.0) ** 2]), NOISE,
                    gates=AssociationGates(), params=PARAMS, goal=np.array([100.0, 0.0]),
                    options=EstimatorOptions(motion_model="velocity_ned",
                                             velocity_noise=VelocityNoise(0.1, 0.1,
                                                                          math.radians(3.0))))
    steps = int(round(seconds * rate_hz))
    for k in range(steps + 1):
        t = k / rate_hz
        nav.on_velocity(t, 5.0, 0.0, math.radians(24.0) * t, 0.0)
    error = math.degrees(float(nav.slam.pose[2]) - math.radians(24.0) * seconds)
    return error, math.degrees(math.sqrt(float(nav.slam.pose_cov[2, 2])))


def test_at_4_hz_a_stop_go_turn_is_followed_by_the_autopilot_yaw():
    error, sigma = stop_go_turn(4.0)
    assert abs(error) < 0.5, error
    assert abs(error) < 3.0 * sigma


def test_at_the_reference_rate_the_yaw_rate_sample_is_used_as_before():
    # at 10 Hz the rate (0 here) drives the yaw and the yaw samples only correct it: the filter
    # lags the turn (what keeps the 10 Hz flights identical; there the rate is the interval's)
    error, _ = stop_go_turn(10.0)
    assert error < -3.0, error
