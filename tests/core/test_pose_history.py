"""The pose at a depth frame's capture from the estimator's history: interpolated, the motion
since then in the level frame at capture, refused outside the history."""
import math

import pytest

from companion.core.perception.pose_history import PoseHistory


def test_motion_since_a_capture_between_two_estimates():
    history = PoseHistory(span_s=1.0)
    history.add(10.0, 0.0, 0.0, math.radians(90.0), 10.0)     # facing east
    history.add(10.2, 0.0, 2.0, math.radians(100.0), 11.0)
    motion = history.motion_since(10.1)                      # halfway: east 1 m, yaw 95 deg
    assert motion.forward_m == pytest.approx(math.cos(math.radians(5.0)), abs=1e-9)
    assert motion.right_m == pytest.approx(-math.sin(math.radians(5.0)), abs=1e-9)
    assert motion.yaw_rad == pytest.approx(math.radians(5.0))
    assert motion.down_m == pytest.approx(-0.5)              # climbed half a metre since


def test_a_capture_outside_the_history_is_refused():
    history = PoseHistory(span_s=0.5)
    for i in range(20):
        history.add(0.1 * i, 0.0, 0.0, 0.0)
    assert history.motion_since(0.5) is None                  # older than the span
    assert history.motion_since(2.5) is None                  # in the future
    assert history.motion_since(1.9).forward_m == 0.0


def test_yaw_interpolates_the_short_way_round():
    history = PoseHistory()
    history.add(0.0, 0.0, 0.0, math.radians(179.0))
    history.add(1.0, 0.0, 0.0, math.radians(-179.0))
    assert abs(history.at(0.5)[2]) == pytest.approx(math.pi, abs=1e-9)


def test_a_capture_just_after_the_latest_estimate_is_extrapolated_within_the_bound():
    history = PoseHistory(span_s=1.0, extrapolate_s=0.25)
    history.add(0.0, 0.0, 0.0, 0.0, 10.0)
    history.add(0.1, 0.5, 0.0, 0.02, 10.1)           # 5 m/s north, turning
    n, e, yaw, alt = history.at(0.15)
    assert (n, e, alt) == pytest.approx((0.75, 0.0, 10.15))
    assert yaw == pytest.approx(0.03)                # the estimates' own turn carried on ...
    assert history.at(0.15, yaw_rate_rad_s=-0.4)[2] == pytest.approx(0.0, abs=1e-12)  # or the gyro
    motion = history.motion_since(0.15, yaw_rate_rad_s=-0.4)
    assert motion.forward_m < 0.0                    # the capture is ahead of the latest estimate
    assert history.at(0.4) is None                   # beyond the bound
