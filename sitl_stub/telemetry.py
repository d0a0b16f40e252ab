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


def heartbeat_autopilot(mode: int, armed: bool, landed: bool = True) -> mavlink.MAVLink_message:
    """system_status as GCS_MAVLINK_Copter::vehicle_system_status: STANDBY while landed."""
    base = (mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED | mavlink.MAV_MODE_FLAG_STABILIZE_ENABLED
            | mavlink.MAV_MODE_FLAG_MANUAL_INPUT_ENABLED)
    if mode in _GUIDED_FLAG_MODES:
        base |= mavlink.MAV_MODE_FLAG_GUIDED_ENABLED
    if armed:
        base |= mavlink.MAV_MODE_FLAG_SAFETY_ARMED
    status = mavlink.MAV_STATE_STANDBY if landed else mavlink.MAV_STATE_ACTIVE
    return mavlink.MAVLink_heartbeat_message(
        mavlink.MAV_TYPE_QUADROTOR, mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA, base, mode, status, 3)


def heartbeat_camera() -> mavlink.MAVLink_message:
    return mavlink.MAVLink_heartbeat_message(
        mavlink.MAV_TYPE_CAMERA, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, mavlink.MAV_STATE_ACTIVE, 3)


# SYS_STATUS sensor bits as ArduCopter sets them (GCS::update_sensor_status_flags in
# libraries/GCS_MAVLink/GCS.cpp, GCS_Copter::update_vehicle_sensor_status_flags), checked against
# the ArduCopter 4.6 SITL binary in /work/shared/ardupilot (present 0x5371fc2f with its GPS, RC
# and propulsion bits; the stub has no RC receiver or ESC telemetry).
_S = mavlink
SENSORS_ALWAYS = (_S.MAV_SYS_STATUS_SENSOR_3D_GYRO | _S.MAV_SYS_STATUS_SENSOR_3D_ACCEL
                  | _S.MAV_SYS_STATUS_SENSOR_3D_MAG | _S.MAV_SYS_STATUS_SENSOR_ABSOLUTE_PRESSURE
                  | _S.MAV_SYS_STATUS_AHRS | _S.MAV_SYS_STATUS_SENSOR_BATTERY
                  | _S.MAV_SYS_STATUS_SENSOR_MOTOR_OUTPUTS | _S.MAV_SYS_STATUS_PREARM_CHECK
                  | _S.MAV_SYS_STATUS_SENSOR_ANGULAR_RATE_CONTROL
                  | _S.MAV_SYS_STATUS_SENSOR_ATTITUDE_STABILIZATION
                  | _S.MAV_SYS_STATUS_SENSOR_YAW_POSITION | _S.MAV_SYS_STATUS_LOGGING
                  | _S.MAV_SYS_STATUS_TERRAIN)
SENSORS_POSITION_CONTROL = (_S.MAV_SYS_STATUS_SENSOR_Z_ALTITUDE_CONTROL
                            | _S.MAV_SYS_STATUS_SENSOR_XY_POSITION_CONTROL)
# Healthy whether present or not: a fence that has not failed, a proximity sensor that is absent.
SENSORS_HEALTHY_ANYWAY = _S.MAV_SYS_STATUS_GEOFENCE | _S.MAV_SYS_STATUS_SENSOR_PROXIMITY


def sys_status(has_gps: bool, position_control_active: bool, voltage_mv: int, current_ca: int,
               remaining_pct: int) -> mavlink.MAVLink_message:
    """Present / enabled / healthy sensor bits as ArduCopter reports a healthy vehicle.

    GEOFENCE: present (ArduCopter has a fence), not enabled, but healthy
    (``!fence->sys_status_failed()``): a ground station reads a cleared health bit of a fence as a
    breach (MAVProxy says "fence breach"). The position controllers are enabled (and healthy)
    only while active.
    """
    present = SENSORS_ALWAYS | SENSORS_POSITION_CONTROL | _S.MAV_SYS_STATUS_GEOFENCE
    enabled = SENSORS_ALWAYS
    if has_gps:
        present |= _S.MAV_SYS_STATUS_SENSOR_GPS
        enabled |= _S.MAV_SYS_STATUS_SENSOR_GPS
    if position_control_active:
        enabled |= SENSORS_POSITION_CONTROL
    health = enabled | SENSORS_HEALTHY_ANYWAY
    return mavlink.MAVLink_sys_status_message(present, enabled, health, 0, voltage_mv, current_ca,
                                              remaining_pct, 0, 0, 0, 0, 0, 0)


def battery_status(voltage_mv: int, current_ca: int, consumed_mah: int,
                   remaining_pct: int) -> mavlink.MAVLink_message:
    cells = [voltage_mv] + [UINT16_MAX] * 9
    return mavlink.MAVLink_battery_status_message(
        0, mavlink.MAV_BATTERY_FUNCTION_UNKNOWN, mavlink.MAV_BATTERY_TYPE_UNKNOWN, 32767, cells,
        current_ca, consumed_mah, -1, remaining_pct, 0, mavlink.MAV_BATTERY_CHARGE_STATE_OK)


