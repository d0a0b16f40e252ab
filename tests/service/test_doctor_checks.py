"""companion doctor's pure parts: the observer (messages -> facts), the verdicts (facts ->
checklist, onboard/doctor_checks.py and doctor_params.py) and what it may send."""
import dataclasses

import pytest

from companion.config.service import load_config
from companion.daemon.streams import STREAMS
from companion.mavlink import codec
from companion.mavlink import doctor_codec as dc
from companion.mavlink.dialect import mavlink
from companion.core.estimation.slam_types import Observation
from companion.onboard.doctor_checks import blockers, evaluate
from companion.onboard.doctor_facts import CameraFacts, Facts, Observer
from companion.onboard.doctor_params import PX4, judge_px4

CONFIG = load_config("config/companion.yaml")
NEEDED = {msg_id: getattr(CONFIG.streams, key) for msg_id, key in STREAMS}
HB = dc.HeartbeatInfo(1, 1, dc.AUTOPILOT_ARDUPILOT, 2, 0x59, 5, 3)
SECTORS = dc.ObstacleLayout(1, 100, dc.MSG_ID_OBSTACLE_DISTANCE, 12, 0.2, 40.0, -44.375, 1.25,
                            72, 0, 71)
GOOD = Facts(
    listened_s=10.0, measured_s=8.0, vehicle=HB, other_autopilots=(),
    firmware=dc.FirmwareVersion(1, 1, 4, 6, 0, "official", 0),
    rates_hz={msg_id: hz for msg_id, hz in NEEDED.items()}, streams_asked=True,
    origin=(-35.36, 149.16), gps=codec.GpsFix(1, 1, 3, 0.7, None, 12), ekf_flags=0x33f,
    position_trusted=True,
    camera=CameraFacts(100, True, {dc.MSG_ID_OBSTACLE_DISTANCE: 10.0}, 10.0, {}, (SECTORS,), {},
                       40, 12.0, 38.0),
    round_trips_ms=(3.0, 4.0), timesync_sent=2, signed=0, unsigned=300, signature_rejected=0,
    params={"GUID_TIMEOUT": 3.0, "WPNAV_ACCEL": 250.0, "PRX1_TYPE": 0.0, "AVOID_ENABLE": 3.0,
            "AVOID_MARGIN": 2.0, "OA_TYPE": 0.0},
    params_asked=())


def facts(**changes) -> Facts:
    return dataclasses.replace(GOOD, **changes)


def camera(**changes) -> CameraFacts:
    return dataclasses.replace(GOOD.camera, **changes)


def by_name(checks) -> dict:
    return {c.name: c for c in checks}


def with_params(**params) -> Facts:
    return facts(params={**GOOD.params, **params})


def test_a_ready_vehicle_is_every_line_ok():
    checks = evaluate(GOOD, CONFIG, NEEDED)
    assert [c for c in checks if c.status != "ok"] == []
    names = by_name(checks)
    assert "ArduPilot" in names["vehicle"].measured and "4.6.0" in names["vehicle"].measured
    assert {f"stream {dc.message_name(m)} ({m})" for m in NEEDED} <= set(names)
    assert "15.0 m" in names["GUID_TIMEOUT"].measured      # 3 s x 5 m/s, more than d = 10 m


def test_no_vehicle_is_a_blocker_with_what_to_do():
    checks = evaluate(facts(vehicle=None), CONFIG, NEEDED)
    (failed,) = blockers(checks)
    assert failed.name == "vehicle" and "URL" in failed.todo


def test_a_silent_camera_is_named_and_one_on_another_component_is_pointed_at():
    checks = by_name(evaluate(facts(camera=camera(msgs_hz={}, frames_hz=0.0, heartbeat=False,
                                                  layouts=(), observations=0)), CONFIG, NEEDED))
    assert checks["camera"].status == "fail" and "component 100" in checks["camera"].measured
    moved = by_name(evaluate(facts(camera=camera(msgs_hz={}, frames_hz=0.0, ignored={197: 50})),
                             CONFIG, NEEDED))["camera"]
    assert moved.status == "fail" and "camera_component_id: 197" in moved.todo


