"""Stock ground stations see an ArduCopter: MAVProxy detects the vehicle and its camera, names the
flight mode by ArduCopter's numbering, downloads the whole parameter set, arms, and says no
"fence breach"; MAVSDK reports the vehicle healthy and armable and flies its takeoff."""
from __future__ import annotations

import importlib.util
import json
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pytest
import yaml

from tests.stub.support import PAPER, start_stub

MAVPROXY = shutil.which("mavproxy.py") or str(Path(sys.executable).parent / "mavproxy.py")


def read_until(proc: subprocess.Popen, needles: list[str], timeout_s: float) -> str:
    """Collect MAVProxy's output until every needle has appeared (bounded by timeout_s)."""
    import selectors
    seen = ""
    deadline = time.monotonic() + timeout_s
    selector = selectors.DefaultSelector()
    selector.register(proc.stdout, selectors.EVENT_READ)
    while time.monotonic() < deadline and not all(n in seen for n in needles):
        if selector.select(timeout=0.2):
            line = proc.stdout.readline()
            if not line:
                break
            seen += line
    return seen


@pytest.mark.skipif(not Path(MAVPROXY).exists(), reason="MAVProxy is in the test extra")
def test_mavproxy_sees_a_normal_arducopter(tmp_path):
    stub = start_stub(tmp_path)
    gcs = subprocess.Popen(
        [sys.executable, MAVPROXY, f"--master=tcp:127.0.0.1:{stub.tcp_port}", "--non-interactive",
         "--default-modules=param,mode,arm,cmdlong,fence", "--cmd=arm throttle"],
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL, text=True,
        cwd=tmp_path)
    try:
        out = read_until(gcs, ["Detected vehicle 1:1", "Detected vehicle 1:100", "Mode STABILIZE",
                               "ARMED", "parameters"], timeout_s=30.0)
    finally:
        gcs.terminate()
        try:
            gcs.wait(timeout=10)
        except subprocess.TimeoutExpired:
            gcs.kill()
        assert stub.stop() == 0
    assert "Detected vehicle 1:1 on link 0" in out, out        # the autopilot
    assert "Detected vehicle 1:100 on link 0" in out, out      # the stereo camera
    assert "Mode STABILIZE" in out, out                         # ArduCopter's mode 0, by name
    assert "fence breach" not in out, out                       # SYS_STATUS bits as ArduCopter's
    assert "COMPONENT_ARM_DISARM: ACCEPTED" in out and "ARMED" in out, out
    params = dict(line.split()[:2] for line in (tmp_path / "mav.parm").read_text().splitlines()
                  if line.strip() and not line.startswith("#"))
    assert f"Received {len(params)} parameters" in out, out
    assert float(params["GUID_TIMEOUT"]) == 3.0 and float(params["SYSID_THISMAV"]) == 1.0


MAVSDK_CLIENT = r'''
import asyncio, json, sys, time
from mavsdk.asyncio import ComponentType, Configuration, Mavsdk
from mavsdk.asyncio.plugins.action import ActionAsync
from mavsdk.asyncio.plugins.telemetry import TelemetryAsync

async def main(port):
    config = Configuration.create_with_component_type(ComponentType.GROUND_STATION)
    async with Mavsdk(config) as mavsdk:
        await mavsdk.add_any_connection(f"tcpout://127.0.0.1:{port}")
        system = await mavsdk.first_autopilot(timeout_s=10.0)
        telemetry, action = TelemetryAsync(system), ActionAsync(system)
        deadline = time.monotonic() + 15.0
        while time.monotonic() < deadline:
            health = await telemetry.health()
            if health.is_armable and health.is_global_position_ok:
                break
            await asyncio.sleep(0.2)
        await action.arm()
        await action.set_takeoff_altitude(10.0)
        await action.takeoff()
        deadline = time.monotonic() + 15.0
        while time.monotonic() < deadline and not await telemetry.in_air():
            await asyncio.sleep(0.2)
        print(json.dumps({"health": vars(health), "in_air": await telemetry.in_air()}))

asyncio.run(main(int(sys.argv[1])))
'''


@pytest.mark.skipif(importlib.util.find_spec("mavsdk") is None, reason="mavsdk is in the test extra")
def test_mavsdk_reports_the_vehicle_armable_and_flies_its_takeoff(tmp_path):
    """MAVSDK reads health from SYS_STATUS bits, GPS_RAW_INT and HOME_POSITION; the stub with a
    GPS (the scenario's position error keys) must look like a healthy ArduCopter to it."""
    data = yaml.safe_load(PAPER.read_text())
    data["noise"].update(position_sigma_m=0.5, position_bias_sigma_m=1.0)
    scenario = tmp_path / "gps.yaml"
    scenario.write_text(yaml.safe_dump(data))
    stub = start_stub(tmp_path, "--speedup", "5", scenario=scenario)
    try:
        done = subprocess.run([sys.executable, "-c", MAVSDK_CLIENT, str(stub.tcp_port)],
                              capture_output=True, text=True, timeout=60, cwd=tmp_path)
    finally:
        assert stub.stop() == 0
    assert done.returncode == 0, done.stdout + done.stderr
    result = json.loads(done.stdout.strip().splitlines()[-1])
    assert all(result["health"].values()), result       # calibrations, positions, home, armable
    assert result["in_air"], result
