"""Issue 32: the stub as ArduCopter is with two clients (libraries/GCS_MAVLink/MissionItemProtocol.cpp,
GCS_Common.cpp): one mission upload at a time and the other client refused with the right
MAV_MISSION_RESULT; downloads keep no state; stream rates and message intervals kept per link."""
from __future__ import annotations

import os
import time

import pytest

os.environ.setdefault("MAVLINK20", "1")
from pymavlink import mavutil  # noqa: E402
from pymavlink.dialects.v20 import ardupilotmega as mavlink  # noqa: E402

from sitl_stub.mission_store import MissionStore  # noqa: E402
from tests.stub.support import start_stub  # noqa: E402
from tests.stub.test_stub_autopilot import Rig, wire  # noqa: E402
from tests.stub.test_stub_mission import HOME, from_gcs, gcs_item  # noqa: E402

COMPANION = (1, 191)


def from_companion(msg):
    msg.pack(mavlink.MAVLink(None, *COMPANION))
    return msg


def test_during_an_upload_downloads_and_other_uploads_are_denied_and_clear_all_is_an_error():
    store = MissionStore(lambda: HOME)
    first = store.handle(from_gcs(mavlink.MAVLink_mission_count_message(1, 1, 2, 0)), 0.0)
    assert first[0].get_type() == "MISSION_REQUEST" and first[0].target_component == 190
    for msg in (mavlink.MAVLink_mission_request_list_message(1, 1, 0),
                mavlink.MAVLink_mission_request_int_message(1, 1, 0, 0),
                mavlink.MAVLink_mission_count_message(1, 1, 1, 0)):
        reply = store.handle(from_companion(msg), 0.1)[0]
        assert (reply.get_type(), reply.type) == ("MISSION_ACK", mavlink.MAV_MISSION_DENIED)
        assert (reply.target_system, reply.target_component) == COMPANION     # to the asker
    clear = store.handle(from_companion(mavlink.MAVLink_mission_clear_all_message(1, 1, 0)), 0.2)
    assert clear[0].type == mavlink.MAV_MISSION_ERROR      # handle_mission_clear_all: !receiving
    store.handle(gcs_item(0, 0, 0), 0.3)
    done = store.handle(gcs_item(1, -35.362, 149.1652), 0.4)
    assert done[0].type == mavlink.MAV_MISSION_ACCEPTED and done[0].target_component == 190
    count = store.handle(from_companion(mavlink.MAVLink_mission_request_list_message(1, 1, 0)), 0.5)
    assert count[0].count == 2


def test_an_upload_may_start_during_someone_elses_download():
    """Downloads keep no state on ArduPilot: the uploader is served, the downloader's next
    request is refused."""
    store = MissionStore(lambda: HOME)
    assert store.handle(from_companion(mavlink.MAVLink_mission_request_list_message(1, 1, 0)),
                        0.0)[0].get_type() == "MISSION_COUNT"
    up = store.handle(from_gcs(mavlink.MAVLink_mission_count_message(1, 1, 2, 0)), 0.1)
    assert up[0].get_type() == "MISSION_REQUEST"
    nxt = store.handle(from_companion(mavlink.MAVLink_mission_request_int_message(1, 1, 0, 0)), 0.2)
    assert nxt[0].type == mavlink.MAV_MISSION_DENIED


def test_set_message_interval_applies_to_the_link_it_came_on():
    rig = Rig()
    res, _ = rig.cmd(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, 30, 100000)    # from nowhere: shared
    assert rig.ap.scheduler.interval_s(30) == pytest.approx(0.1)
    msg = wire(mavlink.MAVLink_command_long_message(1, 1, mavlink.MAV_CMD_SET_MESSAGE_INTERVAL,
                                                    0, 30, 500000, 0, 0, 0, 0, 0))
    rig.ap.handle(msg, 0.0, link="udp:companion")
    assert rig.ap.streams.of("udp:companion").interval_s(30) == pytest.approx(0.5)
    assert rig.ap.scheduler.interval_s(30) == pytest.approx(0.1)         # the others unchanged
    gcs = wire(mavlink.MAVLink_request_data_stream_message(1, 1, 0, 2, 1))   # ALL at 2 Hz
    rig.ap.handle(gcs, 0.0, link="tcp:gcs")
    assert rig.ap.streams.of("tcp:gcs").interval_s(32) == pytest.approx(0.5)
    assert rig.ap.streams.of("udp:companion").interval_s(32) == pytest.approx(0.25)  # SR0 4 Hz
    get = wire(mavlink.MAVLink_command_long_message(1, 1, mavlink.MAV_CMD_GET_MESSAGE_INTERVAL,
                                                    0, 30, 0, 0, 0, 0, 0, 0))
    reply = [m for _, m in rig.ap.handle(get, 0.0, link="udp:companion")
             if m.get_type() == "MESSAGE_INTERVAL"][0]
    assert reply.interval_us == 500000


def rates_hz(conns, msg_type: str, seconds: float) -> list[float]:
    """Per wall second, over the same window on every connection (what came before: drained)."""
    for conn in conns:
        while conn.recv_match(blocking=False) is not None:
            pass
    counts = [0] * len(conns)
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        for i, conn in enumerate(conns):
            while (msg := conn.recv_match(blocking=False)) is not None:
                counts[i] += msg.get_type() == msg_type
        time.sleep(0.01)
    return [n / seconds for n in counts]


def test_a_companion_on_its_own_port_keeps_its_rates_when_a_ground_station_sets_others(tmp_path):
    """Real sockets: the companion on UDP asks ATTITUDE at 10 Hz; a ground station on TCP asks
    every stream at 2 Hz (as MAVProxy and Mission Planner do): each gets what it asked."""
    stub = start_stub(tmp_path, "--udp", "127.0.0.1:0", "--speedup", "2")
    try:
        gcs = mavutil.mavlink_connection(f"tcp:127.0.0.1:{stub.tcp_port}", source_system=255,
                                         source_component=190)
        gcs.wait_heartbeat(timeout=10)
        companion = mavutil.mavlink_connection(f"udpout:127.0.0.1:{stub.udp_port}",
                                               source_system=1, source_component=191)
        companion.mav.heartbeat_send(18, 8, 0, 0, 0)
        companion.wait_heartbeat(timeout=10)
        companion.mav.command_long_send(1, 1, mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, 0, 30,
                                        1e5, 0, 0, 0, 0, 0)
        for _ in range(3):                                   # as MAVProxy re-asks
            gcs.mav.request_data_stream_send(1, 1, 0, 2, 1)
            time.sleep(0.2)
        companion_hz, gcs_hz = rates_hz([companion, gcs], "ATTITUDE", 2.0)
    finally:
        assert stub.stop() == 0
    # vehicle time runs at 2x: 10 Hz asked -> ~20 per wall second, 2 Hz -> ~4
    assert companion_hz > 12.0, companion_hz
    assert 2.0 < gcs_hz < 7.0, gcs_hz
