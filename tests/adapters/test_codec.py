"""Codec: round trips through real MAVLink bytes, scalings, frames and refusals."""
import math

import pytest

from companion.mavlink import dialect
from companion.mavlink import codec
from companion.mavlink.dialect import mavlink


def roundtrip(msg, sysid=1, compid=1):
    """Pack with an Encoder, parse back with a Parser: the message the other side sees."""
    data = codec.Encoder(sysid, compid).encode(msg)
    parser = codec.Parser()
    (out,) = parser.feed(data)
    assert parser.bad_packets == 0
    return out


def test_heartbeat_roundtrip_reads_armed_and_mode():
    msg = mavlink.MAVLink_heartbeat_message(2, 3, mavlink.MAV_MODE_FLAG_SAFETY_ARMED | 1, 4, 4, 3)
    event = codec.decode(roundtrip(msg, 7, 1))
    assert event == codec.Heartbeat(7, 1, 2, True, True, 4, autopilot=3)


def test_our_heartbeat_is_an_onboard_controller_not_an_autopilot():
    event = codec.decode(roundtrip(codec.heartbeat(), 1, 191))
    assert event.mav_type == mavlink.MAV_TYPE_ONBOARD_CONTROLLER
    assert not event.is_autopilot and event.component_id == 191


def test_attitude_and_local_position_scale_time_boot_ms_to_seconds():
    att = codec.decode(roundtrip(mavlink.MAVLink_attitude_message(12345, 0, 0, 0.5, 0, 0, 0.1)))
    assert att.t_s == pytest.approx(12.345) and att.yaw_rad == pytest.approx(0.5)
    assert att.yaw_rate_rad_s == pytest.approx(0.1)
    lpn = codec.decode(roundtrip(mavlink.MAVLink_local_position_ned_message(
        2000, 10.0, -3.0, 0.0, 4.0, 3.0, 0.0)))
    assert (lpn.t_s, lpn.north_m, lpn.east_m) == (2.0, 10.0, -3.0)
    assert math.hypot(lpn.vel_north_mps, lpn.vel_east_mps) == pytest.approx(5.0)


def test_obstacle_3d_body_frd_gives_range_and_right_positive_bearing():
    msg = mavlink.MAVLink_obstacle_distance_3d_message(
        5000, 0, mavlink.MAV_FRAME_BODY_FRD, 7, 30.0, 40.0, 0.0, 0.2, 60.0)
    frame = codec.decode(roundtrip(msg, 1, 100))
    (obs,) = frame.observations
    assert frame.t_s == 5.0 and frame.component_id == 100
    assert obs.range_m == pytest.approx(50.0)
    assert obs.bearing_rad == pytest.approx(math.atan2(40.0, 30.0), abs=1e-6)
    assert obs.obstacle_id == 7


def test_obstacle_3d_without_id_and_in_another_frame():
    no_id = mavlink.MAVLink_obstacle_distance_3d_message(
        1, 0, mavlink.MAV_FRAME_BODY_FRD, 65535, 10.0, -10.0, 0.0, 0.2, 60.0)
    (obs,) = codec.decode(roundtrip(no_id)).observations
    assert obs.obstacle_id is None and obs.bearing_rad == pytest.approx(-math.pi / 4)
    ned = mavlink.MAVLink_obstacle_distance_3d_message(
        1, 0, mavlink.MAV_FRAME_LOCAL_NED, 3, 10.0, 0.0, 0.0, 0.2, 60.0)
    frame = codec.decode(roundtrip(ned))
    assert frame.observations == () and "BODY_FRD" in frame.rejected