def test_a_slow_stream_is_named_with_its_rate_and_a_missing_odometry_stream_blocks():
    slow = by_name(evaluate(facts(rates_hz={**GOOD.rates_hz, 32: 2.0}), CONFIG, NEEDED))
    line = slow["stream LOCAL_POSITION_NED (32)"]
    assert line.status == "warn" and "2.0 Hz, needs 10 Hz" in line.measured
    none = by_name(evaluate(facts(rates_hz={**GOOD.rates_hz, 30: 0.0}), CONFIG, NEEDED))
    assert none["stream ATTITUDE (30)"].status == "fail"


def test_guid_timeout_beyond_the_checked_horizon_is_a_warning_with_the_cost():
    line = by_name(evaluate(with_params(GUID_TIMEOUT=5.0), CONFIG, NEEDED))["GUID_TIMEOUT"]
    assert line.status == "warn" and "25.0 m" in line.measured and "<= 4 s" in line.todo
    cone = dataclasses.replace(CONFIG, avoidance=dataclasses.replace(CONFIG.avoidance,
                                                                     strategy="cone"))
    assert by_name(evaluate(GOOD, cone, NEEDED))["GUID_TIMEOUT"].status == "warn"


def test_the_autopilot_accelerating_slower_than_planned_is_said():
    line = by_name(evaluate(with_params(WPNAV_ACCEL=150.0), CONFIG, NEEDED))["WPNAV_ACCEL"]
    assert line.status == "warn" and "max_accel_mps2: 1.5" in line.todo


def test_arducopters_own_avoidance_braking_inside_d_is_a_warning():
    margin = with_params(PRX1_TYPE=2.0, AVOID_ENABLE=3.0, AVOID_MARGIN=12.0)
    assert by_name(evaluate(margin, CONFIG, NEEDED))["proximity"].status == "warn"
    backstop = with_params(PRX1_TYPE=2.0, AVOID_ENABLE=3.0, AVOID_MARGIN=2.0)
    line = by_name(evaluate(backstop, CONFIG, NEEDED))["proximity"]
    assert line.status == "ok" and "backstop" in line.measured


def test_sector_angles_off_the_nose_and_a_wrong_frame_and_a_short_range():
    shifted = dataclasses.replace(SECTORS, angle_offset_deg=0.0)     # MAVROS's angle_offset 0
    line = by_name(evaluate(facts(camera=camera(layouts=(shifted,))), CONFIG, NEEDED))
    assert line["OBSTACLE_DISTANCE angles"].status == "warn"
    assert "+44.4 deg" in line["OBSTACLE_DISTANCE angles"].measured
    ned = dc.ObstacleLayout(1, 100, dc.MSG_ID_OBSTACLE_DISTANCE_3D, 1, 0.2, 40.0)
    line = by_name(evaluate(facts(camera=camera(layouts=(ned,))), CONFIG, NEEDED))
    assert line["OBSTACLE_DISTANCE_3D frame"].status == "fail"
    short = dataclasses.replace(SECTORS, max_distance_m=6.0)
    line = by_name(evaluate(facts(camera=camera(layouts=(short,))), CONFIG, NEEDED))
    assert line["OBSTACLE_DISTANCE angles"].status == "fail" and "< d" in \
        line["OBSTACLE_DISTANCE angles"].measured


def test_a_signing_vehicle_without_our_key_blocks():
    line = by_name(evaluate(facts(signed=300, unsigned=0), CONFIG, NEEDED))["signing"]
    assert line.status == "fail" and "signing_key_file" in line.todo


def test_the_steering_mode_needs_a_copter_and_a_position():
    no_position = by_name(evaluate(facts(ekf_flags=0x0007), CONFIG, NEEDED))["steering mode"]
    assert no_position.status == "fail" and "position" in no_position.measured
    plane = dataclasses.replace(HB, mav_type=mavlink.MAV_TYPE_FIXED_WING)
    assert by_name(evaluate(facts(vehicle=plane), CONFIG, NEEDED))["steering mode"].status == "fail"


