"""PX4's side of MAVLink: its HEARTBEAT autopilot id, its custom_mode encoding, its mode command.

PX4 packs its flight mode into HEARTBEAT.custom_mode as two bytes (PX4-Autopilot
src/modules/commander/px4_custom_mode.h, union px4_custom_mode): the main mode in bits 16-23 and
the sub mode in bits 24-31 (sub modes only for AUTO). MAV_CMD_DO_SET_MODE takes the same pair as
param2 (main) and param3 (sub), with param1 = MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
(Commander::handle_command, VEHICLE_CMD_DO_SET_MODE). PX4 answers a mode it cannot enter now (no
offboard signal, no position) with COMMAND_ACK TEMPORARILY_REJECTED.
"""
from __future__ import annotations

import struct
from dataclasses import dataclass

from companion.mavlink.dialect import mavlink

MAV_AUTOPILOT_PX4 = mavlink.MAV_AUTOPILOT_PX4                     # 12
MAV_AUTOPILOT_ARDUPILOTMEGA = mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA   # 3

# px4_custom_mode.h: PX4_CUSTOM_MAIN_MODE_*
MAIN_MANUAL, MAIN_ALTCTL, MAIN_POSCTL, MAIN_AUTO, MAIN_ACRO, MAIN_OFFBOARD, MAIN_STABILIZED = \
    1, 2, 3, 4, 5, 6, 7
# PX4_CUSTOM_SUB_MODE_AUTO_*
SUB_AUTO_READY, SUB_AUTO_TAKEOFF, SUB_AUTO_LOITER, SUB_AUTO_MISSION, SUB_AUTO_RTL, \
    SUB_AUTO_LAND = 1, 2, 3, 4, 5, 6

MAIN_NAMES = {MAIN_MANUAL: "MANUAL", MAIN_ALTCTL: "ALTCTL", MAIN_POSCTL: "POSCTL",
              MAIN_AUTO: "AUTO", MAIN_ACRO: "ACRO", MAIN_OFFBOARD: "OFFBOARD",
              MAIN_STABILIZED: "STABILIZED"}
AUTO_SUB_NAMES = {SUB_AUTO_READY: "READY", SUB_AUTO_TAKEOFF: "TAKEOFF",
                  SUB_AUTO_LOITER: "LOITER", SUB_AUTO_MISSION: "MISSION", SUB_AUTO_RTL: "RTL",
                  SUB_AUTO_LAND: "LAND"}


def main_mode(custom_mode: int) -> int:
    return (int(custom_mode) >> 16) & 0xFF


def sub_mode(custom_mode: int) -> int:
    return (int(custom_mode) >> 24) & 0xFF


def custom_mode(main: int, sub: int = 0) -> int:
    """HEARTBEAT.custom_mode of a (main, sub) pair: OFFBOARD is 6 << 16 = 393216."""
    return ((main & 0xFF) << 16) | ((sub & 0xFF) << 24)


def mode_name(custom_mode_value: int) -> str:
    """'OFFBOARD', 'AUTO.LOITER', ... (the number if unknown)."""
    main, sub = main_mode(custom_mode_value), sub_mode(custom_mode_value)
    name = MAIN_NAMES.get(main, str(main))
    if main == MAIN_AUTO:
        return f"{name}.{AUTO_SUB_NAMES.get(sub, str(sub))}"
    return name


OFFBOARD = custom_mode(MAIN_OFFBOARD)
AUTO_LOITER = custom_mode(MAIN_AUTO, SUB_AUTO_LOITER)      # "Hold" in QGroundControl
AUTO_TAKEOFF = custom_mode(MAIN_AUTO, SUB_AUTO_TAKEOFF)
AUTO_LAND = custom_mode(MAIN_AUTO, SUB_AUTO_LAND)
POSCTL = custom_mode(MAIN_POSCTL)


@dataclass(frozen=True)
class ModeRequest:
    """Our intent: ask the vehicle for a PX4 mode (MAV_CMD_DO_SET_MODE), with the reason."""
    target_system: int
    target_component: int
    custom_mode: int
    reason: str


