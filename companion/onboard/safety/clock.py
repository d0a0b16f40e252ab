"""The vehicle's clock (time since boot, carried by its messages) and reboot detection.

One stamp is never evidence. A message whose time lies outside
[latest - behind_tolerance_s, latest + ahead_window_s] is refused (counted by the caller) and
starts, or adds to, a *candidate* clock. The candidate is adopted only when
``evidence_messages`` consecutive autopilot messages agree on it (each within the same window of
the one before); going back (a reboot) also needs a heartbeat of the vehicle after the first of
them. Any autopilot message on the current clock in between drops the candidate. Camera frames
are judged against the clock but are never evidence (the camera may not reboot with the
autopilot, and it is the easier one to fake).

A camera may stamp OBSTACLE_DISTANCE.time_usec in Unix time (the spec allows it). Such a stamp
(after 2001) cannot be a time since boot; it is mapped to vehicle time by the offset seen on
the first one (:class:`EpochCamera`).
"""
from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass
from typing import Any

EPOCH_THRESHOLD_S = 1e9          # 2001-09-09 in Unix time; 31 years since boot is not a boot time
HELD_ITEMS = 256                 # messages kept while a candidate clock awaits its evidence


@dataclass(frozen=True)
class ClockLimits:
    behind_tolerance_s: float = 1.0    # reordering is accepted within this
    ahead_window_s: float = 1.0        # a step ahead beyond this needs evidence
    evidence_messages: int = 5         # consecutive autopilot messages on a new clock


@dataclass(frozen=True)
class ClockVerdict:
    accepted: bool
    reason: str     # 'ok'; refused: 'not_finite', 'behind', 'ahead'; adopted: 'reboot', 'jump'
    held: tuple = ()   # adopted: the items refused on the new clock, in order, to handle again


class VehicleClock:
    """The latest believed vehicle time, and the evidence for a new one."""

    def __init__(self, limits: ClockLimits = ClockLimits()) -> None:
        self.limits = limits
        self.latest_t_s: float | None = None
        self._candidate: _Candidate | None = None
        self._held: deque[Any] = deque(maxlen=HELD_ITEMS)

    @property
    def candidate_pending(self) -> bool:
        return self._candidate is not None

    def on_autopilot(self, t_s: float, item: Any = None) -> ClockVerdict:
        """A stamp of the autopilot's ATTITUDE or LOCAL_POSITION_NED; ``item`` (the message) is
        kept if refused on a candidate clock.

        Adopting a new clock ('reboot', 'jump') sets ``latest_t_s`` to the first stamp of the
        evidence and returns the kept items, so that the caller handles them again in order
        (then :meth:`settle` on the adopting stamp).
        """
        if not math.isfinite(t_s):
            return ClockVerdict(False, "not_finite")
        where = self._place(t_s)
        if where == "ok":
            self.latest_t_s = t_s if self.latest_t_s is None else max(self.latest_t_s, t_s)
            self._drop_candidate()
            return ClockVerdict(True, "ok")
        cand = self._candidate
        if cand is None or cand.direction != where or not self._near(cand.last_t_s, t_s):
            self._drop_candidate()
            cand = self._candidate = _Candidate(where, t_s)
        else:
            cand.add(t_s)
        if cand.count >= self.limits.evidence_messages and (where == "ahead" or cand.heartbeat):
            held = tuple(self._held)
            self._drop_candidate()
            self.latest_t_s = cand.first_t_s
            return ClockVerdict(True, "reboot" if where == "behind" else "jump", held)
        if item is not None:
            self._held.append(item)
        return ClockVerdict(False, where)

    def _drop_candidate(self) -> None:
        self._candidate = None
        self._held.clear()

    def settle(self, t_s: float) -> None:
        """After an adopted clock's evidence was handled again: the adopting stamp is the latest."""
        self.latest_t_s = t_s if self.latest_t_s is None else max(self.latest_t_s, t_s)

    def on_vehicle_heartbeat(self) -> None:
        if self._candidate is not None:
            self._candidate.heartbeat = True

    def check_frame(self, t_s: float, item: Any = None) -> ClockVerdict:
        """A camera frame's stamp (already in vehicle time): never evidence for a new clock. A
        refused frame that agrees with the candidate clock is kept with its evidence."""
        if not math.isfinite(t_s):
            return ClockVerdict(False, "not_finite")
        where = self._place(t_s)
        cand = self._candidate
        if where != "ok" and item is not None and cand is not None \
                and self._near(cand.last_t_s, t_s):
            self._held.append(item)
        return ClockVerdict(where == "ok", where)

    def _place(self, t_s: float) -> str:
        if self.latest_t_s is None:
            return "ok"
        if t_s < self.latest_t_s - self.limits.behind_tolerance_s:
            return "behind"
        if t_s > self.latest_t_s + self.limits.ahead_window_s:
            return "ahead"
        return "ok"

    def _near(self, reference_s: float, t_s: float) -> bool:
        return (reference_s - self.limits.behind_tolerance_s <= t_s
                <= reference_s + self.limits.ahead_window_s)


class _Candidate:
    def __init__(self, direction: str, t_s: float) -> None:
        self.direction = direction
        self.first_t_s = self.last_t_s = t_s
        self.count = 1
        self.heartbeat = False

    def add(self, t_s: float) -> None:
        self.count += 1
        self.last_t_s = max(self.last_t_s, t_s)


class EpochCamera:
    """Maps a camera's Unix-time stamps to vehicle time by the offset seen on the first one."""

    def __init__(self) -> None:
        self.offset_s: float | None = None

    @staticmethod
    def is_epoch(t_s: float) -> bool:
        return math.isfinite(t_s) and t_s >= EPOCH_THRESHOLD_S

    def to_vehicle_time(self, t_s: float, vehicle_now_s: float | None) -> float | None:
        """Vehicle time of a Unix-time stamp; None while the vehicle's clock is unknown.

        The offset includes the camera-to-us latency of that first frame: a few tens of ms,
        well inside the clock's window.
        """
        if self.offset_s is None:
            if vehicle_now_s is None:
                return None
            self.offset_s = t_s - vehicle_now_s
        return t_s - self.offset_s

    def forget(self) -> None:
        self.offset_s = None
