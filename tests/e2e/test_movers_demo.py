"""`companion demo` with moving obstacles: flown safely through the stub, movers kept out of the
map and published for the ground station as OBSTACLE_DISTANCE_3D in LOCAL_NED."""
from __future__ import annotations

import json

import yaml
from pymavlink import mavutil

from companion.mavlink.dialect import mavlink
from tests.e2e.support import REPO
from tests.e2e.test_demo_replay import companion

# The demo takes off first (spool-up, climb to 10 m: about 12 s of simulated time) while the
# movers move on the stub's clock: mover 3 starts that much further east, so that it still
# crosses in front of the vehicle as it does in `companion simulate`, which starts in the air.
TAKEOFF_S = 12.0


def movers_after_takeoff(tmp_path):
    data = yaml.safe_load((REPO / "config" / "scenarios" / "movers.yaml").read_text())
    mover = next(o for o in data["world"]["obstacles"] if o["id"] == 3)
    mover["east_m"] -= mover["vel_east_mps"] * TAKEOFF_S
    path = tmp_path / "movers.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def test_demo_with_movers_tracks_and_publishes_them(tmp_path):
    done = companion("demo", "--scenario", str(movers_after_takeoff(tmp_path)), "--speedup", "20",
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
    # Mover 3 starts at (95, 48) heading west at 1.5 m/s: its published track moves that way.
    first, last = published[3][0], published[3][-1]
    elapsed_s = (last[0] - first[0]) / 1000.0
    assert elapsed_s > 5.0
    assert abs((last[2] - first[2]) / elapsed_s - (-1.5)) < 0.3
    assert abs(last[1] - first[1]) < 0.3 * elapsed_s
    replay = companion("replay", str(tmp_path / "d.tlog"), "--json", str(tmp_path / "r.json"))
    assert replay.returncode == 0, replay.stderr
    compared = json.loads((tmp_path / "r.json").read_text())
    assert compared["setpoints_compared"] > 0 and compared["setpoints_mismatched"] == 0
