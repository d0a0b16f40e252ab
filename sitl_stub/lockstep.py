"""Lock-step: the stub steps its physics only when its peer (the companion) has caught up.

The peer's ODOMETRY is the sign: its ``time_usec`` is the vehicle time the pose was computed for,
so an ODOMETRY at t says "I have absorbed the odometry sample of t, and everything sent before
it". A client becomes a peer with its first ODOMETRY. The stub waits, before each step, until
every peer has answered the latest *whole* odometry sample (LOCAL_POSITION_NED and ATTITUDE)
delivered to it, so with one sample per step it is never more than one step (one control period)
ahead. A sample lost on the way (``--drop-rate``) is not waited for. A peer that answers only
every n-th sample (a companion without ``--lockstep`` publishes ODOMETRY at 5 Hz) may lag by its
own answer period less one sample: the stub never waits for an answer that will not come, and
stays within one of the peer's control periods (logged once, as that loosens the lock).

The wait is bounded in wall time: after ``timeout_s`` (``start_timeout_s`` for the first peer)
the stub logs a warning and free-runs at ``--speedup``; it locks again as soon as the peers have
caught up. A dead companion therefore slows the stub down for one timeout, never freezes it.

No sockets, no clocks here: the caller reports deliveries and ODOMETRY, and asks ``caught_up``.
"""
from __future__ import annotations

import logging
from dataclasses import dataclass

from pymavlink.dialects.v20 import ardupilotmega as mavlink

log = logging.getLogger(__name__)

MSG_ID_ODOMETRY = mavlink.MAVLINK_MSG_ID_ODOMETRY
# What one odometry sample is made of; both must reach the peer for an answer to be due.
SAMPLE_IDS = (mavlink.MAVLINK_MSG_ID_LOCAL_POSITION_NED, mavlink.MAVLINK_MSG_ID_ATTITUDE)
DEFAULT_TIMEOUT_S = 3.0
DEFAULT_START_TIMEOUT_S = 60.0


@dataclass(frozen=True)
class LockstepOptions:
    timeout_s: float = DEFAULT_TIMEOUT_S
    start_timeout_s: float = DEFAULT_START_TIMEOUT_S
    # Step on the answer to the sample before the latest: the peer computes on sample k while
    # the stub steps to k+1; what the peer sent for sample k takes effect one step later.
    overlap: bool = False


def odometry_last(items: list[tuple[int, object]]) -> list[tuple[int, object]]:
    """A step's messages with LOCAL_POSITION_NED moved to the end (stable otherwise).

    The companion answers a position with its ODOMETRY; anything of the same step sent after the
    position (a camera frame) would be handled after that answer, and its consequences (a
    setpoint) would reach the stub on one step or the next depending on the machine's load. The
    companion's estimator holds a frame stamped after its latest odometry until that odometry
    arrives, so it sees the same estimate either way.
    """
    last = [item for item in items if item[1].id == SAMPLE_IDS[0]]
    if not last:
        return items
    return [item for item in items if item[1].id != SAMPLE_IDS[0]] + last


class LockstepGate:
    """Who the peers are, what each has been sent and what each has answered (all in ms)."""

    def __init__(self, overlap: bool = False) -> None:
        self.overlap = overlap
        self._answered_ms: dict[str, int] = {}            # peer -> latest ODOMETRY time
        self._delivered_ms: dict[str, dict[int, int]] = {}  # client -> msg id -> latest time
        self._whole_ms: dict[str, int] = {}       # client -> latest time both parts went out
        self._sample_gap_ms: int | None = None    # smallest gap between whole samples
        self._answer_gap_ms: dict[str, int] = {}  # peer -> smallest gap between its answers
        self.free_running = False
        self.waits = 0            # steps that had to wait for a peer
        self.timeouts = 0         # waits that ran out

    @property
    def has_peer(self) -> bool:
        return bool(self._answered_ms)

    def is_peer(self, client: str) -> bool:
        return client in self._answered_ms

    def on_delivered(self, client: str, msg) -> None:
        """A message went out to ``client`` (not dropped)."""
        if msg.id in SAMPLE_IDS:
            t_ms = int(msg.time_boot_ms)
            sent = self._delivered_ms.setdefault(client, {})
            sent[msg.id] = t_ms
            if all(sent.get(msg_id) == t_ms for msg_id in SAMPLE_IDS):
                previous = self._whole_ms.get(client)
                if previous is not None and t_ms > previous:
                    self._sample_gap_ms = min(self._sample_gap_ms or t_ms - previous,
                                              t_ms - previous)
                self._whole_ms[client] = t_ms

    def on_odometry(self, client: str, msg) -> None:
        t_ms = int(round(msg.time_usec / 1000.0))
        previous = self._answered_ms.get(client)
        if previous is None:
            log.info("lock-step peer: %s (first ODOMETRY at %.3f s)", client, t_ms / 1000.0)
        elif t_ms > previous:
            gap = min(self._answer_gap_ms.get(client, t_ms - previous), t_ms - previous)
            if self._sample_gap_ms and gap > self._sample_gap_ms \
                    and self._answer_gap_ms.get(client, 0) <= self._sample_gap_ms:
                log.warning("lock-step peer %s answers every %.3f s, samples come every %.3f s: "
                            "it may lag by one of its periods (is it running with --lockstep?)",
                            client, gap / 1000.0, self._sample_gap_ms / 1000.0)
            self._answer_gap_ms[client] = gap
        self._answered_ms[client] = max(t_ms, previous if previous is not None else t_ms)

    def awaited_ms(self, client: str) -> int | None:
        """Time of the latest whole odometry sample (both parts, same time) delivered to
        ``client``, if any: half a sample is not answered until the next whole one."""
        return self._whole_ms.get(client)

    def lagging(self) -> str:
        """Which peers are behind, for the log: 'client answered 1.200 s of 1.300 s'."""
        return ", ".join(f"{client} answered {answered / 1000:.3f} s of "
                         f"{self.awaited_ms(client) / 1000:.3f} s"
                         for client, answered in self._answered_ms.items()
                         if (self.awaited_ms(client) or 0) > answered) or "none"

    def caught_up(self) -> bool:
        """Every peer has answered everything due (False while there is no peer at all)."""
        if not self._answered_ms:
            return False
        for client, answered in self._answered_ms.items():
            awaited = self.awaited_ms(client)
            if awaited is not None and answered < awaited - self._slack_ms(client) - self.lag_ms:
                return False
        return True

    @property
    def lag_ms(self) -> int:
        """How many ms of samples the peers may still owe: one sample with ``overlap``."""
        return (self._sample_gap_ms or 0) if self.overlap else 0

    def _slack_ms(self, client: str) -> int:
        """How far behind the peer may be: 0 if it answers every sample."""
        gap, sample = self._answer_gap_ms.get(client), self._sample_gap_ms
        return max(0, gap - sample) if gap and sample else 0