def test_px4_is_named_and_its_parameters_judged_through_its_profile():
    px4 = dataclasses.replace(HB, autopilot=dc.AUTOPILOT_PX4)
    checks = by_name(evaluate(facts(vehicle=px4, params={"COM_OF_LOSS_T": 1.0,
                                                         "COM_OBL_RC_ACT": 6.0}),
                              CONFIG, NEEDED))
    assert "autopilot" not in checks                   # flown: no "not flown by this version"
    assert checks["steering mode"].measured.startswith("OFFBOARD")
    assert "GUIDED" not in checks["steering mode"].measured
    assert checks["COM_OF_LOSS_T"].status == "ok" and "5.0 m" in checks["COM_OF_LOSS_T"].measured
    assert checks["COM_OBL_RC_ACT"].status == "fail"
    hold = by_name(judge_px4(facts(params={"COM_OF_LOSS_T": 1.0, "COM_OBL_RC_ACT": 5.0}), CONFIG))
    assert hold["COM_OBL_RC_ACT"].status == "ok"
    assert PX4.params == ("COM_OF_LOSS_T", "COM_OBL_RC_ACT")


def _msg(m, sysid, compid):
    data = m.pack(mavlink.MAVLink(None, srcSystem=sysid, srcComponent=compid))
    return mavlink.MAVLink(None).decode(bytearray(data))


def feed(observer, t_s, m, sysid=1, compid=1):
    msg = _msg(m, sysid, compid)
    observer.observe(t_s, msg.get_msgId(), (sysid, compid), dc.is_signed(msg),
                     codec.decode(msg), dc.decode(msg))


def test_the_observer_finds_the_vehicle_measures_rates_and_keeps_what_the_camera_sends():
    obs = Observer(CONFIG, 0.0)
    feed(obs, 0.0, mavlink.MAVLink_heartbeat_message(6, 8, 0, 0, 4, 3), 255, 190)   # a GCS
    feed(obs, 0.1, mavlink.MAVLink_heartbeat_message(2, 3, 0x59, 5, 3, 3))
    feed(obs, 0.1, mavlink.MAVLink_heartbeat_message(30, 8, 0, 0, 4, 3), 1, 100)
    obs.streams_asked_at(0.5)                                 # measured from 1.5 s
    for k in range(50):                                       # 10 Hz from 1.5 s to 6.5 s
        feed(obs, 1.5 + 0.1 * k, mavlink.MAVLink_attitude_message(1500 + 100 * k, 0, 0, 0, 0,
                                                                  0, 0))
    feed(obs, 2.0, mavlink.MAVLink_obstacle_distance_3d_message(
        2000, 0, 12, 5, 20.0, 1.0, 0.0, 0.2, 40.0), 1, 100)
    feed(obs, 2.0, mavlink.MAVLink_obstacle_distance_3d_message(
        2000, 0, 12, 5, 20.0, 1.0, 0.0, 0.2, 40.0), 1, 197)    # another component: ignored
    feed(obs, 3.0, mavlink.MAVLink_param_value_message(b"GUID_TIMEOUT", 3.0, 9, 10, 3))
    result = obs.facts(6.5)
    assert (result.vehicle.system_id, result.vehicle.component_id) == (1, 1)
    assert result.rates_hz[30] == pytest.approx(10.0)
    assert result.camera.heartbeat and result.camera.ignored == {197: 1}
    assert result.camera.observations == 1 and result.camera.range_min_m == pytest.approx(20.025,
                                                                                        abs=1e-3)
    assert result.params == {"GUID_TIMEOUT": 3.0} and result.unsigned >= 52


@pytest.mark.parametrize("message, allowed", [
    (codec.set_message_interval(1, 1, 32, 10.0), True),
    (codec.request_message(1, 1, 49), True),
    (codec.request_data_stream(1, 1, 32, 10.0), True),
    (dc.param_request_read(1, 1, "GUID_TIMEOUT"), True),
    (codec.timesync_request(1), True),
    (codec.set_mode(1, 1, 4), False),
    (codec.arm(1, 1), False),
    (codec.takeoff(1, 1, 10.0), False),
    (mavlink.MAVLink_param_set_message(1, 1, b"GUID_TIMEOUT", 1.0, 9), False),
    (mavlink.MAVLink_set_position_target_local_ned_message(0, 1, 1, 1, 0x9C7, 0, 0, 0, 1, 0, 0,
                                                           0, 0, 0, 0, 0), False),
])
def test_the_doctor_may_send_only_what_cannot_command(message, allowed):
    assert dc.is_listen_only(message) is allowed
