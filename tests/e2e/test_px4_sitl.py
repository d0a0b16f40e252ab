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

# In the slow suite (`pytest -m slow`), not the default run: on 2026-12-06 one of about five
# `companion` flights ended with the estimate 4.1 m off PX4's ground truth (pose NEES 105), not
# reached by the truth while the service declared arrival; the same offset as after a kill -9
# (docs/results/px4.md). Until that is understood, a real-time flight that fails one run in five
# would make every CI run a lottery.
pytestmark = [
    pytest.mark.px4,
    pytest.mark.slow,
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


@pytest.mark.slow
def test_killed_between_the_posts_px4_holds_and_a_new_service_takes_over(tmp_path):
    """kill -9 at north 88 m: PX4's offboard-loss fallback (COM_OBL_RC_ACT 5, set by the demo as
    docs/real-vehicle.md says) holds the vehicle after COM_OF_LOSS_T; the new service's stream
    brings OFFBOARD back (still the user's mode), and it flies on clear of the posts to report
    arrival. (The scorer's reached_goal is not asserted: it measures the new estimate against
    PX4's ground truth, 5.5 m apart at arrival in the first flight measured, docs/results/px4.md.)
    In the slow suite: of its two flights on 2026-12-06 the second came to 9.16 m of a post
    (below the 9.5 m asserted), so it is not in the default run that .ci/run makes beside a
    PX4 build until that is understood."""
    companion("demo", "--scenario", "config/scenarios/paper.yaml", "--px4", PX4_DIR,
              "--px4-kill-at-north", "88", "--json", str(tmp_path / "o.json"),
              "--keep", str(tmp_path), timeout_s=TIMEOUT_S)
    result = json.loads((tmp_path / "o.json").read_text())
    run, flight = result["runs"][0], result["flight"]
    print(json.dumps({"run": run, "flight": flight}))
    assert flight["killed_north_m"] >= 88.0 and flight["fallback"] == "AUTO.LOITER"
    assert flight["fallback_t_s"] - flight["killed_t_s"] <= 1.0 + 1.5     # COM_OF_LOSS_T + a beat
    assert flight["restarted_t_s"] < flight["offboard_again_t_s"]
    assert run["min_clearance_m"] >= 9.5 and not run["collided"]
    assert flight["setpoints_while_landed"] == 0
    report = json.loads((tmp_path / "companion-report.json").read_text())
    assert report["arrived"] and report["look_around"]["end_reason"].startswith("full circle")
