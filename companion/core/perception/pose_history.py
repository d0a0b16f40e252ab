"""The estimator's recent poses, to place a depth frame where the vehicle was when it was captured.

A frame is captured at ``t_capture_s`` (the vehicle's clock: the stub's time_boot_ms natively, a
camera's host time mapped through the service's time sync) and perceived later, when the
estimate is at ``t_now_s``. Its points are in the level frame at capture; ``motion_since`` gives
how the vehicle moved from the capture to now (core/perception/depth_perception.MotionSince), from
the estimates kept here, interpolated at the capture (linear in position, shortest way in yaw). A capture after the latest estimate by
at most ``extrapolate_s`` (a frame handled before the odometry sample of its time: lock-step
hands the frames of a step over before the step's position) is placed by the last two estimates'
rates carried forward, the yaw by the autopilot's yaw rate where the caller gives it (ATTITUDE's
yawspeed: a gyro's, where two estimates' difference carries their noise, and a step's turn). A capture older than the history, or later than that, is refused (None):
the caller counts it.
"""
from __future__ import annotations

import math
from collections import deque

from companion.core.geometry import wrap_angle
from companion.core.perception.depth_perception import MotionSince


class PoseHistory:
    """The last ``span_s`` of estimated poses (north_m, east_m, yaw_rad) and altitudes."""

    def __init__(self, span_s: float = 1.0, extrapolate_s: float = 0.0) -> None:
        if span_s <= 0.0 or extrapolate_s < 0.0:
            raise ValueError(f"span_s must be > 0 and extrapolate_s >= 0, got {span_s}, "
                             f"{extrapolate_s}")
        self.span_s = span_s
        self.extrapolate_s = extrapolate_s
        self._poses: deque[tuple[float, float, float, float, float]] = deque()

    def add(self, t_s: float, north_m: float, east_m: float, yaw_rad: float,
            altitude_m: float = 0.0) -> None:
        """An estimate at ``t_s`` (not earlier than the last one added: an older one is
        ignored)."""
        if self._poses and t_s < self._poses[-1][0]:
            return
        self._poses.append((t_s, north_m, east_m, yaw_rad, altitude_m))
        while self._poses and self._poses[0][0] < t_s - self.span_s:
            self._poses.popleft()

    @property
    def latest_t_s(self) -> float | None:
        return self._poses[-1][0] if self._poses else None

    def clear(self) -> None:
        self._poses.clear()

    def at(self, t_s: float, yaw_rate_rad_s: float | None = None
           ) -> tuple[float, float, float, float] | None:
        """(north_m, east_m, yaw_rad, altitude_m) interpolated at ``t_s`` (extrapolated up to
        ``extrapolate_s`` past the latest, the yaw by ``yaw_rate_rad_s`` if given), None
        outside."""
        poses = self._poses
        if not poses or t_s < poses[0][0] - 1e-9:
            return None
        if t_s > poses[-1][0] + 1e-9:
            return self._extrapolated(t_s, yaw_rate_rad_s)
        for (t0, n0, e0, y0, a0), (t1, n1, e1, y1, a1) in zip(poses, list(poses)[1:]):
            if t0 <= t_s <= t1:
                w = 0.0 if t1 <= t0 else (t_s - t0) / (t1 - t0)
                return (n0 + w * (n1 - n0), e0 + w * (e1 - e0),
                        wrap_angle(y0 + w * wrap_angle(y1 - y0)), a0 + w * (a1 - a0))
        _, n, e, y, a = poses[-1]
        return n, e, y, a

    def _extrapolated(self, t_s: float, yaw_rate_rad_s: float | None
                      ) -> tuple[float, float, float, float] | None:
        t1, n1, e1, y1, a1 = self._poses[-1]
        if t_s > t1 + self.extrapolate_s + 1e-9:
            return None
        yaw = None if yaw_rate_rad_s is None else wrap_angle(y1 + yaw_rate_rad_s * (t_s - t1))
        if len(self._poses) < 2 or self._poses[-2][0] >= t1:
            return n1, e1, y1 if yaw is None else yaw, a1
        t0, n0, e0, y0, a0 = self._poses[-2]
        w = (t_s - t1) / (t1 - t0)
        if yaw is None:
            yaw = wrap_angle(y1 + w * wrap_angle(y1 - y0))
        return n1 + w * (n1 - n0), e1 + w * (e1 - e0), yaw, a1 + w * (a1 - a0)

    def motion_since(self, t_capture_s: float, yaw_rate_rad_s: float | None = None) -> MotionSince | None:
        """How the vehicle moved from ``t_capture_s`` to the latest estimate, in the level frame
        at capture (forward, right, down), and the heading's change; None if the capture lies
        outside the history."""
        then = self.at(t_capture_s, yaw_rate_rad_s)
        if then is None:
            return None
        _, n1, e1, y1, a1 = self._poses[-1]
        n0, e0, y0, a0 = then
        c, s = math.cos(y0), math.sin(y0)
        dn, de = n1 - n0, e1 - e0
        return MotionSince(c * dn + s * de, -s * dn + c * de, a0 - a1, wrap_angle(y1 - y0))
