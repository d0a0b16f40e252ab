"""`companion doctor` against real processes on loopback: the stub (every line ok, exit 0), the
stub with a silent camera (exit 1, the camera named), the stub holding LOCAL_POSITION_NED at 2 Hz
behind MAVProxy as the router (the slow stream named with its rate), and ArduPilot's own
ArduCopter SITL with the stub's camera beside it (the `ardupilot` tests: skipped without
ARDUCOPTER_SITL and ARDUCOPTER_DEFAULTS)."""
from __future__ import annotations

import json
import os
import select
import subprocess
import sys
from pathlib import Path

import pytest

from tests.e2e.support import PAPER, REPO, start_stub

COPTER = REPO / "config" / "scenarios" / "copter.yaml"      # a GPS: the position is trusted
LISTEN_S = 6.0
MAVPROXY = str(Path(sys.executable).parent / "mavproxy.py")


def doctor(url: str, seconds: float = LISTEN_S, *extra: str) -> tuple[int, dict]:
    done = subprocess.run([sys.executable, "-m", "companion", "doctor", "--connect", url,
                           "--seconds", str(seconds), "--json", *extra],
                          capture_output=True, text=True, cwd=REPO, timeout=seconds + 60)
    assert done.returncode in (0, 1), done.stderr[-3000:]
    return done.returncode, json.loads(done.stdout)


def lines(report: dict) -> dict[str, dict]:
    return {check["name"]: check for check in report["checks"]}


def test_against_the_stub_every_line_is_ok(tmp_path):
    stub, _, udp_port = start_stub(tmp_path, scenario=COPTER)
    try:
        code, report = doctor(f"udpout:127.0.0.1:{udp_port}")
    finally:
        stub.stop()
    assert code == 0 and report["ready"]
    assert [c for c in report["checks"] if c["status"] != "ok"] == []
    checks = lines(report)
    for name in ("vehicle", "camera", "EKF origin", "time sync", "signing", "steering mode",
                 "GUID_TIMEOUT", "proximity", "stream LOCAL_POSITION_NED (32)"):
        assert name in checks, sorted(checks)
    assert "ArduPilot, QUADROTOR, firmware 4.5.0" in checks["vehicle"]["measured"]
    assert report["facts"]["params"]["GUID_TIMEOUT"] == 3.0
    assert report["facts"]["rates_hz"]["32"] >= 5.0            # it asked, as the service does


def test_against_the_stubs_px4_face_the_px4_lines_are_checked(tmp_path):
    stub, _, udp_port = start_stub(tmp_path, "--autopilot", "px4", "--px4-arm-delay-s", "1",
                                   scenario=COPTER)
    try:
        code, report = doctor(f"udpout:127.0.0.1:{udp_port}")
    finally:
        stub.stop()
    checks = lines(report)
    assert code == 0 and report["ready"], [c for c in report["checks"] if c["status"] != "ok"]
    assert "PX4" in checks["vehicle"]["measured"]
    assert checks["steering mode"]["measured"].startswith("OFFBOARD")
    assert "stream ESTIMATOR_STATUS (230)" in checks           # PX4's, in place of EKF_STATUS_REPORT
    assert "stream EKF_STATUS_REPORT (193)" not in checks
    assert {"COM_OF_LOSS_T", "COM_OBL_RC_ACT"} <= set(checks) and "GUID_TIMEOUT" not in checks


def test_a_stub_whose_camera_sends_nothing_is_not_ready_and_the_camera_is_named(tmp_path):
    stub, _, udp_port = start_stub(tmp_path, "--no-camera", scenario=COPTER)
    try:
        code, report = doctor(f"udpout:127.0.0.1:{udp_port}")
    finally:
        stub.stop()
    assert code == 1 and not report["ready"]
    failed = [c for c in report["checks"] if c["status"] == "fail"]
    assert [c["name"] for c in failed] == ["camera"]
    assert "component 100" in failed[0]["measured"] and "camera driver" in failed[0]["todo"]