def set_mode_command(request: ModeRequest) -> mavlink.MAVLink_command_long_message:
    """MAV_CMD_DO_SET_MODE: param1 base mode (custom enabled), param2 main, param3 sub."""
    return mavlink.MAVLink_command_long_message(
        request.target_system, request.target_component, mavlink.MAV_CMD_DO_SET_MODE, 0,
        float(mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED), float(main_mode(request.custom_mode)),
        float(sub_mode(request.custom_mode)), 0, 0, 0, 0)


def takeoff(target_system: int, target_component: int,
            alt_amsl_m: float) -> mavlink.MAVLink_command_long_message:
    """MAV_CMD_NAV_TAKEOFF as PX4 reads it: param7 an AMSL altitude; param4 (yaw), param5 and
    param6 (latitude, longitude) NaN: "here" (finite ones are a take-off position, and 0, 0 is
    the Gulf of Guinea: PX4 SITL then sat in AUTO.TAKEOFF with no thrust until it disarmed)."""
    nan = float("nan")
    return mavlink.MAVLink_command_long_message(
        target_system, target_component, mavlink.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, 0, nan, nan, nan,
        float(alt_amsl_m))


def param_set_int(target_system: int, target_component: int, name: str,
                  value: int) -> mavlink.MAVLink_param_set_message:
    """PARAM_SET of an INT32 parameter as PX4 reads it: the integer's bits in the float
    (bytewise encoding, MAV_PROTOCOL_CAPABILITY_PARAM_ENCODE_BYTEWISE)."""
    raw = struct.unpack("<f", struct.pack("<i", int(value)))[0]
    return mavlink.MAVLink_param_set_message(target_system, target_component, name.encode(),
                                             raw, mavlink.MAV_PARAM_TYPE_INT32)


def set_mode(target_system: int, target_component: int,
             custom_mode_value: int) -> mavlink.MAVLink_command_long_message:
    """The same command from a ground station (the demo's, the tests')."""
    return set_mode_command(ModeRequest(target_system, target_component, custom_mode_value, ""))


# What PX4 streams unasked on a MAVLink instance in onboard mode (MAV_x_MODE 2), Hz
# (src/modules/mavlink/mavlink_main.cpp, Mavlink::configure_streams_to_default,
# MAVLINK_MODE_ONBOARD; GPS_RAW_INT there is "unlimited": every GPS update, 5-10 Hz).
# The service never asks for less than these: a lower SET_MESSAGE_INTERVAL would slow them.
MSG_ID_ESTIMATOR_STATUS = mavlink.MAVLINK_MSG_ID_ESTIMATOR_STATUS
ONBOARD_STREAM_RATES_HZ = {
    mavlink.MAVLINK_MSG_ID_ATTITUDE: 100.0,
    mavlink.MAVLINK_MSG_ID_LOCAL_POSITION_NED: 30.0,
    mavlink.MAVLINK_MSG_ID_ODOMETRY: 30.0,
    mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT: 50.0,
    mavlink.MAVLINK_MSG_ID_EXTENDED_SYS_STATE: 5.0,
    MSG_ID_ESTIMATOR_STATUS: 1.0,
    mavlink.MAVLINK_MSG_ID_SYS_STATUS: 5.0,
    mavlink.MAVLINK_MSG_ID_HOME_POSITION: 0.5,
    mavlink.MAVLINK_MSG_ID_GPS_GLOBAL_ORIGIN: 1.0,
    mavlink.MAVLINK_MSG_ID_BATTERY_STATUS: 0.5,
    mavlink.MAVLINK_MSG_ID_SYSTEM_TIME: 1.0,
}


def stream_request(msg_id: int, rate_hz: float) -> tuple[int, float]:
    """The stream to ask PX4 for in place of ``msg_id`` at ``rate_hz``: ESTIMATOR_STATUS for
    ArduPilot's EKF_STATUS_REPORT (the same flags), and never below PX4's onboard default."""
    if msg_id == mavlink.MAVLINK_MSG_ID_EKF_STATUS_REPORT:
        msg_id = MSG_ID_ESTIMATOR_STATUS
    return msg_id, max(rate_hz, ONBOARD_STREAM_RATES_HZ.get(msg_id, 0.0))
