"""Lock-step: the stub steps its physics only when its peer (the companion) has caught up.

The peer's ODOMETRY is the sign: its ``time_usec`` is the vehicle time the pose was computed for,
so an ODOMETRY at t says "I have absorbed the odometry sample of t, and everything sent before
it". A client becomes a peer with its first ODOMETRY. The stub waits, before each step, until
every peer has answered the latest *whole* odometry sample (LOCAL_POSITION_NED and ATTITUDE)
delivered to it, so with one sample per step it is never more than one step (one control period)
ahead. A sample lost on the way (``--drop-rate``) is not waited for.

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

    def __init__(self) -> None:
        self._answered_ms: dict[str, int] = {}            # peer -> latest ODOMETRY time
        self._delivered_ms: dict[str, dict[int, int]] = {}  # client -> msg id -> latest time
        self._whole_ms: dict[str, int] = {}       # client -> latest time both parts went out
        self.free_running = False
        self.waits = 0            # steps that had to wait for a peer
        self.timeouts = 0         # waits that ran out

    @property
    def has_peer(self) -> bool:
        return bool(self._answered_ms)

    def on_delivered(self, client: str, msg) -> None:
        """A message went out to ``client`` (not dropped)."""
        if msg.id in SAMPLE_IDS:
            t_ms = int(msg.time_boot_ms)
            sent = self._delivered_ms.setdefault(client, {})
            sent[msg.id] = t_ms
            if all(sent.get(msg_id) == t_ms for msg_id in SAMPLE_IDS):
                self._whole_ms[client] = t_ms

    def on_odometry(self, client: str, msg) -> None:
        t_ms = int(round(msg.time_usec / 1000.0))
        if client not in self._answered_ms:
            log.info("lock-step peer: %s (first ODOMETRY at %.3f s)", client, t_ms / 1000.0)
        self._answered_ms[client] = max(t_ms, self._answered_ms.get(client, t_ms))

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
            if awaited is not None and answered < awaited:
                return False
        return True
