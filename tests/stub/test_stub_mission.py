"""The stub stores a mission as ArduCopter 4.6 does (sitl_stub/mission_store.py): item 0 is home,
upload by MISSION_REQUEST with resends and a timeout, download by _INT or not, clear, and
MISSION_CURRENT's total; and MAVProxy's `wp load` uploads one through the stub's TCP port."""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

os.environ.setdefault("MAVLINK20", "1")
from pymavlink import mavutil  # noqa: E402
from pymavlink.dialects.v20 import ardupilotmega as mavlink  # noqa: E402

from sitl_stub.mission_store import MissionStore  # noqa: E402
from sitl_stub.world import load_scenario  # noqa: E402
from tests.stub.support import PAPER, start_stub  # noqa: E402
from tests.stub.test_stock_ground_station import MAVPROXY, read_until  # noqa: E402

HOME = (-35.363261, 149.165230, 584.0)
GCS = (255, 190)


def from_gcs(msg):
    msg.pack(mavlink.MAVLink(None, *GCS))          # sets the source ids as the parser would
    return msg


def gcs_item(seq, lat, lon, frame=mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT):
    return from_gcs(mavlink.MAVLink_mission_item_int_message(
        1, 1, seq, frame, mavlink.MAV_CMD_NAV_WAYPOINT, 0, 1, 0, 0, 0, 0,
        int(lat * 1e7), int(lon * 1e7), 10.0, 0))


def upload(store, items, t_s=0.0):
    replies = store.handle(from_gcs(mavlink.MAVLink_mission_count_message(1, 1, len(items), 0)), t_s)
    for it in items:
        assert replies[-1].get_type() == "MISSION_REQUEST" and replies[-1].seq == it.seq
        replies = store.handle(it, t_s)
    return replies


def test_upload_then_download_with_home_as_item_0():
    store = MissionStore(lambda: HOME)
    assert store.handle(from_gcs(mavlink.MAVLink_mission_request_list_message(1, 1, 0)), 0)[0].count == 1
    replies = upload(store, [gcs_item(0, 0, 0), gcs_item(1, -35.362, 149.1652),
                             gcs_item(2, -35.361, 149.1652)])
    assert replies[0].get_type() == "MISSION_ACK" and replies[0].type == mavlink.MAV_MISSION_ACCEPTED
    assert (replies[1].total, replies[1].mission_state) == (2, mavlink.MISSION_STATE_NOT_STARTED)
    count = store.handle(from_gcs(mavlink.MAVLink_mission_request_list_message(1, 1, 0)), 1)[0]
    assert count.count == 3
    home = store.handle(from_gcs(mavlink.MAVLink_mission_request_int_message(1, 1, 0, 0)), 1)[0]
    assert (home.x, home.y, home.frame) == (int(HOME[0] * 1e7), int(HOME[1] * 1e7), 0)
    wp2 = store.handle(from_gcs(mavlink.MAVLink_mission_request_message(1, 1, 2, 0)), 1)[0]
    assert wp2.get_type() == "MISSION_ITEM" and wp2.x == pytest.approx(-35.361, abs=1e-6)
    beyond = store.handle(from_gcs(mavlink.MAVLink_mission_request_int_message(1, 1, 3, 0)), 1)[0]
    assert beyond.get_type() == "MISSION_ACK" and beyond.type == mavlink.MAV_MISSION_INVALID_SEQUENCE


def test_clear_leaves_home_and_an_upload_resends_then_times_out():
    store = MissionStore(lambda: HOME)
    upload(store, [gcs_item(0, 0, 0), gcs_item(1, -35.362, 149.1652)])
    ack, current = store.handle(from_gcs(mavlink.MAVLink_mission_clear_all_message(1, 1, 0)), 2)
    assert ack.type == mavlink.MAV_MISSION_ACCEPTED and current.total == 0 and store.count == 1
    store.handle(from_gcs(mavlink.MAVLink_mission_count_message(1, 1, 2, 0)), 10.0)
    assert store.tick(10.5) == []
    again = store.tick(11.1)
    assert again[0].get_type() == "MISSION_REQUEST" and again[0].seq == 0     # resent after 1 s
    other = mavlink.MAVLink_mission_count_message(1, 1, 1, 0)
    other.pack(mavlink.MAVLink(None, 254, 190))
    assert store.handle(other, 11.2)[0].type == mavlink.MAV_MISSION_DENIED   # someone else
    assert store.tick(18.2)[0].type == mavlink.MAV_MISSION_OPERATION_CANCELLED
    assert store.count == 1                                                   # nothing kept


