"""Builders of outgoing MAVLink messages: the only module that knows field scalings.

Times (time_boot_ms, time_usec) are simulated time since stub start. Messages are returned
unpacked (pymavlink message objects); the links pack them per client and per component.
"""
from __future__ import annotations

import math

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from . import camera
from .guided import MAV_FRAME_LOCAL_NED
from .params import ParamValue
from .vehicle import Odometry, TruthState
from .world import Origin, SensorConfig, UINT16_MAX

COMP_AUTOPILOT = mavlink.MAV_COMP_ID_AUTOPILOT1   # 1
COMP_CAMERA = mavlink.MAV_COMP_ID_CAMERA          # 100

# ArduCopter custom_mode numbers (ArduCopter/mode.h, Tools/autotest/default_params/copter.parm).
MODE_STABILIZE = 0
MODE_ALT_HOLD = 2
MODE_AUTO = 3
MODE_GUIDED = 4
MODE_LOITER = 5
MODE_RTL = 6
MODE_LAND = 9
MODE_POSHOLD = 16
MODE_BRAKE = 17
MODE_NAMES = {MODE_STABILIZE: "STABILIZE", MODE_ALT_HOLD: "ALT_HOLD", MODE_AUTO: "AUTO",
              MODE_GUIDED: "GUIDED", MODE_LOITER: "LOITER", MODE_RTL: "RTL", MODE_LAND: "LAND",
              MODE_POSHOLD: "POSHOLD", MODE_BRAKE: "BRAKE"}
# Modes in which ArduCopter sets MAV_MODE_FLAG_GUIDED_ENABLED (GCS_MAVLINK_Copter::base_mode).
_GUIDED_FLAG_MODES = (MODE_AUTO, MODE_RTL, MODE_LOITER, MODE_GUIDED, MODE_POSHOLD, MODE_BRAKE)

# float32 just below pi: keeps reported angles inside (-pi, pi] after float32 packing.
_F32_PI_BELOW = 3.1415925025939941


def time_boot_ms(t_s: float) -> int:
    return int(round(t_s * 1000.0)) & 0xFFFFFFFF


def _angle_f32(angle_rad: float) -> float:
    return min(max(angle_rad, -_F32_PI_BELOW), _F32_PI_BELOW)


def _int16(value: float) -> int:
    return int(max(-32768, min(32767, round(value))))


def _deg_e7(deg: float) -> int:
    return int(round(deg * 1e7))


def heading_cdeg(yaw_rad: float) -> int:
    return int(round(math.degrees(yaw_rad) % 360.0 * 100.0)) % 36000


def heartbeat_autopilot(mode: int, armed: bool) -> mavlink.MAVLink_message:
    base = (mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED | mavlink.MAV_MODE_FLAG_STABILIZE_ENABLED
            | mavlink.MAV_MODE_FLAG_MANUAL_INPUT_ENABLED)
    if mode in _GUIDED_FLAG_MODES:
        base |= mavlink.MAV_MODE_FLAG_GUIDED_ENABLED
    if armed:
        base |= mavlink.MAV_MODE_FLAG_SAFETY_ARMED
    status = mavlink.MAV_STATE_ACTIVE if armed else mavlink.MAV_STATE_STANDBY
    return mavlink.MAVLink_heartbeat_message(
        mavlink.MAV_TYPE_QUADROTOR, mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA, base, mode, status, 3)


def heartbeat_camera() -> mavlink.MAVLink_message:
    return mavlink.MAVLink_heartbeat_message(
        mavlink.MAV_TYPE_CAMERA, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, mavlink.MAV_STATE_ACTIVE, 3)


def sys_status() -> mavlink.MAVLink_message:
    return mavlink.MAVLink_sys_status_message(0, 0, 0, 0, 12600, -1, -1, 0, 0, 0, 0, 0, 0)


def system_time(t_s: float, start_unix_s: float) -> mavlink.MAVLink_message:
    """time_unix_usec: the stub's start wall-clock plus simulated time (a simulated clock)."""
    return mavlink.MAVLink_system_time_message(int((start_unix_s + t_s) * 1e6), time_boot_ms(t_s))


def attitude(t_s: float, odom: Odometry) -> mavlink.MAVLink_message:
    return mavlink.MAVLink_attitude_message(time_boot_ms(t_s), 0.0, 0.0, _angle_f32(odom.yaw_rad),
                                            0.0, 0.0, odom.yaw_rate_rad_s)


def local_position_ned(t_s: float, odom: Odometry) -> mavlink.MAVLink_message:
    return mavlink.MAVLink_local_position_ned_message(
        time_boot_ms(t_s), odom.north_m, odom.east_m, 0.0, odom.vel_north_mps, odom.vel_east_mps, 0.0)


def global_position_int(t_s: float, odom: Odometry, origin: Origin) -> mavlink.MAVLink_message:
    lat, lon = origin.to_lat_lon_deg(odom.north_m, odom.east_m)
    return mavlink.MAVLink_global_position_int_message(
        time_boot_ms(t_s), _deg_e7(lat), _deg_e7(lon), int(round(origin.alt_m * 1000)), 0,
        _int16(odom.vel_north_mps * 100), _int16(odom.vel_east_mps * 100), 0,
        heading_cdeg(odom.yaw_rad))


