"""The camera beside any autopilot (sans-I/O): vehicle, requests, placement, clock, frames."""
import dataclasses
import math

import numpy as np
import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from sitl_stub.external_camera import ExternalCamera, Placement
from sitl_stub.world import load_scenario

from .support import PAPER

SCENARIO = load_scenario(PAPER)           # origin (-35.363261, 149.165230); obstacles (60, 5), (120, 0)
QUIET = dataclasses.replace(SCENARIO, sensor=dataclasses.replace(
    SCENARIO.sensor, range_sigma_m=0.0, bearing_sigma_rad=0.0))
_parser = mavlink.MAVLink(None)


def heard(sysid: int, compid: int, msg):
    """msg as it arrives from (sysid, compid): packed and parsed, so it carries its header."""
    return _parser.parse_buffer(msg.pack(mavlink.MAVLink(None, sysid, compid)))[0]


def autopilot_heartbeat(armed=False, sysid=7):
    base = mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED | (
        mavlink.MAV_MODE_FLAG_SAFETY_ARMED if armed else 0)
    return heard(sysid, 1, mavlink.MAVLink_heartbeat_message(
        mavlink.MAV_TYPE_QUADROTOR, mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA, base, 4, 3, 3))


def origin_at(north_m: float, east_m: float, sysid=7):
    lat, lon = SCENARIO.world.origin.to_lat_lon_deg(north_m, east_m)
    return heard(sysid, 1, mavlink.MAVLink_gps_global_origin_message(
        int(round(lat * 1e7)), int(round(lon * 1e7)), 584000, 0))


def attitude(t_ms: int, yaw_rad: float = 0.0, sysid=7):
    return heard(sysid, 1, mavlink.MAVLink_attitude_message(t_ms, 0, 0, yaw_rad, 0, 0, 0))


def position(t_ms: int, x_m: float, y_m: float, sysid=7):
    return heard(sysid, 1, mavlink.MAVLink_local_position_ned_message(t_ms, x_m, y_m, -10, 0, 0, 0))


def ready_camera(scenario=QUIET, origin=(20.0, 0.0), **kwargs) -> ExternalCamera:
    cam = ExternalCamera(scenario, np.random.default_rng(0), **kwargs)
    cam.handle(autopilot_heartbeat(), 0.0)
    if origin is not None:
        cam.handle(origin_at(*origin), 0.0)
    return cam


def fly(cam, t0_ms: int, t1_ms: int, step_ms: int = 100, north_m=20.0, east_m=0.0, yaw_rad=0.0,
        wall_s: float = 0.0) -> list:
    out = []
    for t_ms in range(t0_ms, t1_ms, step_ms):
        out += cam.handle(attitude(t_ms, yaw_rad), wall_s)
        out += cam.handle(position(t_ms, north_m, east_m), wall_s)
    return out


def of_type(msgs, kind):
    return [m for m in msgs if m.get_type() == kind]


def test_it_learns_the_vehicle_then_asks_for_pose_and_ekf_origin():
    cam = ExternalCamera(SCENARIO, np.random.default_rng(0))
    gcs = heard(255, 190, mavlink.MAVLink_heartbeat_message(
        mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0, 3))
    assert cam.handle(gcs, 0.0) == [] and cam.sysid is None
    out = cam.handle(autopilot_heartbeat(sysid=7), 0.0)
    assert cam.sysid == 7
    commands = of_type(out, "COMMAND_LONG")
    intervals = {(c.param1, c.param2) for c in commands
                 if c.command == mavlink.MAV_CMD_SET_MESSAGE_INTERVAL}
    assert intervals == {(mavlink.MAVLINK_MSG_ID_LOCAL_POSITION_NED, 1e5),
                         (mavlink.MAVLINK_MSG_ID_ATTITUDE, 1e5)}
    assert any(c.command == mavlink.MAV_CMD_REQUEST_MESSAGE
               and c.param1 == mavlink.MAVLINK_MSG_ID_GPS_GLOBAL_ORIGIN for c in commands)
    assert all((c.target_system, c.target_component) == (7, 1) for c in commands)
    assert len(of_type(out, "HEARTBEAT")) == 1
    # asked again while nothing comes, not more often than every 2 s of wall time
    assert of_type(cam.poll(1.0), "COMMAND_LONG") == []
    assert len(of_type(cam.poll(2.5), "COMMAND_LONG")) == 3


