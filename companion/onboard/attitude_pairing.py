"""Odometry's yaw: each LOCAL_POSITION_NED paired with the ATTITUDE of its own time.

The position waits (is held) for the ATTITUDE of the same time_boot_ms until that attitude or
the next position arrives; then it takes the latest earlier ATTITUDE, its yaw carried forward by
its yaw rate over the gap (at most ``max_attitude_age_s``, else no yaw: the sample is skipped).
Pure: the pipeline feeds the messages and processes the positions this hands back, in order.
"""
from __future__ import annotations

import math
from collections import deque

from companion.core.geometry import wrap_angle
from companion.mavlink import codec

PLAUSIBLE_YAW_RATE_RAD_S = 20.0  # ArduCopter's fastest yaw is well under 10 rad/s
ATTITUDE_HISTORY = 32
TIME_EPS_S = 1e-6


def plausible_attitude(att: codec.Attitude) -> bool:
    """A finite yaw within two turns and a finite yaw rate a multicopter can have."""
    return (math.isfinite(att.yaw_rad) and abs(att.yaw_rad) <= 2.0 * math.pi
            and math.isfinite(att.yaw_rate_rad_s)
            and abs(att.yaw_rate_rad_s) <= PLAUSIBLE_YAW_RATE_RAD_S)


class AttitudePairing:
    """The recent ATTITUDEs, the position waiting for its own, the yaw rate last used."""

    def __init__(self) -> None:
        self.attitudes: deque[codec.Attitude] = deque(maxlen=ATTITUDE_HISTORY)
        self.held: codec.LocalPosition | None = None
        self.yaw_rate_rad_s = 0.0                  # of the ATTITUDE the last yaw came from

    def add(self, att: codec.Attitude) -> codec.LocalPosition | None:
        """A plausible ATTITUDE; returns the held position it now covers (no longer held)."""
        self.attitudes.append(att)
        held = self.held
        if held is not None and att.t_s >= held.t_s - TIME_EPS_S:
            self.held = None
            return held
        return None

    def take_held(self) -> codec.LocalPosition | None:
        """The position still waiting (a new position has come: it waits no longer)."""
        held, self.held = self.held, None
        return held

    def covers(self, t_s: float) -> bool:
        """The latest ATTITUDE is not older than ``t_s``: a position at t_s can be paired now."""
        return bool(self.attitudes) and self.attitudes[-1].t_s >= t_s - TIME_EPS_S

    def hold(self, lpn: codec.LocalPosition) -> None:
        self.held = lpn

    def yaw_at(self, t_s: float, max_age_s: float) -> float | None:
        """Yaw at t_s from the latest ATTITUDE not after it, carried forward by its yaw rate."""
        for att in reversed(self.attitudes):
            if att.t_s <= t_s + TIME_EPS_S:
                gap = t_s - att.t_s
                if gap > max_age_s:
                    return None
                rate = att.yaw_rate_rad_s
                self.yaw_rate_rad_s = rate
                return wrap_angle(att.yaw_rad + rate * max(gap, 0.0))
        return None

    def latest_yaw_rad(self) -> float | None:
        return self.attitudes[-1].yaw_rad if self.attitudes else None

    def clear(self) -> None:
        """The estimate restarts: no attitude history, no position waiting."""
        self.attitudes.clear()
        self.held = None
