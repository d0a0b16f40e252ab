"""The service's velocity choice over MAVLink against the stub (issue 16), in lock-step:
a way blocked all round stops the vehicle short of every safety circle, and a multicopter looks
at a crossing mover that has left its camera's view while its velocity keeps clear of it."""
from __future__ import annotations

import json
import math

import yaml

from tests.e2e.support import (PAPER, GroundStation, companion_setpoints, read_tlog,
                               start_companion, start_stub, wait_until, write_config)
from tests.e2e.test_demo_replay import companion
from tests.stub.support import read_truth_log

SAFETY_M = 10.0
RING_RADIUS_M = 14.0
FLOWN_S = 50.0                   # vehicle time after which the blocked flight is judged


def scenario(tmp_path, name: str, obstacles: list[dict], **avoidance) -> str:
    data = yaml.safe_load(PAPER.read_text())
    data["name"] = name
    data["world"]["obstacles"] = obstacles
    data["avoidance"].update(avoidance)
    path = tmp_path / f"{name}.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def test_a_way_blocked_all_round_stops_the_vehicle_short_of_every_circle(tmp_path):
    """A ring of overlapping circles round the start (8 obstacles 10.7 m apart on a 14 m
    circle): no way keeps d but a few metres round the start. The vehicle stays (mostly
    stopped) inside, at least d from every obstacle; it never turns across the ring."""
    ring = [{"id": i + 1, "north_m": 20.0 + RING_RADIUS_M * math.cos(2 * math.pi * i / 8),
             "east_m": RING_RADIUS_M * math.sin(2 * math.pi * i / 8), "radius_m": 1.0}
            for i in range(8)]
    truth_path, tlog = tmp_path / "truth.jsonl", tmp_path / "run.tlog"
    stub, tcp_port, udp_port = start_stub(tmp_path, "--truth-log", str(truth_path),
                                          scenario=scenario(tmp_path, "ring", ring),
                                          lockstep=True)
    processes = [stub]
    try:
        config = write_config(tmp_path, goal=(180.0, 0.0))
        processes.append(start_companion(tmp_path, f"udpout:127.0.0.1:{udp_port}", config,
                                         "--tlog", str(tlog), lockstep=True))
        gcs = GroundStation(tcp_port)
        gcs.fly_from_the_ground()
        wait_until(lambda: truth_path.exists() and (rows := read_truth_log(truth_path))
                   and rows[-1]["t_s"] >= FLOWN_S, 90.0, f"{FLOWN_S} s of flight")
        gcs.close()
    finally:
        for process in reversed(processes):
            if process.proc.poll() is None:
                process.stop()
    truth = [r for r in read_truth_log(truth_path) if r["t_s"] <= FLOWN_S]
    sent = companion_setpoints(read_tlog(tlog))
    assert len(sent) > 100
    flying = [r for r in truth if not r["landed"]]
    clearance = min(math.hypot(r["north_m"] - o["north_m"], r["east_m"] - o["east_m"])
                    for r in flying for o in r["obstacles"])
    assert clearance >= 0.95 * SAFETY_M
    farthest = max(math.hypot(r["north_m"] - 20.0, r["east_m"]) for r in flying)
    # it stayed inside: a multicopter flies its setpoint straight (arc._fly_copter), so even a
    # quarter speed for the roll-out's horizon leaves the few metres that keep d and it holds
    # still (the unicycle's arc circled at 2.4 m radius in there and crept 2.2 m off the start)
    assert farthest <= RING_RADIUS_M - 0.95 * SAFETY_M
    # boxed in, it stays stopped (turning in place to look round, creeping a metre now and then)
    last = [math.hypot(r["vel_north_mps"], r["vel_east_mps"])
            for r in truth if r["t_s"] >= FLOWN_S - 20.0]
    assert max(last) < 2.0 and sum(v < 0.1 for v in last) >= 0.5 * len(last)
    speeds = [math.hypot(sp.vx, sp.vy) for sp in sent]
    assert max(speeds) <= 5.0 + 1e-6
    assert sum(v < 1e-3 for v in speeds) >= 0.5 * len(speeds)           # stopped, by command


def test_a_crossing_mover_out_of_view_is_looked_at_and_avoided(tmp_path):
    """A mover walks west at 3 m/s across the path from ahead-right; seen during the takeoff, it
    slides out of the 90 degree view as the vehicle flies on. With avoidance.look_at_threats the
    nose turns to it (the yaw setpoint apart from the velocity's direction) while the velocity
    keeps clear; the goal is reached with the safety distance kept."""
    mover = [{"id": 3, "north_m": 50.0, "east_m": 56.0, "radius_m": 1.0,
              "vel_north_mps": 0.0, "vel_east_mps": -3.0}]
    path = scenario(tmp_path, "look-at", mover, look_at_threats=True)
    work = tmp_path / "work"
    done = companion("demo", "--scenario", str(path), "--json", str(tmp_path / "d.json"),
                     "--tlog", str(tmp_path / "d.tlog"), "--keep", str(work))
    assert done.returncode == 0, done.stdout + done.stderr
    (run,) = json.loads((tmp_path / "d.json").read_text())["runs"]
    assert run["reached_goal"] and not run["collided"] and run["min_clearance_m"] >= 9.5
    truth = {round(r["t_s"] * 10): r for r in read_truth_log(work / "truth.jsonl")}
    looked = []
    for sp in companion_setpoints(read_tlog(tmp_path / "d.tlog")):
        speed = math.hypot(sp.vx, sp.vy)
        row = truth.get(round(sp.time_boot_ms / 100))
        if row is None or speed < 1.0:
            continue
        course = math.atan2(sp.vy, sp.vx)
        (o,) = row["obstacles"]
        bearing = math.atan2(o["east_m"] - row["east_m"], o["north_m"] - row["north_m"])
        apart = abs(math.remainder(sp.yaw - course, 2 * math.pi))
        off_course = abs(math.remainder(bearing - course, 2 * math.pi))
        if apart > math.radians(30.0):
            looked.append((off_course, abs(math.remainder(bearing - row["yaw_rad"], 2 * math.pi))))
    assert len(looked) >= 20, "the nose never left the velocity's direction"
    # while apart, the mover was outside the view of a camera along the velocity, and the true
    # nose had it in view (the camera saw it again)
    assert all(off > math.radians(45.0) for off, _ in looked)
    assert sum(nose < math.radians(45.0) for _, nose in looked) >= 0.8 * len(looked)
