"""Commands to the vehicle (COMMAND_LONG, REQUEST_DATA_STREAM) and the acks that answer them.

Stream set-up (SET_MESSAGE_INTERVAL, REQUEST_MESSAGE, the REQUEST_DATA_STREAM fallback) for the
service, mode, arming and takeoff for the demos' ground station.
"""
from __future__ import annotations

from companion.mavlink.dialect import DATA_STREAMS_FOR, mavlink
from companion.mavlink.events import CommandAck


def set_message_interval(target_system: int, target_component: int, msg_id: int,
                         rate_hz: float) -> mavlink.MAVLink_command_long_message:
    return mavlink.MAVLink_command_long_message(
        target_system, target_component, mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, 0,
        float(msg_id), 1e6 / rate_hz, 0, 0, 0, 0, 0)


def request_message(target_system: int, target_component: int,
                    msg_id: int) -> mavlink.MAVLink_command_long_message:
    """MAV_CMD_REQUEST_MESSAGE: send one message now (HOME_POSITION, GPS_GLOBAL_ORIGIN)."""
    return mavlink.MAVLink_command_long_message(
        target_system, target_component, mavlink.MAV_CMD_REQUEST_MESSAGE, 0, float(msg_id),
        0, 0, 0, 0, 0, 0)


def takeoff(target_system: int, target_component: int,
            alt_m: float) -> mavlink.MAVLink_command_long_message:
    """MAV_CMD_NAV_TAKEOFF: param7 = altitude above home in metres (ArduCopter)."""
    return mavlink.MAVLink_command_long_message(
        target_system, target_component, mavlink.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, 0, 0, 0, 0,
        float(alt_m))


def is_set_message_interval_ack(ack: CommandAck) -> bool:
    return ack.command == mavlink.MAV_CMD_SET_MESSAGE_INTERVAL


def request_data_stream(target_system: int, target_component: int, msg_id: int,
                        rate_hz: float) -> mavlink.MAVLink_request_data_stream_message:
    return mavlink.MAVLink_request_data_stream_message(
        target_system, target_component, DATA_STREAMS_FOR[msg_id], max(1, round(rate_hz)), 1)


def set_mode(target_system: int, target_component: int,
             custom_mode: int) -> mavlink.MAVLink_command_long_message:
    """MAV_CMD_DO_SET_MODE with a custom (ArduPilot) mode number."""
    return mavlink.MAVLink_command_long_message(
        target_system, target_component, mavlink.MAV_CMD_DO_SET_MODE, 0,
        mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, float(custom_mode), 0, 0, 0, 0, 0)


def arm(target_system: int, target_component: int,
        armed: bool = True) -> mavlink.MAVLink_command_long_message:
    return mavlink.MAVLink_command_long_message(
        target_system, target_component, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 0,
        1.0 if armed else 0.0, 0, 0, 0, 0, 0, 0)


def is_ack_for(ack: CommandAck, command_name: str) -> bool:
    """True if the ack answers the named command ('set_mode', 'arm' or 'takeoff')."""
    wanted = {"set_mode": mavlink.MAV_CMD_DO_SET_MODE,
              "arm": mavlink.MAV_CMD_COMPONENT_ARM_DISARM,
              "takeoff": mavlink.MAV_CMD_NAV_TAKEOFF}[command_name]
    return ack.command == wanted