def test_no_frame_until_the_ekf_origin_places_the_scenario():
    cam = ready_camera(origin=None)
    assert of_type(fly(cam, 1000, 3000, north_m=20.0), "OBSTACLE_DISTANCE_3D") == []
    cam.handle(origin_at(20.0, 0.0), 3.0)
    assert cam.placement.north_m == pytest.approx(20.0, abs=0.01)
    assert cam.placement.east_m == pytest.approx(0.0, abs=0.01)
    # local (20, 0) is scenario (40, 0): obstacle 1 at (60, 5) is 20 m ahead, 5 m right
    reports = of_type(fly(cam, 3000, 3100, north_m=20.0), "OBSTACLE_DISTANCE_3D")
    assert [r.obstacle_id for r in reports] == [1]
    assert reports[0].x == pytest.approx(20.0, abs=0.02)
    assert reports[0].y == pytest.approx(5.0, abs=0.02)
    assert reports[0].time_boot_ms == 3000 and reports[0].frame == mavlink.MAV_FRAME_BODY_FRD


def test_the_given_ekf_origin_wins_over_the_autopilots():
    cam = ready_camera(origin=(0.0, 0.0), placement=Placement(20.0, 0.0, "--ekf-origin"))
    assert cam.placement == Placement(20.0, 0.0, "--ekf-origin")
    reports = of_type(fly(cam, 1000, 1100, north_m=20.0), "OBSTACLE_DISTANCE_3D")
    assert reports and reports[0].x == pytest.approx(20.0, abs=0.02)


def test_bearing_uses_the_attitude_yaw():
    cam = ready_camera()
    # facing east at scenario (60, -15): obstacle 1 at (60, 5) dead ahead, 20 m
    reports = of_type(fly(cam, 1000, 1100, north_m=40.0, east_m=-15.0, yaw_rad=math.pi / 2),
                      "OBSTACLE_DISTANCE_3D")
    assert [r.obstacle_id for r in reports] == [1]
    assert reports[0].x == pytest.approx(20.0, abs=0.02) and abs(reports[0].y) < 0.02


def test_frames_and_heartbeats_run_on_the_autopilots_clock():
    cam = ready_camera()
    out = fly(cam, 1000, 11000, wall_s=0.5)     # 10 s of autopilot time within no wall time
    frames = {r.time_boot_ms for r in of_type(out, "OBSTACLE_DISTANCE_3D")}
    assert len(frames) == 50                      # 5 Hz of autopilot time
    assert sorted(frames)[:3] == [1000, 1200, 1400]
    assert 9 <= len(of_type(out, "HEARTBEAT")) <= 11


def test_a_reboot_forgets_the_placement():
    cam = ready_camera()
    assert of_type(fly(cam, 50_000, 51_000), "OBSTACLE_DISTANCE_3D")
    assert of_type(fly(cam, 1000, 2000), "OBSTACLE_DISTANCE_3D") == []
    assert cam.counters["reboots"] == 1 and cam.placement is None
    cam.handle(origin_at(20.0, 0.0), 1.0)
    assert of_type(fly(cam, 2000, 2200), "OBSTACLE_DISTANCE_3D")


def test_moving_obstacles_start_when_the_vehicle_arms():
    world = dataclasses.replace(QUIET.world, obstacles=(dataclasses.replace(
        QUIET.world.obstacles[0], vel_east_mps=1.0),))
    cam = ready_camera(scenario=dataclasses.replace(QUIET, world=world))
    before = of_type(fly(cam, 30_000, 30_100), "OBSTACLE_DISTANCE_3D")
    assert before[0].y == pytest.approx(5.0, abs=0.02)   # 30 s after boot, not moved yet
    cam.handle(autopilot_heartbeat(armed=True), 0.0)
    after = of_type(fly(cam, 30_100, 33_100), "OBSTACLE_DISTANCE_3D")
    assert after[-1].y == pytest.approx(5.0 + 3.0, abs=0.05)   # armed at 30.0 s, seen at 33.0 s


