"""The companion's parameters from stock and hostile ground stations, through the stub's routing
(`sitl-stub --route`, ArduPilot's rules), over real loopback sockets, in lock-step.

MAVProxy addresses the companion's component (--target-component 191): the list arrives complete,
`param set CA_SAFE_DIST 12` is echoed and kept in the overlay, an out-of-range set is refused with
a STATUSTEXT, and after a restart the companion flies the flight with 12 m of clearance.
"""
from __future__ import annotations

import json
import math
import os
import selectors
import subprocess
import sys
import time
from pathlib import Path

import pytest
import yaml

from companion.onboard.parameters import MAV_PARAM_TYPE_INT32, MAV_PARAM_TYPE_REAL32, TABLE
from tests.e2e.support import (GroundStation, companion_setpoints, read_tlog, start_companion,
                               start_stub, wait_until, write_config)
from tests.stub.support import read_truth_log
from tests.stub.test_stock_ground_station import MAVPROXY

pytestmark = pytest.mark.skipif(not Path(MAVPROXY).exists(), reason="MAVProxy is in the test extra")


class MavProxy:
    """An interactive MAVProxy on the stub's TCP port, aimed at system 1, component 191."""

    def __init__(self, tcp_port: int, cwd: Path) -> None:
        self.proc = subprocess.Popen(
            [sys.executable, MAVPROXY, f"--master=tcp:127.0.0.1:{tcp_port}",
             "--default-modules=param", "--target-system=1", "--target-component=191",
             "--cmd=param fetch"],
            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, stdin=subprocess.PIPE, text=True,
            cwd=cwd, env={**os.environ, "PYTHONUNBUFFERED": "1"})     # each line as printed
        self.out = ""
        self._selector = selectors.DefaultSelector()
        self._selector.register(self.proc.stdout, selectors.EVENT_READ)

    def expect(self, needle: str, timeout_s: float = 20.0) -> str:
        deadline = time.monotonic() + timeout_s
        start = len(self.out)
        while needle not in self.out[start:]:
            if time.monotonic() > deadline:
                raise AssertionError(f"MAVProxy: no {needle!r} in {timeout_s} s:\n{self.out}")
            if self._selector.select(timeout=0.2):
                line = self.proc.stdout.readline()
                if not line:
                    raise AssertionError(f"MAVProxy exited:\n{self.out}")
                self.out += line
        return self.out[start:]

    def send(self, command: str) -> None:
        self.proc.stdin.write(command + "\n")
        self.proc.stdin.flush()

    def close(self) -> None:
        self.proc.kill()
        self.proc.wait(timeout=10)


def clearance_m(truth_path: Path, until_t_s: float) -> float:
    flying = [r for r in read_truth_log(truth_path) if r["armed"] and r["up_m"] > 5.0
              and r["t_s"] <= until_t_s]
    return min(math.hypot(r["north_m"] - o["north_m"], r["east_m"] - o["east_m"])
               for r in flying for o in r["obstacles"])


def test_mavproxy_lists_sets_and_the_next_flight_keeps_the_new_distance(tmp_path):
    config = write_config(tmp_path)
    overlay = tmp_path / "companion.params.yaml"
    stub, tcp_port, udp_port = start_stub(tmp_path, "--route", lockstep=True)
    processes = [stub]
    try:
        companion = start_companion(tmp_path, f"udpout:127.0.0.1:{udp_port}", config,
                                    lockstep=True)
        processes.append(companion)
        gcs = MavProxy(tcp_port, tmp_path)
        try:
            gcs.expect(f"Received {len(TABLE)} parameters")       # param_count's, all indices
            parm = tmp_path / "mav_1_191.parm"
            wait_until(lambda: parm.exists() and len(parm.read_text().splitlines()) >= len(TABLE),
                       10.0, "MAVProxy's saved parameter file")
            saved = dict(line.split()[:2] for line in parm.read_text().splitlines()
                         if line.strip() and not line.startswith("#"))
            assert sorted(saved) == sorted(spec.name for spec in TABLE)   # count matches
            assert float(saved["CA_SAFE_DIST"]) == 10.0
            gcs.send("param set CA_SAFE_DIST 12")
            gcs.expect("CA_SAFE_DIST 12 applies now")
            gcs.send("param set CA_SAFE_DIST 500")
            gcs.expect("CA_SAFE_DIST 500 out of 0.5..100")
            gcs.send("param fetch CA_SAFE_DIST")
            assert "CA_SAFE_DIST = 12.0" in gcs.expect("CA_SAFE_DIST = ")
        finally:
            gcs.close()
        # written off the event loop after the set (param_overlay.OverlaySaver): wait for it
        wait_until(overlay.exists, 10.0, "the parameter overlay file")
        assert yaml.safe_load(overlay.read_text()) == {"avoidance": {"safety_distance_m": 12.0}}
        code, _ = companion.stop()
        assert code == 0, companion.stderr()
        assert "parameter CA_SAFE_DIST (avoidance.safety_distance_m) 10.0 -> 12.0" \
            in companion.stderr()
        stub.stop()
        # The next start: a new flight from the ground; the overlay gives d = 12 m.
        truth_path, report = tmp_path / "truth.jsonl", tmp_path / "report.json"
        stub, tcp_port, udp_port = start_stub(tmp_path, "--route", "--truth-log",
                                              str(truth_path), lockstep=True)
        processes = [stub]
        companion = start_companion(tmp_path, f"udpout:127.0.0.1:{udp_port}", config,
                                    "--report", str(report), lockstep=True)
        processes.append(companion)
        wait_until(lambda: report.exists(), 30.0, "the daemon's estimator")
        pilot = GroundStation(tcp_port)
        pilot.fly_from_the_ground()
        wait_until(lambda: json.loads(report.read_text()).get("arrived"), 120.0, "arrival")
        pilot.close()
    finally:
        for process in reversed(processes):
            if process.proc.poll() is None:
                process.stop()
    result = json.loads(report.read_text())
    assert result["config"]["avoidance"]["safety_distance_m"] == 12.0
    assert result["parameter_overlay"]["values"] == {"avoidance.safety_distance_m": 12.0}
    assert "parameter overlay" in companion.stderr()
    # main's paper flights at d = 10 keep 10.2-10.8 m (companion demo seeds 0-3); at 12 more
    assert clearance_m(truth_path, result["arrival_t_s"]) >= 11.5


