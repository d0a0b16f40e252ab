"""TIMESYNC (MAVLink message 111) with the autopilot: our Unix clock against its time since boot.

Why: a camera may stamp its obstacle reports in Unix time (OBSTACLE_DISTANCE allows it). Without
help, ``EpochCamera`` maps them to vehicle time by the offset seen on the first such frame, which
carries that frame's transport and queueing delay for the whole flight. A camera on the companion
computer (USB, the common case) stamps with this computer's clock, so what the mapping needs is
this computer's Unix clock against the autopilot's clock: exactly what TIMESYNC measures.

The protocol (mavlink.io, services/timesync; ArduPilot's GCS_MAVLINK::handle_timesync): a request
carries tc1 = 0 and ts1 = the requester's time in ns; the reply mirrors ts1 and puts the
responder's time in tc1 (ArduPilot: its micros64() since boot x 1000). With the reply received at
our time r: round trip r - ts1, and the autopilot's clock read tc1 at about our (ts1 + r) / 2, so
offset = tc1 - (ts1 + r) / 2 (vehicle ns minus our ns), uncertain by at most half the round trip.
The sample of the shortest round trip among the recent ones is kept (the least queueing).

Pure: times come in as arguments (ns).
"""
from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

MAX_PENDING = 8            # requests awaiting a reply (older ones are forgotten)
KEPT_SAMPLES = 16          # the best of the last this many replies is used
MAX_ROUND_TRIP_NS = 500_000_000   # a reply later than this says nothing useful


@dataclass(frozen=True)
class SyncSample:
    """One answered request: ``offset_ns`` = vehicle clock minus ours, ``round_trip_ns``."""
    offset_ns: int
    round_trip_ns: int


class TimeSync:
    """Our requests and the autopilot's replies (see the module docstring)."""

    def __init__(self) -> None:
        self._pending: deque[int] = deque(maxlen=MAX_PENDING)
        self._samples: deque[SyncSample] = deque(maxlen=KEPT_SAMPLES)
        self.replies = 0
        self.refused = 0

    def request(self, now_ns: int) -> int:
        """The ts1 of a new request sent at ``now_ns`` (our clock)."""
        ts1 = int(now_ns)
        self._pending.append(ts1)
        return ts1

    def on_reply(self, tc1_ns: int, ts1_ns: int, now_ns: int) -> SyncSample | None:
        """A TIMESYNC from the autopilot with tc1 != 0, received at ``now_ns``; None: not an
        answer to one of our requests, or too late to be of use."""
        if ts1_ns not in self._pending or tc1_ns <= 0:
            self.refused += 1
            return None
        self._pending.remove(ts1_ns)
        round_trip = int(now_ns) - int(ts1_ns)
        if not 0 <= round_trip <= MAX_ROUND_TRIP_NS:
            self.refused += 1
            return None
        sample = SyncSample(int(tc1_ns) - (int(ts1_ns) + int(now_ns)) // 2, round_trip)
        self._samples.append(sample)
        self.replies += 1
        return sample

    def best(self) -> SyncSample | None:
        """The kept sample with the shortest round trip, or None before any reply."""
        return min(self._samples, key=lambda s: s.round_trip_ns) if self._samples else None

    def vehicle_time_s(self, unix_s: float) -> float | None:
        """Vehicle time (s since boot) at our Unix time ``unix_s``; None before any reply."""
        best = self.best()
        if best is None or not math.isfinite(unix_s):
            return None
        return unix_s + best.offset_ns * 1e-9

    def forget(self) -> None:
        """The vehicle rebooted: its clock restarted, the samples are stale."""
        self._pending.clear()
        self._samples.clear()