def simstate(truth: TruthState, origin: Origin) -> mavlink.MAVLink_message:
    """Truth: yaw and lat/lng of the TRUE position."""
    lat, lon = origin.to_lat_lon_deg(truth.north_m, truth.east_m)
    return mavlink.MAVLink_simstate_message(0.0, 0.0, _angle_f32(truth.yaw_rad), 0.0, 0.0, -9.81,
                                            0.0, 0.0, 0.0, _deg_e7(lat), _deg_e7(lon))


def position_target_local_ned(t_s: float, fields: dict) -> mavlink.MAVLink_message:
    return mavlink.MAVLink_position_target_local_ned_message(
        time_boot_ms(t_s), MAV_FRAME_LOCAL_NED, fields["type_mask"], fields["x"], fields["y"], 0.0,
        fields["vx"], fields["vy"], 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)


def home_position(origin: Origin, home_north_m: float, home_east_m: float,
                  t_s: float) -> mavlink.MAVLink_message:
    lat, lon = origin.to_lat_lon_deg(home_north_m, home_east_m)
    return mavlink.MAVLink_home_position_message(
        _deg_e7(lat), _deg_e7(lon), int(round(origin.alt_m * 1000)), home_north_m, home_east_m,
        0.0, [1.0, 0.0, 0.0, 0.0], 0.0, 0.0, 0.0, int(t_s * 1e6))


def autopilot_version() -> mavlink.MAVLink_message:
    caps = (mavlink.MAV_PROTOCOL_CAPABILITY_MISSION_FLOAT | mavlink.MAV_PROTOCOL_CAPABILITY_PARAM_FLOAT
            | mavlink.MAV_PROTOCOL_CAPABILITY_MISSION_INT | mavlink.MAV_PROTOCOL_CAPABILITY_COMMAND_INT
            | mavlink.MAV_PROTOCOL_CAPABILITY_SET_POSITION_TARGET_LOCAL_NED
            | mavlink.MAV_PROTOCOL_CAPABILITY_MAVLINK2)
    version = (4 << 24) | (5 << 16) | (0 << 8) | mavlink.FIRMWARE_VERSION_TYPE_OFFICIAL
    return mavlink.MAVLink_autopilot_version_message(
        caps, version, 0, 0, 0, [0] * 8, [0] * 8, [0] * 8, 0, 0, 0, [0] * 18)


def command_ack(command: int, result: int, target_system: int,
                target_component: int) -> mavlink.MAVLink_message:
    return mavlink.MAVLink_command_ack_message(command, result, 0, 0, target_system, target_component)


def param_value(p: ParamValue) -> mavlink.MAVLink_message:
    return mavlink.MAVLink_param_value_message(p.name.encode("ascii"), p.value, p.param_type,
                                               p.count, p.index)


def message_interval(msg_id: int, interval_us: int) -> mavlink.MAVLink_message:
    return mavlink.MAVLink_message_interval_message(msg_id, interval_us)


def mission_count(target_system: int, target_component: int,
                  mission_type: int) -> mavlink.MAVLink_message:
    return mavlink.MAVLink_mission_count_message(target_system, target_component, 0, mission_type)


def ftp_nak(request_payload: list[int] | bytes, error_code: int, target_system: int,
            target_component: int) -> mavlink.MAVLink_message:
    """A MAVLink FTP NAK (opcode 129) answering a request, with a one-byte error code."""
    req = bytes(request_payload)
    seq = (int.from_bytes(req[0:2], "little") + 1) & 0xFFFF if len(req) >= 2 else 0
    session = req[2] if len(req) > 2 else 0
    req_opcode = req[3] if len(req) > 3 else 0
    payload = bytearray(251)
    payload[0:2] = seq.to_bytes(2, "little")
    payload[2] = session
    payload[3] = 129          # NAK
    payload[4] = 1            # size of data
    payload[5] = req_opcode
    payload[12] = error_code
    return mavlink.MAVLink_file_transfer_protocol_message(0, target_system, target_component,
                                                          list(payload))


def obstacle_distance_3d(det: camera.Detection, t_s: float,
                         cfg: SensorConfig) -> mavlink.MAVLink_message:
    return mavlink.MAVLink_obstacle_distance_3d_message(
        time_boot_ms(t_s), mavlink.MAV_DISTANCE_SENSOR_UNKNOWN, mavlink.MAV_FRAME_BODY_FRD,
        det.obstacle_id, det.x_m, det.y_m, 0.0, camera.MIN_DISTANCE_M, cfg.max_range_m)


def obstacle_distance(detections: list[camera.Detection], t_s: float,
                      cfg: SensorConfig) -> mavlink.MAVLink_message:
    distances, increment_deg, offset_deg = camera.sector_distances_cm(detections, cfg)
    return mavlink.MAVLink_obstacle_distance_message(
        int(t_s * 1e6), mavlink.MAV_DISTANCE_SENSOR_UNKNOWN, distances, 0,
        int(camera.MIN_DISTANCE_M * 100), min(int(round(cfg.max_range_m * 100)), UINT16_MAX - 1),
        increment_deg, offset_deg, mavlink.MAV_FRAME_BODY_FRD)