def hostile_requests(mav, rng_seed: int = 7):
    """Garbage names, NaN and inf, wrong types, out-of-range values, and in-range sets."""
    import random
    rng = random.Random(rng_seed)
    names = [spec.name for spec in TABLE]
    yield mav.param_set_encode(1, 191, bytes(rng.randrange(256) for _ in range(16)), 1.0, 9)
    yield mav.param_set_encode(1, 191, b"CA_SAFE_DIST", math.nan, MAV_PARAM_TYPE_REAL32)
    yield mav.param_set_encode(1, 191, b"CA_SAFE_DIST", math.inf, MAV_PARAM_TYPE_REAL32)
    yield mav.param_set_encode(1, 191, b"CA_SAFE_DIST", 11.0, MAV_PARAM_TYPE_INT32)
    yield mav.param_set_encode(1, 191, b"CA_STRATEGY", 0.5, MAV_PARAM_TYPE_INT32)
    yield mav.param_set_encode(1, 191, b"CA_CRUISE_SPD", 1e30, MAV_PARAM_TYPE_REAL32)
    yield mav.param_request_read_encode(1, 191, b"", 30000)
    yield mav.param_request_read_encode(1, 191, b"\xff\xfe", -1)
    for _ in range(150):
        name = rng.choice(names).encode()
        value = rng.choice([rng.uniform(-1e3, 1e3), math.nan, rng.uniform(0.0, 20.0)])
        yield mav.param_set_encode(1, 191, name, value, rng.choice([6, 9, 9, 2]))
        if rng.random() < 0.1:
            yield mav.param_request_list_encode(1, 191)


