"""The interval the link actually delivers, where a rate was assumed (issue 32). Pure.

The service is tuned at 10 Hz odometry, but a ground station on a shared link sets the vehicle's
streams (MAVProxy: 4 Hz, some setups 2 Hz) and the companion's request is overridden. Whatever
was scaled per sample at the configured rate must then be scaled by the interval that came:

- ``setpoint_interval_s``: a setpoint's turn limit (rate x interval) covers the time until the
  next setpoint, which comes with the next odometry sample: at 4 Hz a limit of 30 deg/s x 0.1 s
  per setpoint flies 12 deg/s, the vehicle turning 3 deg and then waiting (stop-go), its yaw
  rate at the sample times near zero while it turns.
- ``MeanInterval``: the mean of the last few odometry intervals, for what accumulates per sample
  (a dead reckoning's random walk) and what depends on how far a frame may be from a sample.
- ``interval_turn_rate``: the multicopter's turn over a long interval, from the autopilot's yaw
  difference rather than the yaw rate at the interval's end.

Both keep the configured (reference) period when the measured one is not clearly longer, so the
same floats come out at the design rate (the interval measured at 10 Hz is 0.1 s give or take a
rounding): flights at the configured rate are unchanged to the bit.
"""
from __future__ import annotations

from collections import deque

from companion.core.geometry import wrap_angle

LONGER_TOLERANCE_S = 1e-3     # a measured interval within this of the reference is the reference


def at_least_reference_s(measured_s: float | None, reference_s: float) -> float:
    """``measured_s`` if it is clearly (``LONGER_TOLERANCE_S``) longer than ``reference_s``,
    else ``reference_s`` (also when nothing was measured yet)."""
    if measured_s is not None and measured_s > reference_s + LONGER_TOLERANCE_S:
        return measured_s
    return reference_s


def long_interval(dt_s: float, reference_s: float) -> bool:
    """Is an odometry interval clearly longer than the reference period (a slowed stream, or
    samples lost)?"""
    return dt_s > reference_s + LONGER_TOLERANCE_S


def interval_turn_rate(yaw_before_rad: float, yaw_after_rad: float, dt_s: float,
                       yaw_white_sigma_rad: float) -> tuple[float, float]:
    """The multicopter's mean yaw rate over an odometry interval longer than the reference, and
    the extra yaw variance (rad^2) of the turn it gives over the whole interval.

    The autopilot's yaw rate sample is the rate at the sample's time; over a long interval it is
    not the interval's: a vehicle that reaches each setpoint's yaw before the next one turns and
    stops within the interval, and its rate at both ends may be zero while it turned 6 deg
    (measured at 4 Hz behind MAVProxy: the filter's yaw 6 deg off the truth in the median, 20 deg
    at the 95th percentile, both static obstacles taken for movers). The autopilot's yaw is its
    gyro's integral, so the change of its yaw between the two samples is the turn; its error is
    the two samples' white parts (``yaw_white_sigma_rad`` each), 2 sigma^2, which the turn
    otherwise taken from the rate does not have (the yaw's slow part cancels in the difference).
    """
    return wrap_angle(yaw_after_rad - yaw_before_rad) / dt_s, 2.0 * yaw_white_sigma_rad ** 2


def setpoint_interval_s(t_s: float, last_t_s: float | None, period_s: float,
                        max_s: float) -> float:
    """The interval a setpoint at ``t_s`` stands for: the time since the previous one
    (``last_t_s``, None: none yet), at least the configured ``period_s`` and at most ``max_s``
    (after a gap, a hold or a lost stream, one setpoint must not carry a whole gap's turn)."""
    if last_t_s is None:
        return period_s
    return min(at_least_reference_s(t_s - last_t_s, period_s), max(max_s, period_s))


class MeanInterval:
    """The mean of the last ``samples`` intervals between successive times (seconds)."""

    def __init__(self, samples: int = 10) -> None:
        if samples < 1:
            raise ValueError(f"samples must be >= 1, got {samples}")
        self._intervals: deque[float] = deque(maxlen=samples)

    def add(self, dt_s: float) -> None:
        """One interval (> 0; others are ignored)."""
        if not dt_s > 0.0:
            return
        self._intervals.append(dt_s)

    @property
    def mean_s(self) -> float | None:
        return sum(self._intervals) / len(self._intervals) if self._intervals else None
