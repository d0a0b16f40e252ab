"""`companion demo` with moving obstacles: flown safely through the stub, movers kept out of the
map and published for the ground station as OBSTACLE_DISTANCE_3D in LOCAL_NED."""
from __future__ import annotations

import json

from pymavlink import mavutil

from companion.adapters.codec import mavlink
from tests.e2e.test_demo_replay import companion


def test_demo_with_movers_tracks_and_publishes_them(tmp_path):
    done = companion("demo", "--scenario", "config/scenarios/movers.yaml", "--speedup", "20",
                     "--json", str(tmp_path / "d.json"), "--tlog", str(tmp_path / "d.tlog"))
    assert done.returncode == 0, done.stdout + done.stderr
    (run,) = json.loads((tmp_path / "d.json").read_text())["runs"]
    assert run["reached_goal"] and not run["collided"] and run["min_clearance_m"] >= 9.5
    log = mavutil.mavlink_connection(str(tmp_path / "d.tlog"))
    published = {}
    while (msg := log.recv_match(type="OBSTACLE_DISTANCE_3D")) is not None:
        if msg.get_srcComponent() == 191:
            assert msg.frame == mavlink.MAV_FRAME_LOCAL_NED
            published.setdefault(msg.obstacle_id, []).append((msg.time_boot_ms, msg.x, msg.y))
    assert set(published) == {3, 4}                        # the two movers, not the static two
    # Mover 3 starts at (95, 30) heading west at 1.5 m/s: its published track moves that way.
    first, last = published[3][0], published[3][-1]
    elapsed_s = (last[0] - first[0]) / 1000.0
    assert elapsed_s > 5.0
    assert abs((last[2] - first[2]) / elapsed_s - (-1.5)) < 0.3
    assert abs(last[1] - first[1]) < 0.3 * elapsed_s
    replay = companion("replay", str(tmp_path / "d.tlog"), "--json", str(tmp_path / "r.json"))
    assert replay.returncode == 0, replay.stderr
    compared = json.loads((tmp_path / "r.json").read_text())
    assert compared["setpoints_compared"] > 0 and compared["setpoints_mismatched"] == 0
