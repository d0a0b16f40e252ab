"""The parameter list at a radio's pace (pure: time is an argument).

A ground station's PARAM_REQUEST_LIST is answered with every parameter, one PARAM_VALUE each.
Answered at once, a storm of requests is a storm of replies (510 requests in 30 s drew 7,298
PARAM_VALUE, 240 a second, before this). Here one list is sent at a time, paced at ``rate_hz``:

- a request while a list is being sent does not start another (every PARAM_VALUE carries no
  target, so every ground station on the link gets the one list being sent); the next request
  after the list ends starts a new one, on the same pace;
- at most ``rate_hz`` values a second over any window, plus a burst of at most
  ``MAX_BURST`` + 1 when the caller's timer comes late (it catches up no further).

ArduPilot paces its own list the same way (libraries/GCS_MAVLink/GCS_Param.cpp,
``GCS_MAVLINK::queued_param_send``: at most 30% of the link's bandwidth on parameters, at most 5
per call without flow control); its new request restarts the list from the first parameter,
which a storm of requests would keep restarting, so here the list in progress is finished
instead.
"""
from __future__ import annotations

from collections import deque
from typing import Generic, TypeVar

Value = TypeVar("Value")
MAX_BURST = 1           # periods a late timer may catch up: at most 2 values at once


class ParamListPacer(Generic[Value]):
    """One list at a time, ``rate_hz`` values a second."""

    def __init__(self, rate_hz: float) -> None:
        if not rate_hz > 0:
            raise ValueError(f"rate_hz must be > 0, got {rate_hz}")
        self.period_s = 1.0 / rate_hz
        self._queue: deque[Value] = deque()
        self._next_s: float | None = None          # when the next value may go
        self.lists_started = 0
        self.requests_folded = 0                   # requests while a list was being sent

    @property
    def sending(self) -> bool:
        return bool(self._queue)

    @property
    def next_due_s(self) -> float | None:
        """When the next value is due (None: nothing to send)."""
        return self._next_s if self._queue else None

    def request(self, t_s: float, values: list[Value]) -> bool:
        """A list request at ``t_s``: True if it starts a list, False if one is being sent."""
        if self._queue:
            self.requests_folded += 1
            return False
        self._queue.extend(values)
        self.lists_started += 1
        # the pace carries over from the list before: back-to-back lists stay at rate_hz
        self._next_s = t_s if self._next_s is None else max(self._next_s, t_s)
        return True

    def due(self, t_s: float) -> list[Value]:
        """The values due at ``t_s``, in order."""
        if not self._queue or self._next_s is None:
            return []
        self._next_s = max(self._next_s, t_s - MAX_BURST * self.period_s)
        out = []
        while self._queue and self._next_s <= t_s:
            out.append(self._queue.popleft())
            self._next_s += self.period_s
        return out