def extended_sys_state(landed_state: int, vtol_state: int) -> mavlink.MAVLink_message:
    return mavlink.MAVLink_extended_sys_state_message(vtol_state, landed_state)


def gps_raw_int(t_s: float, has_gps: bool, lat_deg: float, lon_deg: float, alt_m: float,
                sigma_m: float, speed_mps: float, course_rad: float,
                fix: bool = True) -> mavlink.MAVLink_message:
    """GPS_RAW_INT: a 3D fix with the position error's 1-sigma in eph (cm, HDOP x 100 with a
    1 m UERE) and h_acc (mm); without a GPS, NO_GPS and everything unknown; in an outage
    (``fix`` False), NO_FIX and everything unknown."""
    if not has_gps or not fix:
        fix_type = mavlink.GPS_FIX_TYPE_NO_GPS if not has_gps else mavlink.GPS_FIX_TYPE_NO_FIX
        return mavlink.MAVLink_gps_raw_int_message(int(t_s * 1e6), fix_type,
                                                   0, 0, 0, UINT16_MAX, UINT16_MAX, UINT16_MAX,
                                                   UINT16_MAX, 0)
    eph = int(min(max(round(sigma_m * 100.0), 1), UINT16_MAX - 1))
    return mavlink.MAVLink_gps_raw_int_message(
        int(t_s * 1e6), mavlink.GPS_FIX_TYPE_3D_FIX, _deg_e7(lat_deg), _deg_e7(lon_deg),
        int(round(alt_m * 1000)), eph, eph, int(round(speed_mps * 100)),
        heading_cdeg(course_rad), 12, 0, int(round(sigma_m * 1000)), int(round(sigma_m * 1500)))


# EKF_STATUS_REPORT flags of a healthy EKF3: with a GPS, absolute horizontal position too.
EKF_FLAGS_RELATIVE = (mavlink.EKF_ATTITUDE | mavlink.EKF_VELOCITY_HORIZ | mavlink.EKF_VELOCITY_VERT
                      | mavlink.EKF_POS_HORIZ_REL | mavlink.EKF_POS_VERT_ABS
                      | mavlink.EKF_PRED_POS_HORIZ_REL)
EKF_FLAGS_ABSOLUTE = EKF_FLAGS_RELATIVE | mavlink.EKF_POS_HORIZ_ABS | mavlink.EKF_PRED_POS_HORIZ_ABS


def ekf_status_report(has_gps: bool) -> mavlink.MAVLink_message:
    """Variances are ArduPilot's normalised test ratios (< 0.5 good, > 1 failing)."""
    flags = EKF_FLAGS_ABSOLUTE if has_gps else EKF_FLAGS_RELATIVE
    return mavlink.MAVLink_ekf_status_report_message(flags, 0.05, 0.05 if has_gps else 0.0,
                                                     0.02, 0.03, 0.0)


def gps_global_origin(origin: Origin, t_s: float) -> mavlink.MAVLink_message:
    return mavlink.MAVLink_gps_global_origin_message(
        _deg_e7(origin.lat_deg), _deg_e7(origin.lon_deg), int(round(origin.alt_m * 1000)),
        int(t_s * 1e6))


def system_time(t_s: float, start_unix_s: float) -> mavlink.MAVLink_message:
    """time_unix_usec: the stub's start wall-clock plus simulated time (a simulated clock)."""
    return mavlink.MAVLink_system_time_message(int((start_unix_s + t_s) * 1e6), time_boot_ms(t_s))


def attitude(t_s: float, yaw_rad: float, yaw_rate_rad_s: float, roll_rad: float = 0.0,
             pitch_rad: float = 0.0) -> mavlink.MAVLink_message:
    """roll, pitch: the true tilt (an AHRS's attitude is good to a fraction of a degree)."""
    return mavlink.MAVLink_attitude_message(time_boot_ms(t_s), roll_rad, pitch_rad,
                                            _angle_f32(yaw_rad), 0.0, 0.0, yaw_rate_rad_s)


def local_position_ned(t_s: float, odom: Odometry, north_m: float, east_m: float,
                       vel_ne_mps: tuple[float, float] | None = None) -> mavlink.MAVLink_message:
    """x, y: the reported position (GPS-like or dead-reckoned); vx, vy: ``vel_ne_mps`` (None:
    the odometry's); z = -altitude, vz = -climb."""
    vel_north, vel_east = vel_ne_mps or (odom.vel_north_mps, odom.vel_east_mps)
    return mavlink.MAVLink_local_position_ned_message(
        time_boot_ms(t_s), north_m, east_m, -odom.up_m, vel_north, vel_east, -odom.vel_up_mps)