def test_the_sector_form_when_asked():
    cam = ready_camera(sectors=True)
    out = fly(cam, 1000, 1100, north_m=20.0)
    (sectors,) = of_type(out, "OBSTACLE_DISTANCE")
    assert len(of_type(out, "OBSTACLE_DISTANCE_3D")) == 1
    # the surface, in cm (the EKF origin's 1e-7 degree rounding is about 1 cm)
    assert abs(min(sectors.distances) - (math.hypot(20.0, 5.0) - 2.0) * 100) <= 2
    assert of_type(fly(ready_camera(), 1000, 1100, north_m=20.0), "OBSTACLE_DISTANCE") == []


def test_a_frame_that_sees_nothing_is_still_sent():
    """An empty frame (every sector beyond max_distance) tells the companion the camera is live:
    it judges liveness by obstacle messages, never by heartbeats (without this the service held
    the real ArduCopter at the start, the first obstacle 40.3 m away, out of range)."""
    out = fly(ready_camera(), 1000, 1100, north_m=0.0)
    assert of_type(out, "OBSTACLE_DISTANCE_3D") == []
    (empty,) = of_type(out, "OBSTACLE_DISTANCE")
    assert all(d > empty.max_distance for d in empty.distances)


def test_commands_to_the_camera_are_unsupported():
    cam = ready_camera()
    cmd = heard(255, 190, mavlink.MAVLink_command_long_message(
        7, 100, mavlink.MAV_CMD_REQUEST_MESSAGE, 0, 0, 0, 0, 0, 0, 0, 0))
    (ack,) = cam.handle(cmd, 0.0)
    assert ack.result == mavlink.MAV_RESULT_UNSUPPORTED
    assert (ack.target_system, ack.target_component) == (255, 190)


def test_data_streams_too_only_if_no_interval_request_was_accepted():
    def requests(cam, polls):
        out = []
        for k in range(polls):
            out += cam.poll(10.0 + 2.5 * k)
        return [m for m in out if m.get_type() == "REQUEST_DATA_STREAM"]
    silent = ready_camera()
    assert requests(silent, 2) == []
    assert {m.req_stream_id for m in requests(silent, 4)} == {
        mavlink.MAV_DATA_STREAM_POSITION, mavlink.MAV_DATA_STREAM_EXTRA1}
    acked = ready_camera()
    acked.handle(heard(7, 1, mavlink.MAVLink_command_ack_message(
        mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, mavlink.MAV_RESULT_ACCEPTED, 0, 0, 7, 100)), 0.0)
    assert requests(acked, 6) == []


WALLS = load_scenario(str(PAPER.parent / "walls.yaml"))   # sensor.form: sectors; a wall at 65 m north


def test_a_depth_camera_beside_the_autopilot_sees_walls_in_its_sectors():
    quiet = dataclasses.replace(WALLS, sensor=dataclasses.replace(
        WALLS.sensor, range_sigma_m=0.0, bearing_sigma_rad=0.0, miss_probability=0.0,
        false_alarm_rate_hz=0.0))
    cam = ready_camera(quiet)
    out = fly(cam, 1000, 1100, north_m=20.0)                    # the EKF origin is 20 m north
    assert of_type(out, "OBSTACLE_DISTANCE_3D") == []           # a depth camera: sectors only
    (sectors,) = of_type(out, "OBSTACLE_DISTANCE")
    # the wall's face at 65 - 0.2 m north, 40 m north of the origin: 24.8 m ahead
    seen = [d for d in sectors.distances if d <= sectors.max_distance]
    assert seen and abs(min(seen) - 2480) <= 3
    assert cam.counters["sector_messages"] == 1 and cam.counters["reports"] == 0