@pytest.mark.skipif(not Path(MAVPROXY).exists(), reason="MAVProxy is in the test extra")
def test_behind_a_router_the_slow_stream_is_named_with_its_rate(tmp_path):
    """The stub holds LOCAL_POSITION_NED at 2 Hz whatever is asked (--fixed-rate), MAVProxy
    routes between it and the doctor (its --out)."""
    from benchmarks.gcs_layout import Lines, free_udp_port
    stub, tcp_port, _ = start_stub(tmp_path, "--fixed-rate", "32:2", scenario=COPTER)
    port = free_udp_port()
    router = subprocess.Popen(
        [sys.executable, MAVPROXY, f"--master=tcp:127.0.0.1:{tcp_port}",
         f"--out=udp:127.0.0.1:{port}", "--daemon"],
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL, text=True,
        cwd=tmp_path, env=dict(os.environ, PYTHONUNBUFFERED="1"))
    out = Lines(router)
    try:
        assert out.wait_for("Detected vehicle 1:1", 30.0), out.text()
        code, report = doctor(f"udpin:127.0.0.1:{port}", 8.0)
    finally:
        router.kill()
        router.wait(timeout=10)
        stub.stop()
    slow = lines(report)["stream LOCAL_POSITION_NED (32)"]
    assert slow["status"] == "warn", slow
    assert 1.5 <= report["facts"]["rates_hz"]["32"] <= 2.5
    assert "LOCAL_POSITION_NED (32) 2." in slow["measured"] and "needs 10 Hz" in slow["measured"]
    assert lines(report)["camera"]["status"] == "ok"           # routed through MAVProxy too


SITL = os.environ.get("ARDUCOPTER_SITL")
DEFAULTS = os.environ.get("ARDUCOPTER_DEFAULTS")


@pytest.mark.ardupilot
@pytest.mark.skipif(not (SITL and DEFAULTS), reason="ArduCopter SITL not given: set "
                    "ARDUCOPTER_SITL (binary) and ARDUCOPTER_DEFAULTS (parm file)")
def test_against_arducopter_sitl_with_the_stubs_camera(tmp_path):
    """ArduCopter SITL x10 (its EKF origin ~4 s of wall time after boot), the stub's camera on its
    SERIAL2, the doctor on SERIAL1 as the service would be (docs/doctor.md)."""
    from companion.config.scenario import load_scenario
    from companion.tools import ardupilot_sitl as sitl
    from companion.tools.autopilot_demo import sitl_home
    camera = subprocess.Popen(
        [sys.executable, "-m", "sitl_stub", "--camera-only", "--scenario", str(PAPER),
         "--connect", "udpin:127.0.0.1:0"], stdout=subprocess.PIPE,
        stderr=open(tmp_path / "camera.stderr", "w"), text=True, cwd=REPO)
    procs = [camera]
    try:
        ready, _, _ = select.select([camera.stdout], [], [], 20.0)
        line = camera.stdout.readline() if ready else ""
        assert line.startswith("SITL_STUB CAMERA READY"), line
        camera_port = int(line.strip().rsplit(":", 1)[1])
        links = sitl.SitlLinks(sitl.free_udp_port(), sitl.free_udp_port(), camera_port)
        (tmp_path / "sitl").mkdir()
        procs.append(subprocess.Popen(
            sitl.sitl_command(Path(SITL), Path(DEFAULTS), sitl.free_instance(),
                              sitl_home(load_scenario(PAPER)), 10.0, links),
            cwd=tmp_path / "sitl", stdout=subprocess.DEVNULL, stderr=subprocess.STDOUT))
        code, report = doctor(f"udpin:127.0.0.1:{links.companion_port}", 20.0)
    finally:
        for proc in reversed(procs):
            proc.terminate()
            proc.wait(timeout=20)
    checks = lines(report)
    print(json.dumps(report["checks"], indent=1))
    assert checks["vehicle"]["status"] == "ok" and "ArduPilot" in checks["vehicle"]["measured"]
    assert "GUID_TIMEOUT 3 s" in checks["GUID_TIMEOUT"]["measured"]
    assert checks["camera"]["status"] == "ok" and checks["EKF origin"]["status"] == "ok"
    assert code == 0, [c for c in report["checks"] if c["status"] == "fail"]
