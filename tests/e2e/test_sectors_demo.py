"""`companion demo` with a depth camera (sensor.form: sectors): the stub ray-casts its own
OBSTACLE_DISTANCE, the companion groups the bins into blobs and flies the paper's world by them."""
from __future__ import annotations

import json

from pymavlink import mavutil

from tests.e2e.test_demo_replay import companion


def test_demo_with_sectors_only_reaches_the_paper_goal_clear_of_the_posts(tmp_path):
    done = companion("demo", "--scenario", "config/scenarios/sectors.yaml",
                     "--json", str(tmp_path / "d.json"), "--tlog", str(tmp_path / "d.tlog"))
    assert done.returncode == 0, done.stdout + done.stderr
    (run,) = json.loads((tmp_path / "d.json").read_text())["runs"]
    assert run["reached_goal"] and not run["collided"] and run["min_clearance_m"] >= 9.5
    log = mavutil.mavlink_connection(str(tmp_path / "d.tlog"))
    kinds = set()
    while (msg := log.recv_match(type=["OBSTACLE_DISTANCE", "OBSTACLE_DISTANCE_3D"])) is not None:
        if msg.get_srcComponent() == 100:
            kinds.add(msg.get_type())
    assert kinds == {"OBSTACLE_DISTANCE"}            # the camera sent sectors only
