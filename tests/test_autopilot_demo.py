"""`companion demo --autopilot`: frames, the ground station's record and checks, refusals.
(The flight itself: tests/e2e/test_ardupilot.py, with the real binary.)"""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

import pytest
import yaml

from companion.tools import ardupilot_sitl as sitl
from companion.__main__ import main
from companion.mavlink.dialect import mavlink
from companion.tools.autopilot_demo import (ARDUCOPTER_JERK_MPS3, ARDUCOPTER_YAW_LEAD_S,
                                            service_config, sitl_home)
from companion.tools.demo import demo_config
from companion.config.scenario import load_scenario
from companion.config.service import load_config
from companion.core.flat_earth import to_lat_lon_deg, to_north_east_m
from companion.tools.flight_record import FlightRecorder, takeoff_checks

REPO = Path(__file__).resolve().parents[1]
PAPER = load_scenario(REPO / "config" / "scenarios" / "paper.yaml")
_parser = mavlink.MAVLink(None)


def heard(msg, sysid=1, compid=1):
    return _parser.parse_buffer(msg.pack(mavlink.MAVLink(None, sysid, compid)))[0]


def test_home_is_the_start_and_the_goal_is_relative_to_it():
    home = sitl_home(PAPER)
    origin = PAPER.world.origin
    assert to_north_east_m(origin.lat_deg, origin.lon_deg, home.lat_deg, home.lon_deg) == \
        pytest.approx((20.0, 0.0), abs=1e-6)
    config = service_config(PAPER, 12.0)
    goal = config.goal
    assert goal.is_geographic and goal.radius_m == 2.0
    assert to_north_east_m(origin.lat_deg, origin.lon_deg, goal.lat_deg, goal.lon_deg) == \
        pytest.approx((180.0, 0.0), abs=1e-6)
    assert config.flight.takeoff_alt_m == 12.0


def test_the_filter_gets_the_autopilots_odometry_noise_and_the_scenarios_camera():
    """Beside ArduCopter the velocity and yaw are its EKF's, not the stub's noise model: the
    real-vehicle config's figures (2 deg yaw); the camera is the stub's: the scenario's R."""
    real = load_config(REPO / "config" / "companion.yaml").estimator
    estimator = service_config(PAPER, 10.0).estimator
    assert PAPER.estimator_config(flown_as="multicopter").yaw_sigma_deg != real.yaw_sigma_deg
    for key in ("yaw_sigma_deg", "yaw_rate_sigma_deg_s", "initial_yaw_sigma_deg",
                "vel_north_sigma_mps", "vel_east_sigma_mps", "yaw_bias_sigma_deg",
                "yaw_bias_tau_s"):
        assert getattr(estimator, key) == getattr(real, key), key
    # ArduCopter's ATTITUDE yaw is off by a bias for the whole flight: fused as one
    assert real.yaw_bias_sigma_deg > 0.0 and PAPER.noise.yaw_bias_sigma_deg == 0.0
    assert estimator.range_sigma_m == PAPER.sensor.range_sigma_m
    assert estimator.bearing_sigma_deg == PAPER.sensor.bearing_sigma_deg


def test_beside_arducopter_the_roll_outs_are_shaped_as_it_flies_unless_asked_not_to(tmp_path):
    """The stub's demo plans unshaped (its truth takes a velocity within max_accel at once);
    beside ArduCopter its jerk-limited response and yaw lag by default (the ceiling flight:
    8.67 m unshaped, 11.49 m shaped, README issue 27), the base's own values if it sets them,
    and --unshaped as on the stub."""
    assert demo_config(PAPER).commanding.max_jerk_mps3 is None
    shaped = service_config(PAPER, 10.0).commanding
    assert (shaped.max_jerk_mps3, shaped.yaw_lead_s) == (ARDUCOPTER_JERK_MPS3,
                                                         ARDUCOPTER_YAW_LEAD_S)
    unshaped = service_config(PAPER, 10.0, shaped=False).commanding
    assert (unshaped.max_jerk_mps3, unshaped.yaw_lead_s) == (None, None)
    base = yaml.safe_load((REPO / "config" / "companion.yaml").read_text())
    base["commanding"].update(max_jerk_mps3=8.0, yaw_lead_s=0.3)
    (tmp_path / "base.yaml").write_text(yaml.safe_dump(base))
    own = service_config(PAPER, 10.0, tmp_path / "base.yaml").commanding
    assert (own.max_jerk_mps3, own.yaw_lead_s) == (8.0, 0.3)


def test_unshaped_without_the_autopilot_is_refused():
    done = subprocess.run([sys.executable, "-m", "companion", "demo", "--unshaped"], cwd=REPO,
                          capture_output=True, text=True, timeout=60)
    assert done.returncode == 2 and "--unshaped is --autopilot's" in done.stderr


def test_flat_earth_round_trip():
    lat, lon = to_lat_lon_deg(-35.36, 149.16, 123.4, -56.7)
    assert to_north_east_m(-35.36, 149.16, lat, lon) == pytest.approx((123.4, -56.7), abs=1e-6)


def test_sitl_links_stay_on_loopback():
    command = sitl.sitl_command(Path("/x/arducopter"), Path("/x/copter.parm"), 7,
                                sitl.Home(-35.0, 149.0, 584.0, 0.0), 10.0,
                                sitl.SitlLinks(40001, 40002, 40003))
    serials = [command[i + 1] for i, arg in enumerate(command) if arg.startswith("--serial")]
    assert serials == ["udpclient:127.0.0.1:40001", "udpclient:127.0.0.1:40002",
                       "udpclient:127.0.0.1:40003"]
    assert command[command.index("-I") + 1] == "7" and "--speedup" in command


