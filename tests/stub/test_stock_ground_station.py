"""A stock ground station, MAVProxy, connects to the stub's TCP port and sees an ArduCopter:
the vehicle and its camera detected, the flight mode named by ArduCopter's numbering, the whole
parameter set downloaded, arming acknowledged."""
from __future__ import annotations

import shutil
import subprocess
import sys
import time
from pathlib import Path

import pytest

from tests.stub.support import start_stub

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
