"""A multicopter's look scan: the nose (and its camera) turns to the flanks and back, the velocity
untouched.

A mover crossing the way a few metres behind the vehicle holds a bearing of 45 to 60 degrees off
the course: just outside a 90 degree camera that looks where the vehicle flies, so it is never seen,
or seen once at the edge of the view (issue 16, copter traffic seeds 9, 13, 17, 27, 67, 99). A
multicopter's yaw is its own setpoint (look_at.py turns it to a tracked mover out of view); this
turns it to the flanks while nothing is watched. The flank directions ``offset`` less ``inside``
beyond either edge of the view around the flight direction must each have been in view for
``dwell_frames`` camera frames within the last ``period_s``; when one has not, the nose turns to
the flight direction plus or minus ``offset`` (less than half the view: the flight direction stays
in view all the while) until it has, then to the other flank if that is due, then back.

The velocity choice decides as without the scan (the navigator gives it the flight direction as
the pose's yaw while the nose is apart, as for a look-at): only the yaw setpoint changes, and
shape_setpoint turns it within the turn-rate limit. Judged in world directions from the camera's
own frames (their yaw), so a turn of the course that brings a flank into view counts. A look that
has not been seen through within ``max_look_s`` is given up for a period.
Pure Python; radians, seconds.
"""
from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

from companion.core.geometry import wrap_angle as wrap


@dataclass(frozen=True)
class YawScanParams:
    fov_rad: float                 # the camera's horizontal field of view
    offset_rad: float              # the nose this far from the flight direction during a look
    period_s: float                # each flank is looked at within this
    dwell_frames: int = 3          # ... for at least this many frames
    inside_rad: float = math.radians(5.0)   # how far inside the view's edge a look puts the flank
    max_look_s: float = 5.0        # a look not seen through by then is given up for a period
    goal_gain: float | None = None  # experiment: nose = course + gain x (goal - course), capped
    sweep_rad: float | None = None  # experiment: with goal_gain, the sweep's offset when on course

    def __post_init__(self) -> None:
        if not 0.0 < self.fov_rad < 2.0 * math.pi:
            raise ValueError(f"fov_rad {self.fov_rad!r}: a field of view in (0, 2 pi)")
        if not 0.0 < self.offset_rad < 0.5 * self.fov_rad:
            raise ValueError(f"offset_rad {self.offset_rad!r}: in (0, half the field of view), "
                             "so the flight direction stays in view")
        if not (self.period_s > 0.0 and self.max_look_s > 0.0 and self.dwell_frames >= 1
                and 0.0 <= self.inside_rad < self.offset_rad):
            raise ValueError("period_s, max_look_s > 0, dwell_frames >= 1, "
                             "0 <= inside_rad < offset_rad")

    @property
    def flank_rad(self) -> float:
        """How far off the flight direction the flanks lie."""
        return 0.5 * self.fov_rad + self.sweep - self.inside_rad

    @property
    def sweep(self) -> float:
        return self.sweep_rad if self.sweep_rad is not None else self.offset_rad


class YawScan:
    """The camera frames' yaws, and the nose's look they call for."""

    def __init__(self, params: YawScanParams) -> None:
        self.params = params
        self._frames: deque[tuple[float, float]] = deque()      # (t, camera yaw)
        self._look: tuple[int, float] | None = None              # (side, since t)
        self._rest_until = -math.inf                             # after a look given up

    def mark(self, t_s: float, yaw_rad: float) -> None:
        """One camera frame at ``t_s``, the camera pointing along ``yaw_rad``."""
        self._frames.append((t_s, yaw_rad))
        while self._frames and self._frames[0][0] < t_s - self.params.period_s:
            self._frames.popleft()

    def _views(self, t_s: float, direction: float) -> tuple[int, float]:
        """Frames within the period that had ``direction`` in view, and the last one's time."""
        half = 0.5 * self.params.fov_rad
        count, last = 0, -math.inf
        for t, yaw in self._frames:
            if t >= t_s - self.params.period_s and abs(wrap(direction - yaw)) <= half:
                count += 1
                last = t
        return count, last

    def stop(self) -> None:
        """No look now (the nose is wanted elsewhere, or the vehicle is not flying steadily)."""
        self._look = None

    def toward_goal(self, course_rad: float, goal_heading_rad: float) -> float | None:
        """The nose turned from the course toward the goal's direction (the side the vehicle swerved
        away from), by gain times the swerve, at most ``offset``."""
        p = self.params
        swerve = wrap(goal_heading_rad - course_rad)
        turn = max(-p.offset_rad, min(p.offset_rad, p.goal_gain * swerve))
        return wrap(course_rad + turn) if abs(turn) > 1e-3 else None

    def look(self, t_s: float, course_rad: float) -> float | None:
        """The yaw to point the nose at instead of ``course_rad`` (the flight direction), or None."""
        p = self.params
        stale = []
        for side in (1, -1):
            count, last = self._views(t_s, course_rad + side * p.flank_rad)
            if count < p.dwell_frames:
                stale.append((last, side))
        if self._look is not None:
            side, since = self._look
            if t_s - since > p.max_look_s:
                self._look = None           # given up: fly on for a period
                self._rest_until = t_s + p.period_s
            elif all(s != side for _, s in stale):
                self._look = None           # looked: the other flank may be next
        if self._look is None:
            if not stale or not self._frames or t_s < self._rest_until:
                return None
            stale.sort()                    # the flank seen longest ago first
            self._look = (stale[0][1], t_s)
        return wrap(course_rad + self._look[0] * p.sweep)