def test_the_recorder_pairs_simstate_with_the_attitude_before_it(tmp_path):
    rec = FlightRecorder(tmp_path / "truth.jsonl", PAPER, 100, 4)
    origin = PAPER.world.origin
    lat, lon = to_lat_lon_deg(origin.lat_deg, origin.lon_deg, 50.0, -3.0)
    armed = mavlink.MAV_MODE_FLAG_SAFETY_ARMED | mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
    rec.on_message(heard(mavlink.MAVLink_heartbeat_message(2, 3, 1, 4, 4, 3)))
    rec.on_message(heard(mavlink.MAVLink_heartbeat_message(30, 8, 0, 0, 4, 3), compid=100))
    for t_ms, base in ((41_000, 1), (42_000, armed), (43_000, 1)):
        rec.on_message(heard(mavlink.MAVLink_attitude_message(t_ms, 0, 0, 0.5, 0, 0, 0)))
        rec.on_message(heard(mavlink.MAVLink_heartbeat_message(2, 3, base, 4, 4, 3)))
        rec.on_message(heard(mavlink.MAVLink_extended_sys_state_message(0, 2)))
        rec.on_message(heard(mavlink.MAVLink_simstate_message(
            0, 0, 0.25, 0, 0, 0, 0, 0, 0, int(round(lat * 1e7)), int(round(lon * 1e7)))))
    rec.close()
    rows = [json.loads(line) for line in (tmp_path / "truth.jsonl").read_text().splitlines()]
    assert [r["t_s"] for r in rows] == [41.0, 42.0, 43.0]
    assert rows[0]["north_m"] == pytest.approx(50.0, abs=0.02)
    assert rows[0]["east_m"] == pytest.approx(-3.0, abs=0.02)
    assert rows[0]["yaw_rad"] == pytest.approx(0.25) and rows[1]["armed"]
    assert rows[0]["mode"] == "GUIDED" and rows[0]["landed_state"] == 2
    s = rec.state
    assert s.camera_seen and s.armed_t_s == 42.0 and s.disarmed_t_s == 43.0


def row(t_s, landed_state, alt_m, armed=True):
    return {"t_s": t_s, "landed_state": landed_state, "alt_m": alt_m, "armed": armed}


def test_takeoff_checks_count_setpoints_on_the_ground_and_a_disarm():
    truth = [row(40.0, 1, 0.0, armed=False), row(41.0, 1, 0.0), row(42.0, 3, 2.0),
             row(43.0, 2, 9.8), row(44.0, 2, 10.0), row(45.0, 1, 0.0, armed=False)]
    setpoints = [{"t_s": 41.5, "up_m": 0.0, "landed_state": None},
                 {"t_s": 43.5, "up_m": 9.8, "landed_state": 2},
                 {"t_s": 44.5, "up_m": 10.0, "landed_state": None}]
    checks = takeoff_checks(setpoints, truth, arrival_t_s=None)
    assert checks["setpoints_while_landed"] == 1
    assert checks["setpoints_while_landed_by_service_tlog"] == 1
    assert checks["first_setpoint_alt_m"] == 0.0
    assert checks["first_setpoint_landed_state"] == "on_ground"   # the ground station's view
    heard = [dict(setpoints[0], landed_state=2)] + setpoints[1:]
    assert takeoff_checks(heard, truth, None)["first_setpoint_landed_state"] == "in_air"
    assert checks["armed_t_s"] == 41.0 and checks["disarmed_before_arrival_t_s"] == 45.0
    assert takeoff_checks(setpoints[1:], truth, 44.8)["disarmed_before_arrival_t_s"] is None
    # without a landed state, the altitude decides
    unknown = [dict(r, landed_state=None) for r in truth]
    assert takeoff_checks(setpoints, unknown, None)["setpoints_while_landed"] == 1


def test_the_autopilot_demo_refuses_clearly(tmp_path, monkeypatch, capsys):
    """Through the CLI's entry in this process: each refusal comes before anything starts."""
    monkeypatch.delenv("ARDUCOPTER_DEFAULTS", raising=False)

    def companion_demo(*args):
        capsys.readouterr()
        code = main(["demo", *args])
        return SimpleNamespace(returncode=code, stderr=capsys.readouterr().err)
    done = companion_demo("--autopilot", str(tmp_path / "arducopter"))
    assert done.returncode == 2 and "--autopilot-defaults" in done.stderr
    parm = tmp_path / "copter.parm"
    parm.write_text("FRAME_CLASS 1\n")
    done = companion_demo("--autopilot", str(tmp_path / "arducopter"),
                          "--autopilot-defaults", str(parm))
    assert done.returncode == 2 and "no such file" in done.stderr
    done = companion_demo("--autopilot", str(tmp_path / "arducopter"),
                          "--autopilot-defaults", str(parm), "--drop-rate", "0.1")
    assert done.returncode == 2 and "not with --autopilot" in done.stderr


def test_a_disarm_before_arrival_stops_the_demo_with_the_autopilots_words():
    from companion.tools.autopilot_demo import _not_disarmed
    from companion.tools.demo import DemoError
    from companion.tools.flight_record import VehicleState
    state = VehicleState(armed_t_s=42.0, relative_alt_m=0.0,
                         status_texts=["42.0 s: Arming motors", "52.0 s: Disarming motors"])
    assert _not_disarmed(state)
    state.disarmed_t_s = 52.0
    with pytest.raises(DemoError, match=r"disarmed at 52.0 s \(armed at 42.0 s, 0.0 m above "
                                        r"home\)(.|\n)*52.0 s: Disarming motors"):
        _not_disarmed(state)