def test_obstacle_distance_sectors_follow_the_spec_offset_and_skip_empty():
    distances = [4001] * 72
    distances[0] = 1500          # element 0 sits at angle_offset exactly
    distances[36] = 2000         # offset + 36 * 1.25 deg = 0 deg: straight ahead
    distances[10] = 65535        # unknown
    msg = mavlink.MAVLink_obstacle_distance_message(
        3_000_000, 0, distances, 1, 20, 4000, 1.25, -45.0, mavlink.MAV_FRAME_BODY_FRD)
    frame = codec.decode(roundtrip(msg))
    assert frame.t_s == 3.0
    ranges = sorted((round(o.range_m, 3), round(math.degrees(o.bearing_rad), 6))
                    for o in frame.observations)
    assert ranges == [(15.0, -45.0), (20.0, 0.0)]
    assert all(o.obstacle_id is None for o in frame.observations)


def test_setpoint_roundtrip_is_velocity_and_yaw_in_local_ned():
    sp = codec.VelocitySetpoint(1, 1, 12.3456, 3.0, -4.0, -0.9, "goal")
    msg = roundtrip(codec.set_position_target(sp), 1, 191)
    assert msg.type_mask == 0x09C7 and msg.coordinate_frame == mavlink.MAV_FRAME_LOCAL_NED
    assert msg.time_boot_ms == 12346
    assert (msg.vx, msg.vy, msg.vz) == (3.0, -4.0, 0.0)
    assert msg.yaw == pytest.approx(-0.9)
    assert (msg.target_system, msg.target_component) == (1, 1)


def test_odometry_carries_pose_and_upper_triangle_covariance():
    cov = ((0.04, 0.01, 0.002), (0.01, 0.09, 0.003), (0.002, 0.003, 0.0004))
    pose = codec.PoseEstimate(7.5, 100.0, -2.0, 0.3, cov, 2)
    msg = roundtrip(codec.odometry(pose), 1, 191)
    assert msg.time_usec == 7_500_000 and msg.frame_id == mavlink.MAV_FRAME_LOCAL_NED
    assert msg.estimator_type == mavlink.MAV_ESTIMATOR_TYPE_VIO and msg.reset_counter == 2
    assert (msg.x, msg.y) == (100.0, -2.0) and math.isnan(msg.z)
    c = msg.pose_covariance
    assert len(c) == 21
    assert [c[0], c[1], c[5], c[6], c[10], c[20]] == pytest.approx(
        [0.04, 0.01, 0.002, 0.09, 0.003, 0.0004])
    assert sum(math.isnan(v) for v in c) == 15
    w, x, y, z = msg.q
    assert 2 * math.atan2(z, w) == pytest.approx(0.3) and x == y == 0.0
    assert math.isnan(msg.velocity_covariance[0])


def test_statustext_is_cut_to_fifty_characters():
    msg = roundtrip(codec.statustext(codec.Notice(codec.SEVERITY_WARNING, "x" * 80)))
    assert codec.decode(msg).text == "x" * 50


def test_encoder_advances_the_sequence_and_parser_counts_corruption():
    enc = codec.Encoder(1, 191)
    a, b = enc.encode(codec.heartbeat()), enc.encode(codec.heartbeat())
    assert (a[4], b[4]) == (0, 1)
    bad = bytearray(b)
    bad[-1] ^= 0xFF
    parser = codec.Parser()
    msgs = parser.feed(a + bytes(bad))
    assert len(msgs) == 1 and parser.bad_packets == 1


def test_command_builders_target_the_vehicle():
    msg = roundtrip(codec.set_message_interval(3, 1, dialect.MSG_ID_ATTITUDE, 10.0))
    assert (msg.target_system, msg.command, msg.param1, msg.param2) == (
        3, mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, 30.0, 100000.0)
    msg = roundtrip(codec.request_data_stream(3, 1, dialect.MSG_ID_LOCAL_POSITION_NED, 10.0))
    assert (msg.req_stream_id, msg.req_message_rate, msg.start_stop) == (
        mavlink.MAV_DATA_STREAM_POSITION, 10, 1)
    msg = roundtrip(codec.set_mode(3, 1, 4))
    assert (msg.command, msg.param2) == (mavlink.MAV_CMD_DO_SET_MODE, 4.0)