def global_position_int(t_s: float, odom: Odometry, north_m: float, east_m: float,
                        origin: Origin, home_up_m: float) -> mavlink.MAVLink_message:
    """alt: MSL (origin + altitude), relative_alt: above home, both mm; vz cm/s down."""
    lat, lon = origin.to_lat_lon_deg(north_m, east_m)
    return mavlink.MAVLink_global_position_int_message(
        time_boot_ms(t_s), _deg_e7(lat), _deg_e7(lon),
        int(round((origin.alt_m + odom.up_m) * 1000)), int(round((odom.up_m - home_up_m) * 1000)),
        _int16(odom.vel_north_mps * 100), _int16(odom.vel_east_mps * 100),
        _int16(-odom.vel_up_mps * 100), heading_cdeg(odom.yaw_rad))


def simstate(truth: TruthState, origin: Origin) -> mavlink.MAVLink_message:
    """Truth: yaw and lat/lng of the TRUE position."""
    lat, lon = origin.to_lat_lon_deg(truth.north_m, truth.east_m)
    return mavlink.MAVLink_simstate_message(0.0, 0.0, _angle_f32(truth.yaw_rad), 0.0, 0.0, -9.81,
                                            0.0, 0.0, 0.0, _deg_e7(lat), _deg_e7(lon))


def position_target_local_ned(t_s: float, fields: dict) -> mavlink.MAVLink_message:
    return mavlink.MAVLink_position_target_local_ned_message(
        time_boot_ms(t_s), MAV_FRAME_LOCAL_NED, fields["type_mask"], fields["x"], fields["y"],
        fields.get("z", 0.0), fields["vx"], fields["vy"], fields.get("vz", 0.0), 0.0, 0.0, 0.0, 0.0,
        0.0)


def home_position(origin: Origin, home_north_m: float, home_east_m: float, home_up_m: float,
                  t_s: float) -> mavlink.MAVLink_message:
    lat, lon = origin.to_lat_lon_deg(home_north_m, home_east_m)
    return mavlink.MAVLink_home_position_message(
        _deg_e7(lat), _deg_e7(lon), int(round((origin.alt_m + home_up_m) * 1000)), home_north_m,
        home_east_m, -home_up_m, [1.0, 0.0, 0.0, 0.0], 0.0, 0.0, 0.0, int(t_s * 1e6))


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
                         cfg: SensorConfig, z_m: float = 0.0,
                         point: tuple[float, float] | None = None) -> mavlink.MAVLink_message:
    """One point in BODY_FRD: the detection's centre x, y (or ``point``) at depth ``z_m``
    (down; 0: the 2D camera's, at the camera's height)."""
    x_m, y_m = point if point is not None else (det.x_m, det.y_m)
    return mavlink.MAVLink_obstacle_distance_3d_message(
        time_boot_ms(t_s), mavlink.MAV_DISTANCE_SENSOR_UNKNOWN, mavlink.MAV_FRAME_BODY_FRD,
        det.obstacle_id, x_m, y_m, z_m, camera.MIN_DISTANCE_M, cfg.max_range_m)


def obstacle_points_3d(det: camera.Detection, t_s: float,
                       cfg: SensorConfig) -> list[mavlink.MAVLink_message]:
    """A detection's OBSTACLE_DISTANCE_3D: one point (z 0) from the 2D camera; from a 3D
    world's, its highest and its lowest point seen (same id, same x, y), in that order."""
    if det.top_down_m is None or det.bottom_down_m is None:
        return [obstacle_distance_3d(det, t_s, cfg)]
    return [obstacle_distance_3d(det, t_s, cfg, det.top_down_m),
            obstacle_distance_3d(det, t_s, cfg, det.bottom_down_m)]


def ground_point_3d(point: tuple[float, float, float], t_s: float,
                    cfg: SensorConfig) -> mavlink.MAVLink_message:
    """A floor return: no id (UINT16_MAX), body FRD x, y, z."""
    return mavlink.MAVLink_obstacle_distance_3d_message(
        time_boot_ms(t_s), mavlink.MAV_DISTANCE_SENSOR_UNKNOWN, mavlink.MAV_FRAME_BODY_FRD,
        UINT16_MAX, point[0], point[1], point[2], camera.MIN_DISTANCE_M, cfg.max_range_m)


def obstacle_distance(detections: list[camera.Detection], t_s: float,
                      cfg: SensorConfig, scan: tuple | None = None) -> mavlink.MAVLink_message:
    """The sectors of ``detections`` (form centres), or a depth camera's own ray-cast ``scan``
    (camera.ray_cast_sectors_cm) when given."""
    distances, increment_deg, offset_deg = scan or camera.sector_distances_cm(detections, cfg)
    return mavlink.MAVLink_obstacle_distance_message(
        int(t_s * 1e6), mavlink.MAV_DISTANCE_SENSOR_UNKNOWN, distances, 0,
        int(camera.MIN_DISTANCE_M * 100), min(int(round(cfg.max_range_m * 100)), UINT16_MAX - 1),
        increment_deg, offset_deg, mavlink.MAV_FRAME_BODY_FRD)