def write_wpl(path: Path, points_ne_m) -> None:
    """A QGC WPL 110 file (MAVProxy's and Mission Planner's text format): home, then waypoints
    in MAV_FRAME_GLOBAL_RELATIVE_ALT at 10 m, positions from the paper scenario's origin."""
    origin = load_scenario(PAPER).world.origin
    lines = ["QGC WPL 110"]
    lat, lon = origin.to_lat_lon_deg(20.0, 0.0)
    lines.append(f"0\t1\t0\t16\t0\t0\t0\t0\t{lat:.8f}\t{lon:.8f}\t584.0\t1")
    for seq, (north, east) in enumerate(points_ne_m, start=1):
        lat, lon = origin.to_lat_lon_deg(north, east)
        lines.append(f"{seq}\t0\t3\t16\t0\t2\t0\t0\t{lat:.8f}\t{lon:.8f}\t10.0\t1")
    path.write_text("\n".join(lines) + "\n")


UPLOADED = "waypoints in "      # MAVProxy's line once the last mission item has been sent


def mavproxy_load(tcp_port: int, wpl: Path, cwd: Path) -> str:
    """MAVProxy as an operator uses it: `wp load FILE` typed once the vehicle is detected (its
    mission loaders are kept per system id: a load before that goes to system 0's)."""
    gcs = subprocess.Popen(
        [sys.executable, MAVPROXY, f"--master=tcp:127.0.0.1:{tcp_port}",
         "--default-modules=wp"],
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, stdin=subprocess.PIPE, text=True,
        cwd=cwd, env=dict(os.environ, PYTHONUNBUFFERED="1"))   # its lines reach us as printed
    try:
        seen = read_until(gcs, ["Detected vehicle 1:1"], timeout_s=30.0)
        gcs.stdin.write(f"wp load {wpl}\n")
        gcs.stdin.flush()
        # MAVProxy prints "Loaded N waypoints in T s" and writes "Sent all N waypoints" to its
        # console in the same step, once the vehicle has asked for the last item; only the
        # first reliably reached the pipe (CI: it alone, "in 0.00s", then nothing for 30 s)
        return seen + read_until(gcs, [UPLOADED], timeout_s=30.0)
    finally:
        # Its stdin closed first: MAVProxy at a prompt on a pipe ignores SIGTERM (the 10 s wait
        # below ran out on every call, and the kill ended it)
        gcs.stdin.close()
        gcs.terminate()
        try:
            gcs.wait(timeout=10)
        except subprocess.TimeoutExpired:
            gcs.kill()


@pytest.mark.skipif(not Path(MAVPROXY).exists(), reason="MAVProxy is in the test extra")
def test_mavproxy_wp_load_stores_a_mission_the_stub_serves_back(tmp_path):
    points = [(90.0, 0.0), (150.0, 0.0), (150.0, 30.0), (60.0, 30.0)]
    wpl = tmp_path / "mission.txt"
    write_wpl(wpl, points)
    stub = start_stub(tmp_path)
    try:
        out = mavproxy_load(stub.tcp_port, wpl, tmp_path)
        assert "Loaded 5 waypoints in" in out, out
        conn = mavutil.mavlink_connection(f"tcp:127.0.0.1:{stub.tcp_port}", source_system=255,
                                          source_component=191)
        conn.wait_heartbeat(timeout=10)
        conn.mav.mission_request_list_send(1, 1, 0)
        count = conn.recv_match(type="MISSION_COUNT", blocking=True, timeout=5)
        items = []
        for seq in range(count.count):
            conn.mav.mission_request_int_send(1, 1, seq, 0)
            items.append(conn.recv_match(type="MISSION_ITEM_INT", blocking=True, timeout=5))
        conn.close()
    finally:
        assert stub.stop() == 0
    assert count.count == 5 and [i.seq for i in items] == list(range(5))
    origin = load_scenario(PAPER).world.origin
    for item, (north, east) in zip(items[1:], points):
        lat, lon = origin.to_lat_lon_deg(north, east)
        assert item.command == mavlink.MAV_CMD_NAV_WAYPOINT and item.param2 == 2.0
        assert abs(item.x - lat * 1e7) <= 1 and abs(item.y - lon * 1e7) <= 1
        assert item.frame in (mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT,
                              mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT)
