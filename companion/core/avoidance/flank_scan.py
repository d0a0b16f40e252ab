"""Look at the flanks: a camera fixed to the nose sees only where the vehicle flies.

A mover that crosses the way on a near-collision course is seen, from a vehicle flying straight,
at a constant bearing: with the traffic worlds' movers (3 to 5 m/s, 10 to 40 degrees from square
toward the vehicle) 15 to 42 degrees off the course. Passing a few metres behind the vehicle, or
after a swerve round a post, that bearing is 45 to 60 degrees: just outside a 90 degree camera,
and the mover is never seen (issue 16, traffic seeds 8, 13, 27, 75, 99). The guidance only knows
what the camera has looked at, so it looks: the directions ``margin`` beyond either edge of the
view around the way the vehicle means to fly (the flanks) must each have been in view for
``dwell_frames`` camera frames within the last ``period_s``; when one has not, the heading swings
toward it by ``margin`` plus a little (the flank then lies inside the view) until it has, if that
heading is as free and flyable as the one it replaces (velocity_choice.py checks).

Judged in world directions from the camera's own frames (their yaw), so a swing that brings a
flank into view counts, whatever the decisions in between chose. Only a heading already in view
is swung (not a turn in place), and the look is given up after ``max_look_s`` for a period.

Off by default (avoidance.flank_scan_deg): measured with 20 degrees and 4 s on paper.yaml,
traffic worlds gave 0.98 on seeds 0-99 (0.91 without) but 0.91 on 100-199 (0.93 without) and
0.92 with one collision on 200-299 (0.91, none without): over 300 worlds 0.937 against 0.917,
within what the look's phase alone moves (0.92 to 0.98 on seeds 0-99 by when the first look
comes). Movers it brings into view are often seen 1 to 4 frames, then the look ends and they stay
tentative; dense at 15 m/s passed a post at 9.31 m (seed 70). A mechanism to pair with a
quicker way to take a mover from little evidence, not a fix on its own.

Re-measured on main with the young movers from two sightings (issue 16, round 7), traffic seeds
0-99 / 100-199 / 200-299: off 0.94 / 0.95 / 0.94 (mean 0.943); 20 degrees, 4 s: 0.98 / 0.93 / 0.93
(0.947); 10, 2 s: 0.95 / 0.92 / 0.92; 15, 3 s: 0.95 / 0.93 / 0.94: within the +-0.02 a 100-run rate
moves by chance, fixing some worlds and breaking as many. Why: 16 of the 17 failures without the
scan on the three sets are one geometry (the other, seed 58, weaves round posts). The vehicle is on
a detour (heading 15 to 105 degrees off the goal's direction), 7 to 33 m off the start-goal line,
away from a crossing mover's origin; that mover, on the goal's side, enters the 40 m range 38 to 87
degrees off the nose 5 to 10 s before its closest approach, is seen in 0 or 1 frames and passes
behind (110 to 144 degrees) at 3.5 to 9.5 m. The look it needs is toward the goal's side, where the
obstacle the detour goes round is: its cone blocks the look; a look let through moves the path, and
the new path meets its own mover from a blind flank as often. Even a look timed by the truth
(toward a mover within 40 m, 42 to 70 degrees off the nose, by up to 25 degrees; checked by its
flown path alone) passed 6 of the 17 (4 checked by the cones too; up to 50 degrees, 95 off the
nose: 6). In the 4 others looked into (53, 117, 193, 215) the mover is still seen in 0 to 2 frames
only: the look is refused by its path check (the detour's obstacle) or comes too late, so no
trigger from evidence (a single sighting, a bearing drift) can do much better. Tried and left out
(same sets): looks at the goal's side only, during and for 6 s after a detour (0.90 to 0.94 on the
sets flown); looks checked by their flown path alone, not the cones, with parts down to a quarter
(20 degrees, 4 s: 0.99 / 0.94 / 0.90; 15, 2 s: 0.94 / 0.93 with a collision / 0.90); a steady
triangle weave of the heading (15 degrees, 2 s: 0.94 / 0.92 / 0.91; checked by path alone 0.96 /
0.94 / 0.93); a slower cruise for 6 s after a detour (0.6 of it: 0.91 / 0.91 / 0.87, collisions on
each: at 3 m/s a crossing mover's collision course holds up to 52 degrees off the nose, outside the
view). For scale, the same guidance with a wider camera: 105 degrees 1.00 / 0.96 / 0.97, 120
degrees 1.00 / 0.99 / 1.00; a 60 m range 0.99 on seeds 0-99.
Pure Python; radians, seconds.
"""
from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

from companion.core.geometry import wrap_angle as wrap


@dataclass(frozen=True)
class FlankScanParams:
    fov_rad: float                 # the camera's horizontal field of view
    margin_rad: float              # how far beyond the view's edge a flank lies
    period_s: float                # each flank is looked at within this
    dwell_frames: int = 3          # ... for at least this many frames (a landmark's confirmation)
    inside_rad: float = math.radians(5.0)   # how far inside the view a look puts the flank
    max_look_s: float = 3.0        # a look that has not been flown by then is given up


class FlankScan:
    """The camera frames' yaws, and the look they call for."""

    def __init__(self, params: FlankScanParams) -> None:
        self.params = params
        self._frames: deque[tuple[float, float]] = deque()      # (t, yaw)
        self._look: tuple[int, float] | None = None              # (side, since t)
        self._rest_until = -math.inf                             # after a look given up

    def mark(self, t_s: float, yaw_rad: float) -> None:
        """One camera frame at ``t_s``, the camera pointing along ``yaw_rad``."""
        self._frames.append((t_s, yaw_rad))
        while len(self._frames) > 1 and self._frames[1][0] <= t_s - self.params.period_s:
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

    def look(self, t_s: float, course_rad: float) -> float | None:
        """The heading to fly instead of ``course_rad`` to look at a flank, or None (no look)."""
        p = self.params
        reach = 0.5 * p.fov_rad + p.margin_rad
        stale = []
        for side in (1, -1):
            count, last = self._views(t_s, course_rad + side * reach)
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
            stale.sort()
            self._look = (stale[0][1], t_s)
        side = self._look[0]
        return wrap(course_rad + side * (p.margin_rad + p.inside_rad))