def test_a_hostile_ground_station_during_a_flight_changes_nothing_unsafe(tmp_path, capsys):
    from pymavlink import mavutil
    config = write_config(tmp_path)
    truth_path, report, tlog = tmp_path / "truth.jsonl", tmp_path / "r.json", tmp_path / "run.tlog"
    stub, tcp_port, udp_port = start_stub(tmp_path, "--route", "--truth-log", str(truth_path),
                                          lockstep=True)
    processes = [stub]
    try:
        companion = start_companion(tmp_path, f"udpout:127.0.0.1:{udp_port}", config,
                                    "--report", str(report), "--tlog", str(tlog), lockstep=True)
        processes.append(companion)
        wait_until(lambda: report.exists(), 30.0, "the daemon's estimator")
        pilot = GroundStation(tcp_port)
        pilot.fly_from_the_ground()
        wait_until(lambda: len(companion_setpoints(read_tlog(tlog))) >= 20, 30.0, "setpoints")
        hostile = mavutil.mavlink_connection(f"tcp:127.0.0.1:{tcp_port}", source_system=254,
                                             source_component=190)
        hostile.wait_heartbeat(timeout=10)
        for msg in hostile_requests(hostile.mav):
            hostile.write(msg.pack(hostile.mav))
            time.sleep(0.01)                  # a storm, bounded: ~100 messages a second
        wait_until(lambda: json.loads(report.read_text()).get("arrived"), 120.0, "arrival")
        hostile.close()
        pilot.close()
        code, _ = companion.stop()
        assert code == 0, companion.stderr()
    finally:
        for process in reversed(processes):
            if process.proc.poll() is None:
                process.stop()
    result = json.loads(report.read_text())
    params = result["parameters"]
    assert params["refused"].get("unknown name", 0) >= 1 and params["refused"]["not finite"] >= 1
    assert params["refused"]["wrong type"] >= 1 and params["refused"]["out of range"] >= 1
    received = [m for _, m in read_tlog(tlog) if m.get_type() == "PARAM_SET"]
    assert len(received) >= 100                     # the storm reached the companion
    answered = [m for _, m in read_tlog(tlog) if m.get_type() == "PARAM_VALUE"
                and m.get_srcComponent() == 191]
    assert len(answered) >= len(received) // 2     # recorded: the values in force sent back
    setpoints = companion_setpoints(read_tlog(tlog))
    assert setpoints
    stored = result["config"]
    for sp in setpoints:
        values = (sp.vx, sp.vy, sp.vz, sp.yaw)
        assert all(math.isfinite(v) for v in values)
        assert math.hypot(sp.vx, sp.vy) <= 50.0 + 1e-6
    # the speed limit is a next-start parameter: the gate's limit of the start holds all flight
    assert max(math.hypot(sp.vx, sp.vy) for sp in setpoints) <= 8.0 + 1e-4
    assert stored["commanding"]["max_speed_mps"] == 8.0
    assert result["arrived"]
    # identity: standby on the ground, active while commanding; SYS_STATUS's avoidance bit
    ours = [m for _, m in read_tlog(tlog) if m.get_srcComponent() == 191]
    states = [m.system_status for m in ours if m.get_type() == "HEARTBEAT"]
    assert states[0] == 3 and 4 in states and states.index(4) > 0, states
    status = [m for m in ours if m.get_type() == "SYS_STATUS"]
    assert status and {m.onboard_control_sensors_present for m in status} == {0x20000000}
    assert any(m.onboard_control_sensors_health == 0x20000000 for m in status)
    # the live sets that got through changed the flight, and the replay of its tlog (the
    # PARAM_SETs in it go through the same pipeline) reproduces it setpoint for setpoint
    assert params["accepted"] >= 1 and result["counters"]["param_applied"] >= 1
    from companion.__main__ import main
    capsys.readouterr()
    assert main(["replay", str(tlog), "--json", str(tmp_path / "replay.json")]) == 0
    replayed = json.loads((tmp_path / "replay.json").read_text())
    assert replayed["setpoints_compared"] > 100
    assert replayed["setpoints_mismatched"] == 0 and replayed["setpoints_unmatched"] == 0


def test_sys_status_false_sends_none(tmp_path):
    """link.sys_status: false: HEARTBEATs (with their state) and no SYS_STATUS from us."""
    config = write_config(tmp_path, link={"sys_status": False})
    tlog = tmp_path / "run.tlog"
    stub, _, udp_port = start_stub(tmp_path, lockstep=True)
    try:
        companion = start_companion(tmp_path, f"udpout:127.0.0.1:{udp_port}", config,
                                    "--tlog", str(tlog), lockstep=True)
        wait_until(lambda: sum(m.get_type() == "HEARTBEAT" and m.get_srcComponent() == 191
                               for _, m in read_tlog(tlog)) >= 3, 30.0, "three of our heartbeats")
        assert companion.stop()[0] == 0, companion.stderr()
    finally:
        stub.stop()
    ours = [m.get_type() for _, m in read_tlog(tlog) if m.get_srcComponent() == 191]
    assert "HEARTBEAT" in ours and "SYS_STATUS" not in ours


def test_a_corrupt_overlay_is_said_and_ignored_at_start(tmp_path):
    config = write_config(tmp_path)
    overlay = tmp_path / "companion.params.yaml"
    overlay.write_text("avoidance:\n  safety_distance_m: -3\n")
    tlog, report = tmp_path / "run.tlog", tmp_path / "r.json"
    stub, _, udp_port = start_stub(tmp_path, lockstep=True)
    try:
        companion = start_companion(tmp_path, f"udpout:127.0.0.1:{udp_port}", config,
                                    "--tlog", str(tlog), "--report", str(report), lockstep=True)
        wait_until(lambda: report.exists(), 30.0, "the daemon's estimator")
        assert companion.stop()[0] == 0, companion.stderr()
    finally:
        stub.stop()
    texts = [m.text for _, m in read_tlog(tlog) if m.get_type() == "STATUSTEXT"
             and m.get_srcComponent() == 191]
    assert "companion: parameter overlay ignored" in texts
    assert f"{overlay}: avoidance.safety_distance_m" in companion.stderr()
    result = json.loads(report.read_text())
    assert result["config"]["avoidance"]["safety_distance_m"] == 10.0     # the YAML's
    assert str(overlay) in result["parameter_overlay"]["error"]
