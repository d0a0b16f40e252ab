"""The workflow of docs/real-vehicle.md against the stub, over real sockets: the daemon up from
boot, the ground station arms in GUIDED and sends NAV_TAKEOFF to 10 m; the daemon sends nothing
before the climb is over, then flies around the paper's obstacles to the goal. And the stub's
answer to the old mistake: velocity setpoints to a landed vehicle idle it and it disarms."""
from __future__ import annotations

import json
import math

from pymavlink import mavutil

from tests.e2e.support import (GUIDED, GroundStation, companion_setpoints, read_tlog,
                               start_companion, start_stub, wait_until, write_config)
from tests.stub.support import read_truth_log

SPEEDUP = "10"
TAKEOFF_ALT_M = 10.0


def test_docs_workflow_takeoff_in_guided_then_avoid_to_the_goal(tmp_path):
    truth_path, tlog, report = tmp_path / "truth.jsonl", tmp_path / "run.tlog", tmp_path / "r.json"
    # lock-step: the flight is the same whatever the machine's load (and over sooner)
    stub, tcp_port, udp_port = start_stub(tmp_path, "--speedup", SPEEDUP, "--seed", "3",
                                          "--truth-log", str(truth_path), lockstep=True)
    processes = [stub]
    try:
        config = write_config(tmp_path, goal=(180.0, 0.0))
        companion = start_companion(tmp_path, f"udpout:127.0.0.1:{udp_port}", config,
                                    "--tlog", str(tlog), "--report", str(report), lockstep=True)
        processes.append(companion)
        wait_until(lambda: report.exists(), 20.0, "the daemon's estimator (up from boot)")
        gcs = GroundStation(tcp_port)
        gcs.fly_from_the_ground(TAKEOFF_ALT_M)
        wait_until(lambda: json.loads(report.read_text()).get("arrived"), 60.0,
                   "the companion to report arrival")
        gcs.close()
    finally:
        for process in reversed(processes):
            if process.proc.poll() is None:
                process.stop()
    truth = read_truth_log(truth_path)
    at_ms = {round(r["t_s"] * 1000): r for r in truth}
    sent = companion_setpoints(read_tlog(tlog))
    assert len(sent) > 100
    takeoff_ms = min(t for t, r in at_ms.items() if r["armed"])
    for sp in sent:
        row = at_ms[round(sp.time_boot_ms / 100) * 100]
        # no setpoint (hold included) before the takeoff altitude was reached
        assert row["up_m"] >= TAKEOFF_ALT_M - 0.5 and not row["landed"], (sp.time_boot_ms, row)
        assert sp.type_mask == 0x09C7 and abs(sp.vz) <= 1.0 and math.isfinite(sp.vz)
    assert sent[0].time_boot_ms - takeoff_ms >= 3000            # the climb takes seconds
    result = json.loads(report.read_text())
    # the hand-over (issue 32, direct layout): airborne, and commanding, within 5 s of the
    # vehicle reaching its take-off altitude
    reached_s = min(r["t_s"] for r in truth if r["armed"] and r["up_m"] >= TAKEOFF_ALT_M - 0.5)
    airborne_s = min(t for t, phase, _ in result["phases"] if phase == "airborne")
    assert -1.0 <= airborne_s - reached_s <= 5.0, (reached_s, result["phases"])
    assert sent[0].time_boot_ms / 1000.0 - reached_s <= 5.0
    arrival = at_ms[round(result["arrival_t_s"] * 10) * 100]
    assert math.hypot(arrival["north_m"] - 180.0, arrival["east_m"]) <= 2.0 + 2.0
    flying = [r for r in truth if r["armed"] and r["t_s"] <= result["arrival_t_s"]]
    clearance = min(math.hypot(r["north_m"] - o["north_m"], r["east_m"] - o["east_m"])
                    for r in flying for o in r["obstacles"])
    assert clearance >= 9.5
    assert all(r["armed"] for r in truth if r["t_s"] * 1000 >= takeoff_ms)   # never disarmed
    assert abs(arrival["up_m"] - TAKEOFF_ALT_M) < 1.0          # the vertical hold held 10 m
    assert result["urgency_events"], "the paper's obstacle 2 is on the line: avoidance acted"


def test_stub_disarms_a_landed_vehicle_that_gets_velocity_setpoints(tmp_path):
    """ArduCopter's answer to setpoints before the takeoff (issue 13): motors idle, disarmed
    DISARM_DELAY (10 s) later, never off the ground."""
    truth_path = tmp_path / "truth.jsonl"
    stub, tcp_port, _ = start_stub(tmp_path, "--speedup", SPEEDUP, "--truth-log", str(truth_path))
    try:
        gcs = GroundStation(tcp_port)
        gcs.set_mode(GUIDED)
        gcs.arm()
        gcs.takeoff(TAKEOFF_ALT_M)
        conn = gcs.conn

        def disarmed():
            conn.mav.set_position_target_local_ned_send(0, 1, 1, 1, 0x09C7, 0, 0, 0, 5.0, 0.0,
                                                        0.0, 0, 0, 0, 0.0, 0)
            hb = conn.recv_match(type="HEARTBEAT", blocking=True, timeout=0.2)
            return hb is not None and hb.get_srcComponent() == 1 \
                and not hb.base_mode & mavutil.mavlink.MAV_MODE_FLAG_SAFETY_ARMED
        wait_until(disarmed, 20.0, "the stub to disarm the landed vehicle", poll_s=0.0)
        gcs.close()
    finally:
        assert stub.stop()[0] == 0
    truth = read_truth_log(truth_path)
    armed = [r for r in truth if r["armed"]]
    assert armed and all(r["up_m"] < 0.5 and r["speed_mps"] == 0.0 for r in truth)
    armed_s = armed[-1]["t_s"] - armed[0]["t_s"]
    assert 9.5 <= armed_s <= 11.5                               # DISARM_DELAY 10 s


def test_a_lat_lon_goal_is_converted_with_the_ekf_origin_the_daemon_asks_for(tmp_path):
    lat0, lon0 = -35.363261, 149.165230          # the paper scenario's origin
    goal_lat = lat0 + 180.0 / 111318.84502145034  # 180 m north (ArduPilot's scaling)
    stub, _, udp_port = start_stub(tmp_path, "--speedup", SPEEDUP)
    report = tmp_path / "r.json"
    config = write_config(tmp_path)
    companion = start_companion(tmp_path, f"udpout:127.0.0.1:{udp_port}", config,
                                "--goal", f"geo:{goal_lat:.9f},{lon0:.9f}", "--report", str(report))
    try:
        wait_until(lambda: "-> north" in companion.stderr(), 20.0, "the goal in metres")
        assert companion.stop()[0] == 0
    finally:
        for process in (companion, stub):
            if process.proc.poll() is None:
                process.stop()
    north, east = json.loads(report.read_text())["goal_ne_m"]
    assert abs(north - 180.0) < 0.05 and abs(east) < 0.05
    assert "from the EKF origin" in companion.stderr()
