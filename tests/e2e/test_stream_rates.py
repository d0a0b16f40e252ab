"""A router that holds the vehicle's streams at 4 Hz: the daemon measures the rate, asks again for
what it wants (bounded), and stops asking once the streams are back (issue 14)."""
from __future__ import annotations

import os
import re
import select
import socket
import threading
import time

os.environ.setdefault("MAVLINK20", "1")
from pymavlink.dialects.v20 import ardupilotmega as mavlink  # noqa: E402

from tests.e2e.support import start_companion, wait_until, write_config  # noqa: E402

MAX_REASSERTS = 3


class SlowStreamVehicle:
    """A vehicle behind a router: heartbeats at 1 Hz, ATTITUDE and LOCAL_POSITION_NED at
    ``rate_hz`` whatever is asked; acknowledges SET_MESSAGE_INTERVAL and counts the requests."""

    def __init__(self, rate_hz: float) -> None:
        self.rate_hz = rate_hz
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.bind(("127.0.0.1", 0))
        self.mav = mavlink.MAVLink(None, srcSystem=1, srcComponent=1)
        self.parser = mavlink.MAVLink(None)
        self.parser.robust_parsing = True
        self.requests: list[tuple[float, int]] = []     # (time, message id) of each request
        self.peer = None
        self._stop = False
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    @property
    def port(self) -> int:
        return self.sock.getsockname()[1]

    def _send(self, msg) -> None:
        if self.peer is not None:
            self.sock.sendto(msg.pack(self.mav), self.peer)

    def _run(self) -> None:
        start = time.monotonic()
        next_hb = next_stream = start
        while not self._stop:
            now = time.monotonic()
            boot_ms = int((now - start) * 1000)
            if now >= next_hb:
                self._send(mavlink.MAVLink_heartbeat_message(2, 3, 0, 4, 4, 3))
                next_hb += 1.0
            if now >= next_stream:
                self._send(mavlink.MAVLink_attitude_message(boot_ms, 0, 0, 0.0, 0, 0, 0))
                self._send(mavlink.MAVLink_local_position_ned_message(boot_ms, 0, 0, -10, 0, 0, 0))
                next_stream += 1.0 / self.rate_hz
            ready, _, _ = select.select([self.sock], [], [], 0.01)
            if not ready:
                continue
            data, self.peer = self.sock.recvfrom(4096)
            for msg in self.parser.parse_buffer(data) or []:
                if msg.get_type() == "COMMAND_LONG" and msg.command == 511:
                    self.requests.append((time.monotonic(), int(msg.param1)))
                    self._send(mavlink.MAVLink_command_ack_message(511, 0))

    def close(self) -> None:
        self._stop = True
        self._thread.join(timeout=2)
        self.sock.close()


def rounds(vehicle: SlowStreamVehicle) -> int:
    """How many times the streams were asked for: each round asks for 30 then 32 (a retry, when
    an ack comes late on a loaded machine, repeats the same id and is not a new round)."""
    ids = [msg_id for _, msg_id in list(vehicle.requests)]
    return sum(1 for before, now in zip(ids, ids[1:]) if (before, now) == (30, 32))


def test_streams_slower_than_asked_are_asked_again_a_bounded_number_of_times(tmp_path):
    vehicle = SlowStreamVehicle(rate_hz=4.0)
    config = write_config(tmp_path, streams={"rate_check_s": 1.0, "max_reasserts": MAX_REASSERTS})
    daemon = start_companion(tmp_path, f"udpout:127.0.0.1:{vehicle.port}", config)
    try:
        wait_until(lambda: rounds(vehicle) >= 1, 15.0, "the first stream request")
        wait_until(lambda: rounds(vehicle) >= 2, 10.0, "a request again at 4 Hz of 10 asked")
        # bounded: after the allowed re-assertions (one per 1 s window) it stops asking
        wait_until(lambda: rounds(vehicle) >= 1 + MAX_REASSERTS, 15.0, "all re-assertions")
        settled = rounds(vehicle)
        time.sleep(3.0)           # three more windows at 4 Hz: no more requests
        assert rounds(vehicle) == settled == 1 + MAX_REASSERTS
        stderr = daemon.stderr()
        # said once, with what came and why; then once that it flies at that rate
        assert stderr.count("sets the vehicle's stream rates") == 1, stderr
        got = [float(x) for x in re.findall(r"\b3[02] at (\d+\.\d) Hz \(asked 10\)", stderr)]
        assert got and all(3.0 <= x <= 4.5 for x in got), stderr        # the vehicle's 4 Hz
        assert "not asked again" in stderr, stderr
    finally:
        daemon.stop()
        vehicle.close()


def test_streams_at_the_asked_rate_are_not_asked_again(tmp_path):
    vehicle = SlowStreamVehicle(rate_hz=10.0)
    config = write_config(tmp_path, streams={"rate_check_s": 1.0})
    daemon = start_companion(tmp_path, f"udpout:127.0.0.1:{vehicle.port}", config)
    try:
        wait_until(lambda: rounds(vehicle) >= 1, 15.0, "the first stream request")
        time.sleep(3.0)
        assert rounds(vehicle) == 1
    finally:
        daemon.stop()
        vehicle.close()
