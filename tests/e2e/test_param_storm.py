"""A storm of PARAM_REQUEST_LIST at the real daemon, through the stub's routing (ArduPilot's
rules), over loopback: one list at a time, so 100 requests sent at once draw one list (two at
most, if one ended as they came), not 100; a single request still gets the whole list."""
from __future__ import annotations

import time

from companion.onboard.parameters import TABLE
from tests.e2e.support import start_companion, start_stub, wait_until, write_config
from tests.e2e.support import mavutil

STORM = 100
QUIET_S = 3.0          # the list is over when nothing came for this long (the pace: 10 a second)


def collect_param_values(conn, limit_s: float = 60.0) -> list:
    """PARAM_VALUEs from the companion (component 191) until QUIET_S passes without one."""
    out, last, deadline = [], time.monotonic(), time.monotonic() + limit_s
    while time.monotonic() - last < QUIET_S and time.monotonic() < deadline:
        msg = conn.recv_match(type="PARAM_VALUE", blocking=True, timeout=0.2)
        if msg is not None and msg.get_srcComponent() == 191:
            out.append(msg)
            last = time.monotonic()
    return out


def test_a_storm_of_list_requests_draws_one_list_and_a_single_request_the_whole_list(tmp_path):
    stub, tcp_port, udp_port = start_stub(tmp_path, "--route")
    companion = start_companion(tmp_path, f"udpout:127.0.0.1:{udp_port}", write_config(tmp_path))
    try:
        gcs = mavutil.mavlink_connection(f"tcp:127.0.0.1:{tcp_port}", source_system=255,
                                         source_component=190)

        def companion_heard() -> bool:
            # the stub routes to a client once it has spoken (ArduPilot's rule): we speak first
            gcs.mav.heartbeat_send(mavutil.mavlink.MAV_TYPE_GCS,
                                   mavutil.mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0)
            msg = gcs.recv_match(type="HEARTBEAT", blocking=True, timeout=0.5)
            return msg is not None and msg.get_srcComponent() == 191
        wait_until(companion_heard, 30.0, "the companion's heartbeat through the stub")
        for _ in range(STORM):
            gcs.mav.param_request_list_send(1, 191)
        stormed = collect_param_values(gcs)
        gcs.mav.param_request_list_send(1, 191)
        single = collect_param_values(gcs)
        gcs.close()
    finally:
        companion.stop()
        stub.stop()
    n = len(TABLE)
    assert n <= len(stormed) <= 2 * n, len(stormed)          # answered at once: 100 x 13
    assert {m.param_index for m in stormed} == set(range(n))
    assert sorted(m.param_index for m in single) == list(range(n))
    assert {m.param_count for m in single} == {n}
