"""Are the telemetry streams arriving at the rate we asked for? (Pure: time is an argument.)

A router or a ground station may set the vehicle's stream rates behind our back (MAVProxy and
Mission Planner re-request 4 Hz streams periodically). Each stream's rate is measured over
``window_s`` of link time; below ``min_fraction`` of what was asked, it is asked again, at most
``max_reasserts`` times in a row (reset once the rate is back), so a vehicle that cannot deliver
the rate is not flooded with requests; ``gave_up`` then names the streams flown at the rate they
come at (the estimator and the decisions run on whatever odometry rate arrives).
"""
from __future__ import annotations


class StreamRateWatch:
    def __init__(self, asked_hz: dict[int, float], window_s: float, min_fraction: float,
                 max_reasserts: int) -> None:
        self.asked_hz = dict(asked_hz)
        self.window_s = window_s
        self.min_fraction = min_fraction
        self.max_reasserts = max_reasserts
        self.reasserts = 0                       # in total
        self._counts = {msg_id: 0 for msg_id in asked_hz}
        self._in_a_row = {msg_id: 0 for msg_id in asked_hz}
        self._window_start_s: float | None = None
        self.last_measured_hz: dict[int, float] = {}   # over the latest complete window
        self.gave_up: set[int] = set()                  # low and no longer asked again

    def restart(self, t_s: float) -> None:
        """Streams were just (re)requested: measure afresh from ``t_s``."""
        self._window_start_s = t_s
        self._counts = dict.fromkeys(self._counts, 0)

    def on_message(self, msg_id: int) -> None:
        if msg_id in self._counts:
            self._counts[msg_id] += 1

    def measured_hz(self, t_s: float) -> dict[int, float]:
        span = t_s - self._window_start_s if self._window_start_s is not None else 0.0
        return {m: (c / span if span > 0 else 0.0) for m, c in self._counts.items()}

    def check(self, t_s: float) -> list[int]:
        """At the end of a window: the streams to ask for again (maybe none); starts a new window."""
        if self._window_start_s is None:
            self.restart(t_s)
            return []
        if t_s - self._window_start_s < self.window_s:
            return []
        rates = self.measured_hz(t_s)
        self.last_measured_hz = rates
        again = []
        for msg_id, rate in rates.items():
            if rate >= self.min_fraction * self.asked_hz[msg_id]:
                self._in_a_row[msg_id] = 0
                self.gave_up.discard(msg_id)
            elif self._in_a_row[msg_id] < self.max_reasserts:
                self._in_a_row[msg_id] += 1
                self.reasserts += 1
                again.append(msg_id)
            else:
                self.gave_up.add(msg_id)
        self.restart(t_s)
        return again
