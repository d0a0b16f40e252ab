"""Issue 31's crash and restart on ArduPilot's own ArduCopter SITL: the paper's scenario flown by
the service from boot (the stub's camera beside the autopilot), the service SIGKILLed between
the two posts, ArduCopter's GUIDED timeout (GUID_TIMEOUT 3 s) stopping the vehicle, a new
service started 3 s of vehicle time later (as systemd's Restart=on-failure would): it finds the
vehicle, starts its estimator from the autopilot's pose and finishes the flight.

Checked: arrival declared and the truth (SIMSTATE) within the radius + 2 m of the goal, closest
approach >= 9.5 m over the whole flight, the vehicle at rest from the stop to the restart (it
flies only on setpoints: none came from the dead process), the new service's setpoints all
after its start. Needs ARDUCOPTER_SITL and ARDUCOPTER_DEFAULTS (tests/e2e/test_ardupilot.py);
real SITL at x10: about 16 s of wall time.

Not met yet (xfail): four runs, closest approach 8.39, 8.01, 7.72 and 10.47 m, each after the
restart. Killed at 91-93 m, ArduCopter flies 3 s on the last setpoint and brakes, stopping at
about (112, -8.9): 12 m from the second post (120, 0), which is 58 deg off the nose (yaw -10
deg) and so outside the 90 deg camera (the pass: killed at 89.3 m, stopped at (109.3, -7.3)). The new service starts with an empty map, turns for the
goal and sees the post only when already inside its 10 m. Everything else holds (the stop, the
rest, no old setpoint, arrival). On the stub the same kill moments pass (its unicycle stops
sooner, nose along its course). The fix would be a look before moving after a start in the air
(a yaw in place over the camera's blind sides, or the map kept across restarts): not done."""
from __future__ import annotations

import asyncio
import json
import math
from pathlib import Path

import pytest

from companion.config.scenario import load_scenario
from companion.tools.autopilot_demo import AutopilotFiles, AutopilotSetup, run_autopilot_demo
from tests.e2e.support import PAPER
from tests.e2e.test_ardupilot import DEFAULTS, SITL, service_setpoints

GUID_TIMEOUT_S = 3.0
KILL_AT_NORTH_M = 88.0
GOAL_TOLERANCE_M = 2.0 + 2.0

pytestmark = [
    pytest.mark.ardupilot,
    pytest.mark.skipif(not (SITL and DEFAULTS),
                       reason="ArduCopter SITL not given: set ARDUCOPTER_SITL (binary) and "
                              "ARDUCOPTER_DEFAULTS (parm file) to fly it"),
]


@pytest.mark.xfail(reason="the restarted service passes the unseen second post at 7.7-8.4 m "
                          "(module docstring)", strict=False)
def test_ardupilot_service_killed_between_the_posts_restarts_and_finishes(tmp_path):
    scenario = load_scenario(PAPER)
    files = AutopilotFiles(tmp_path / "work", tmp_path / "work" / "companion.tlog")
    files.workdir.mkdir()
    setup = AutopilotSetup(Path(SITL).resolve(), Path(DEFAULTS).resolve(),
                           kill_at_north_m=KILL_AT_NORTH_M)
    report, _, truth, _ = asyncio.run(run_autopilot_demo(PAPER, scenario, files, 10.0, 0, setup))
    crash = json.loads((files.workdir / "crash.json").read_text())
    print(f"ArduCopter crash-restart: {crash}, arrival {report.get('arrival_t_s')}")
    # within 1.5 s of cruise: the ground station polls at 50 ms of wall time, 0.5 s at x10
    assert KILL_AT_NORTH_M <= crash["killed_north_m"] <= KILL_AT_NORTH_M + 7.5
    assert crash["killed_speed_mps"] > 1.0
    # stopped by the GUIDED timeout: 3 s on the last setpoint, then ArduCopter's braking
    assert GUID_TIMEOUT_S <= crash["stopped_t_s"] - crash["killed_t_s"] <= GUID_TIMEOUT_S + 6.0
    rows = [r for r in truth if r["armed"]]
    between = [r for r in rows if crash["stopped_t_s"] <= r["t_s"] <= crash["restarted_t_s"]]
    assert len(between) >= 3
    assert max(r["speed_mps"] for r in between) < 0.3
    spread = max(math.hypot(r["north_m"] - between[0]["north_m"],
                            r["east_m"] - between[0]["east_m"]) for r in between)
    assert spread < 0.5
    # the new service commanded only after its start, and it finished the flight
    second = service_setpoints(files.tlog.with_name(files.tlog.name + ".restarted"))
    assert len(second) > 20 and second[0][0] >= crash["restarted_t_s"]
    assert report["arrived"]
    end = [r for r in rows if r["t_s"] >= report["arrival_t_s"]][0]
    goal = scenario.world.goal
    assert math.hypot(end["north_m"] - goal.north_m, end["east_m"] - goal.east_m) \
        <= GOAL_TOLERANCE_M
    flying = [r for r in rows if (r["alt_m"] or 0.0) > 5.0 and r["t_s"] <= report["arrival_t_s"]]
    clearance = min(math.hypot(r["north_m"] - o["north_m"], r["east_m"] - o["east_m"])
                    for r in flying for o in r["obstacles"])
    print(f"closest approach {clearance:.2f} m")
    assert clearance >= 9.5
