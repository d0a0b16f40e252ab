"""The paper's leg on PX4's own SITL with its SIH simulator (`companion demo --px4 DIR`): the
service up from boot, PX4 armed once its preflight checks pass, NAV_TAKEOFF to an AMSL altitude,
OFFBOARD entered as configured, the stub's camera beside the autopilot.

Needs a PX4 SITL build (a folder with bin/px4 and etc/, e.g. PX4-Autopilot's
build/px4_sitl_default) named by PX4_SITL_DIR (.ci/run passes it on where the machine has one);
skipped otherwise. Checked: reached, clearance >= 9.5 m by PX4's ground truth, no setpoint while
landed (the service's tlog against the ground station's landed state), OFFBOARD by the one
configured to switch."""
from __future__ import annotations

import json
import os
from pathlib import Path

import pytest

from tests.e2e.test_demo_replay import companion

PX4_DIR = os.environ.get("PX4_SITL_DIR")
HAVE_PX4 = bool(PX4_DIR) and (Path(PX4_DIR) / "bin" / "px4").is_file() \
    and (Path(PX4_DIR) / "etc").is_dir()
TIMEOUT_S = 400                   # boot (~35 s), take-off, the leg in real time, with margin

pytestmark = [
    pytest.mark.px4,
    pytest.mark.skipif(not HAVE_PX4, reason="PX4 SITL not given: set PX4_SITL_DIR to a PX4 "
                                            "SITL build (a folder with bin/px4 and etc/)"),
]


@pytest.mark.parametrize("offboard", ["operator", "companion"])
def test_the_paper_leg_on_px4_sitl(tmp_path, offboard):
    done = companion("demo", "--scenario", "config/scenarios/paper.yaml", "--px4", PX4_DIR,
                     "--px4-offboard", offboard, "--json", str(tmp_path / "o.json"),
                     "--keep", str(tmp_path), timeout_s=TIMEOUT_S)
    assert done.returncode == 0, done.stdout + done.stderr[-3000:]
    result = json.loads((tmp_path / "o.json").read_text())
    run, flight = result["runs"][0], result["flight"]
    print(json.dumps({"offboard": offboard, "run": run, "flight": flight}))
    assert run["reached_goal"] and run["min_clearance_m"] >= 9.5
    assert flight["setpoints_while_landed"] == 0
    assert flight["setpoints_while_landed_by_service_tlog"] == 0
    armed = [name for _, name, is_armed in flight["modes"] if is_armed]
    assert "OFFBOARD" in armed
    service = flight["service_offboard"]
    assert (service["requests"] == 0) if offboard == "operator" else service["engaged_by_us"]
