"""The bag-replay map check (issue 44): the depth demo's frames recorded beside the flight by the
RealSense SDK (`companion demo --depth-record`, i.e. `companion depth-record --stub`), its tlog
replayed with `companion replay --depth realsense-bag:FILE` through the SDK's playback, give the
map the live flight had, and the same setpoints.

Tolerance: 1 cm on every landmark. The frames come back pixel for pixel (tests/adapters/
test_depth_bags.py), but the SDK stores the intrinsics as float32 (the stub sends float64): the
replayed landmarks differ by 1.3e-7 m at most, the setpoints by 3.2e-7 (measured, seed 0)."""
from __future__ import annotations

import json

import pytest

from companion.mavlink.tlog import TlogReader

from tests.e2e.test_demo_replay import companion

pytest.importorskip("pyrealsense2", reason="the RealSense SDK (extra 'depth') records and plays "
                                          "the bag")
TOLERANCE_M = 0.01


def test_a_depth_flight_replayed_from_its_realsense_bag_gives_the_live_map(tmp_path):
    work, tlog, bag = tmp_path / "work", tmp_path / "d.tlog", tmp_path / "frames.db3"
    done = companion("demo", "--scenario", "config/scenarios/depth.yaml", "--tlog", str(tlog),
                     "--depth-record", str(bag), "--keep", str(work),
                     "--json", str(tmp_path / "d.json"), timeout_s=400.0)
    assert done.returncode == 0, done.stdout + done.stderr
    live = json.loads((work / "companion-report.json").read_text())    # at the service's exit
    assert live["depth_feed"]["dropped"] == 0
    stub_log = (work / "sitl-stub.stderr").read_text()
    assert "behind" not in stub_log, "the stub dropped frames for a client (the recorder?)"
    replayed = companion("replay", str(tlog), "--depth", f"realsense-bag:{bag}",
                         "--json", str(tmp_path / "r.json"), timeout_s=300.0)
    assert replayed.returncode == 0, replayed.stdout + replayed.stderr
    again = json.loads((tmp_path / "r.json").read_text())
    # every frame the live service perceived, perceived again from the bag (but for the last
    # step's, at most two, if the stop came while they were perceived: at the goal, none of
    # them sees a post)
    assert 0 <= live["depth"]["frames"] - again["depth"]["frames"] <= 2
    assert again["depth"]["frames"] > 500
    assert again["depth"]["observations"] == live["depth"]["observations"]
    assert len(again["landmarks"]) == len(live["landmarks"]) >= 2
    for a, b in zip(live["landmarks"], again["landmarks"]):
        assert abs(a["north_m"] - b["north_m"]) <= TOLERANCE_M
        assert abs(a["east_m"] - b["east_m"]) <= TOLERANCE_M
    assert again["setpoints_unmatched"] == 0 and again["setpoints_compared"] > 100
    assert again["max_position_difference_m"] <= TOLERANCE_M
    # the same setpoints, to the float32 intrinsics' ulps (measured: 3.2e-7 at most)
    sent = [(m.vx, m.vy, m.yaw) for r in TlogReader(tlog) for m in [r.msg]
            if m.get_srcComponent() == 191 and m.get_type() == "SET_POSITION_TARGET_LOCAL_NED"]
    redone = [(s["vel_north_mps"], s["vel_east_mps"], s["yaw_rad"]) for s in again["setpoints"]]
    assert len(sent) == len(redone)
    assert max(abs(a - b) for x, y in zip(sent, redone) for a, b in zip(x, y)) < 1e-4
