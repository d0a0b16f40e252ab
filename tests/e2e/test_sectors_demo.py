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


def test_demo_past_a_wall_and_a_building_keeps_clear_of_their_surfaces(tmp_path):
    # walls.yaml over MAVLink, lock-step: the stub ray-casts the wall and the building itself
    # (sitl_stub/shapes.py) and logs its own distance to their surfaces; the companion's score
    # measures the same flight with its own geometry (companion/core/shapes.py)
    done = companion("demo", "--scenario", "config/scenarios/walls.yaml",
                     "--json", str(tmp_path / "d.json"), "--keep", str(tmp_path / "work"))
    assert done.returncode == 0, done.stdout + done.stderr
    (run,) = json.loads((tmp_path / "d.json").read_text())["runs"]
    assert run["reached_goal"] and not run["collided"]
    assert run["min_clearance_m"] >= 9.5 and run["min_surface_clearance_m"] >= 9.5
    records = [json.loads(line) for line in (tmp_path / "work" / "truth.jsonl").read_text().splitlines()]
    armed = [r for r in records if r["armed"]]
    stub_min = min(r["shape_clearance_m"] for r in armed)
    assert stub_min >= 9.5
    # the companion's figure is over every obstacle (here the post's surface is farther)
    assert run["min_surface_clearance_m"] <= stub_min + 0.05
