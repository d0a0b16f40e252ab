"""`companion demo --scenario config/scenarios/depth.yaml`: the stub renders depth frames and
serves them on a local TCP socket beside the MAVLink link (``--depth-tcp``); the service reads
them itself (``companion run --depth stub:HOST:PORT``), in lock-step, perceives obstacles from
the pixels and flies the paper's leg by them. And ``companion run --depth`` with a source that
cannot be read stops with the source's own message."""
from __future__ import annotations

import json
import socket

import numpy as np

from tests.e2e.test_demo_replay import companion

SAFETY_DISTANCE_M = 10.0          # depth.yaml's d


def test_depth_demo_flies_by_the_services_own_perception_of_the_stubs_frames(tmp_path):
    work = tmp_path / "work"
    done = companion("demo", "--scenario", "config/scenarios/depth.yaml",
                     "--json", str(tmp_path / "d.json"), "--keep", str(work), timeout_s=300.0)
    assert done.returncode == 0, done.stdout + done.stderr
    (run,) = json.loads((tmp_path / "d.json").read_text())["runs"]
    assert run["reached_goal"] and not run["collided"]
    assert run["min_clearance_m"] >= 0.95 * SAFETY_DISTANCE_M
    report = json.loads((work / "companion-report.json").read_text())
    # the service's own frames: read from the stub's socket, none lost, none waited for in vain
    feed = report["depth_feed"]
    assert feed["source"].startswith("stub:127.0.0.1:")
    assert feed["received"] > 500 and feed["dropped"] == 0
    assert feed["lockstep_wait_timeouts"] == 0
    depth = report["depth"]
    # each frame read was perceived or refused (before the estimator), but the last step's
    # (at most two at 15 Hz on 10 Hz steps) that may still wait for its position at the stop
    assert depth["frames"] + depth.get("before_estimator", 0) >= feed["received"] - 2
    assert depth["frames"] > 500
    assert depth["floor_points"] > depth["obstacle_points"] > 0
    # the two posts are in the map, and nothing far from them (the floor is not an obstacle)
    posts = [(60.0, 5.0), (120.0, 0.0)]
    for lm in report["landmarks"]:
        assert min(abs(complex(lm["north_m"] - n, lm["east_m"] - e)) for n, e in posts) < 4.0
    # each post mapped on it: within its 2 m radius and 0.5 m of its centre. (Before the depth
    # form's narrow-blob spread, post 1 had a landmark 0.4 m off its centre; since, its only
    # landmark lies on its surface, 2.25 m off: not diagnosed, docs/results/depth-perception.md)
    for n, e in posts:
        assert any(abs(complex(lm["north_m"] - n, lm["east_m"] - e)) < 2.0 + 0.5
                   for lm in report["landmarks"])


def _closed_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


def test_run_with_a_depth_source_that_cannot_be_read_says_which_and_why(tmp_path):
    from tests.adapters.test_depth_sources import H, W, _write_ros2_bag
    _write_ros2_bag(tmp_path / "mono8", "mono8", [np.zeros((H, W), np.uint8)])  # not a depth image
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as vehicle:   # nobody answers
        vehicle.bind(("127.0.0.1", 0))
        url = f"udpout:127.0.0.1:{vehicle.getsockname()[1]}"
        # (without the extra 'depth', the recording's reader says to install it)
        for source, says in ((f"stub:127.0.0.1:{_closed_port()}", ("cannot connect",)),
                             (f"realsense-bag:{tmp_path / 'none.db3'}",
                              ("no recording", "companion-avoid[depth]")),
                             (f"rosbag:{tmp_path / 'mono8'}:/camera/depth/image_rect_raw",
                              ("'mono8' is not a depth image",))):
            done = companion("run", "--connect", url, "--goal", "10,0", "--depth", source,
                             "--param-overlay", "none", timeout_s=60.0)
            assert done.returncode == 2, done.stderr
            assert f"depth source {source}" in done.stderr, done.stderr
            assert any(text in done.stderr for text in says), done.stderr
