"""The service in 3D on ArduPilot's own ArduCopter SITL (issue 27): config/scenarios/lowwall.yaml
(a 3 m wall of posts across the paper's leg, a 40 m tower beside it) with avoidance.vertical, the
stub's camera beside the autopilot reporting the points' z from LOCAL_POSITION_NED. The vehicle
climbs over the wall and comes back down, clearance >= d in 3D, no setpoint while landed.

Needs ARDUCOPTER_SITL and ARDUCOPTER_DEFAULTS as tests/e2e/test_ardupilot.py; skipped otherwise.
Checked on the ground station's truth (SIMSTATE position, GLOBAL_POSITION_INT altitude)."""
from __future__ import annotations

import json
import math
import subprocess
import sys

import pytest
import yaml

from tests.e2e.support import REPO
from tests.e2e.test_ardupilot import DEFAULTS, SITL, SPEEDUP, TIMEOUT_S

LOWWALL = REPO / "config" / "scenarios" / "lowwall.yaml"
D_M = 10.0

pytestmark = [
    pytest.mark.ardupilot,
    pytest.mark.skipif(not (SITL and DEFAULTS),
                       reason="ArduCopter SITL not given: set ARDUCOPTER_SITL (binary) and "
                              "ARDUCOPTER_DEFAULTS (parm file) to fly it"),
]


def test_ardupilot_climbs_over_a_low_wall_and_comes_back_down(tmp_path):
    done = subprocess.run(
        [sys.executable, "-m", "companion", "-v", "demo", "--scenario", str(LOWWALL),
         "--autopilot", SITL, "--autopilot-defaults", DEFAULTS, "--speedup", str(SPEEDUP),
         "--seed", "1", "--json", str(tmp_path / "demo.json"), "--keep", str(tmp_path / "work")],
        capture_output=True, text=True, cwd=REPO, timeout=TIMEOUT_S)
    assert done.returncode == 0, done.stderr[-4000:]
    result = json.loads((tmp_path / "demo.json").read_text())
    assert result["aggregate"]["success_rate"] == 1.0, result["aggregate"]
    report = json.loads((tmp_path / "work" / "companion-report.json").read_text())
    rows = [json.loads(line) for line in (tmp_path / "work" / "truth.jsonl").open()]
    flying = [r for r in rows if r["armed"] and r["alt_m"] is not None
              and r["t_s"] <= report["arrival_t_s"]]
    tops = {o["id"]: o["height_m"] for o in yaml.safe_load(LOWWALL.read_text())["world"]["obstacles"]}

    def clearance(r, o):
        horizontal = math.hypot(r["north_m"] - o["north_m"], r["east_m"] - o["east_m"])
        over = r["alt_m"] - tops[o["id"]]
        return math.hypot(horizontal, over) if over > 0.0 else horizontal

    airborne = [r for r in flying if r["alt_m"] >= 9.5]
    assert min(clearance(r, o) for r in airborne for o in r["obstacles"]) >= D_M
    at_wall = [r for r in airborne if abs(r["north_m"] - 100.0) <= 2.0]
    assert at_wall and all(r["alt_m"] >= 3.0 + D_M and abs(r["east_m"]) < 30.0 for r in at_wall)
    assert abs(flying[-1]["alt_m"] - 10.0) < 1.0                      # back at the cruise altitude
    assert max(r["alt_m"] for r in flying) <= 30.0
    assert "while landed 0 (service's own view 0)" in done.stdout + done.stderr
