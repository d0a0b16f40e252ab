"""Slowing so that a climb (or a descent) fits: issue 46, "climbing needs time".

A plan that flies over a barrier must reach the barrier's clearance altitude before the vehicle
gets horizontally within d of it. At the cruise speed the way to it may be too short (a 9 m wall
seen 35 m out needs about 35 m to climb 10 m at 5 m/s and 2.5 m/s up); flown slower, or stopped,
it fits. This module gives the time the altitude law takes, and the highest steady speed at which
the horizontal way covered in that time stays short of the grown circle.

- The altitude law (core/avoidance/vertical.py climb_rate_mps): after ``climb_lag_s``, the rate is
  ``gain x error`` within the vertical speed limit. From an error e0 to e1 (e0 > e1 > 0):
  (e0 - k) / limit at the limit while the error exceeds k = limit / gain, then ln(k / e1) / gain.
- The horizontal way: from the speed now v0, the speed changes toward the cap s at the
  acceleration a and then holds s. In time T it covers s T + (v0 - s)^2 / (2 a) when slowing
  (s in [v0 - a T, v0]), or s T - (s - v0)^2 / (2 a) when speeding up (s in [v0, v0 + a T]);
  monotonic in s, so the highest s within a distance D is a root of a quadratic. The direction is
  the worst one, straight at the axis, as vertical.clears assumes: whatever the horizontal law
  then chooses, a row so cleared keeps d vertically.

Pure maths: floats in, floats out.
"""
from __future__ import annotations

import math

STOP_SPEED_MPS = 0.05     # a cap below this is a stop (and a climb in place)


def altitude_time_s(error_m: float, stop_error_m: float, limit_mps: float, gain_per_s: float,
                    lag_s: float) -> float:
    """Time for the altitude law to bring the error toward its target from ``error_m`` down to
    ``stop_error_m`` (both >= 0: distances to the target's altitude), the lag counted; 0 if the
    error is already that small."""
    if error_m <= stop_error_m:
        return 0.0
    knee = limit_mps / gain_per_s
    t = lag_s
    if error_m > knee:
        t += (error_m - max(stop_error_m, knee)) / limit_mps
    if stop_error_m < knee:
        t += math.log(min(error_m, knee) / max(stop_error_m, 1e-9)) / gain_per_s
    return t


def covered_m(time_s: float, speed_now_mps: float, cap_mps: float, accel_mps2: float) -> float:
    """Way covered in ``time_s`` changing speed from ``speed_now_mps`` toward ``cap_mps`` at
    ``accel_mps2``, then holding it (straight)."""
    v0, s, a, t = speed_now_mps, cap_mps, accel_mps2, time_s
    ramp = abs(s - v0) / a
    if t <= ramp:
        return v0 * t + math.copysign(0.5 * a * t * t, s - v0)
    return s * t + math.copysign((s - v0) ** 2 / (2.0 * a), v0 - s)


def fitting_speed_mps(distance_m: float, time_s: float, speed_now_mps: float,
                      accel_mps2: float) -> float | None:
    """The highest steady speed cap s such that the way covered in ``time_s`` (covered_m) is at
    most ``distance_m``; math.inf if any speed fits; None if even stopping at once covers more."""
    d, t, v0, a = distance_m, time_s, max(speed_now_mps, 0.0), accel_mps2
    if t <= 0.0:
        return math.inf
    if d < 0.0:
        return None
    if v0 * t <= d:                     # holding the speed fits: how much faster
        b = v0 + a * t
        disc = b * b - v0 * v0 - 2.0 * a * d
        return math.inf if disc < 0.0 else b - math.sqrt(disc)
    if covered_m(t, v0, 0.0, a) > d:    # even a stop starting now covers more
        return None
    b = v0 - a * t
    disc = max(0.0, b * b - v0 * v0 + 2.0 * a * d)
    return max(0.0, b + math.sqrt(disc))
