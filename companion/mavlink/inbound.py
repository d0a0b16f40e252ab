"""Received messages -> the service's events (mavlink/events.py): field names and scalings.

``decode`` is the one entry: a table from message type to decoder, this module's own, the
obstacle messages' (obstacle_forms.py), the mission protocol's, the goal commands' and the
parameter protocol's. The readers of recorded messages (tlog replay) are here too.
"""
from __future__ import annotations

from companion.mavlink.dialect import mavlink
from companion.mavlink.events import (Attitude, CommandAck, EkfStatus, Event, GeoReference,
                                      GlobalPosition, GpsFix, Heartbeat, LandedState,
                                      LocalPosition, StatusText, TimeSyncReply)
from companion.mavlink.mission_codec import DECODERS as _mission_decoders
from companion.mavlink.mission_codec import GOAL_DECODERS as _goal_decoders
from companion.mavlink.obstacle_forms import _obstacle_3d, _obstacle_sectors
from companion.mavlink.param_codec import DECODERS as _param_decoders


def source(msg) -> tuple[int, int]:
    """(system id, component id) of a received message."""
    return msg.get_srcSystem(), msg.get_srcComponent()


def decode(msg) -> Event | None:
    """The event a received message carries, or None for messages the companion does not use."""
    kind = msg.get_type()
    handler = _DECODERS.get(kind)
    return handler(msg, *source(msg)) if handler else None


def _heartbeat(msg, sysid: int, compid: int) -> Heartbeat:
    return Heartbeat(sysid, compid, msg.type, msg.autopilot != mavlink.MAV_AUTOPILOT_INVALID,
                     bool(msg.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED), msg.custom_mode,
                     msg.autopilot)


def _attitude(msg, sysid: int, compid: int) -> Attitude:
    return Attitude(sysid, compid, msg.time_boot_ms / 1000.0, msg.yaw, msg.yawspeed, msg.roll,
                    msg.pitch)


def _local_position(msg, sysid: int, compid: int) -> LocalPosition:
    return LocalPosition(sysid, compid, msg.time_boot_ms / 1000.0, msg.x, msg.y, msg.vx, msg.vy,
                         msg.z, msg.vz)


def _global_position(msg, sysid: int, compid: int) -> GlobalPosition:
    """lat, lon in 1e7 degrees; relative_alt in mm above home; vz in cm/s, down positive."""
    return GlobalPosition(sysid, compid, msg.time_boot_ms / 1000.0, msg.lat / 1e7, msg.lon / 1e7,
                          msg.relative_alt / 1000.0, msg.vz / 100.0)


def _extended_sys_state(msg, sysid: int, compid: int) -> LandedState:
    return LandedState(sysid, compid, msg.landed_state, msg.vtol_state)


def _gps_global_origin(msg, sysid: int, compid: int) -> GeoReference:
    return GeoReference(sysid, compid, "origin", msg.latitude / 1e7, msg.longitude / 1e7, 0.0, 0.0)


def _home_position(msg, sysid: int, compid: int) -> GeoReference:
    """latitude/longitude in 1e7 degrees; x, y: home in LOCAL_NED (m from the EKF origin)."""
    return GeoReference(sysid, compid, "home", msg.latitude / 1e7, msg.longitude / 1e7,
                        msg.x, msg.y)


def _command_ack(msg, sysid: int, compid: int) -> CommandAck:
    return CommandAck(sysid, compid, msg.command, msg.result == mavlink.MAV_RESULT_ACCEPTED,
                      msg.result)


def _statustext(msg, sysid: int, compid: int) -> StatusText:
    text = msg.text if isinstance(msg.text, str) else msg.text.decode("utf-8", "replace")
    return StatusText(sysid, compid, msg.severity, text.rstrip("\x00"))


def _gps_raw(msg, sysid: int, compid: int) -> GpsFix:
    """GPS_RAW_INT: eph is HDOP x 100 (UINT16_MAX unknown); h_acc, a MAVLink 2 extension, is
    millimetres (0 when not sent); satellites_visible 255 is unknown."""
    hdop = None if msg.eph == 65535 else msg.eph / 100.0
    h_acc = getattr(msg, "h_acc", 0) or 0
    sats = None if msg.satellites_visible == 255 else int(msg.satellites_visible)
    return GpsFix(sysid, compid, int(msg.fix_type), hdop, h_acc / 1000.0 if h_acc > 0 else None,
                  sats)


def _ekf_status(msg, sysid: int, compid: int) -> EkfStatus:
    """EKF_STATUS_REPORT (ArduPilot) and ESTIMATOR_STATUS (PX4, which streams it at 1 Hz on an
    onboard link: src/modules/mavlink/streams/ESTIMATOR_STATUS.hpp): both carry flags."""
    return EkfStatus(sysid, compid, int(msg.flags))


def _timesync(msg, sysid: int, compid: int) -> TimeSyncReply | None:
    return TimeSyncReply(sysid, compid, int(msg.tc1), int(msg.ts1)) if msg.tc1 != 0 else None


_DECODERS = {
    "TIMESYNC": _timesync,
    "GPS_RAW_INT": _gps_raw,
    "EKF_STATUS_REPORT": _ekf_status,
    "ESTIMATOR_STATUS": _ekf_status,
    "HEARTBEAT": _heartbeat,
    "ATTITUDE": _attitude,
    "LOCAL_POSITION_NED": _local_position,
    "GLOBAL_POSITION_INT": _global_position,
    "EXTENDED_SYS_STATE": _extended_sys_state,
    "GPS_GLOBAL_ORIGIN": _gps_global_origin,
    "HOME_POSITION": _home_position,
    "OBSTACLE_DISTANCE_3D": _obstacle_3d,
    "OBSTACLE_DISTANCE": _obstacle_sectors,
    "COMMAND_ACK": _command_ack,
    "STATUSTEXT": _statustext,
}
_DECODERS.update(_mission_decoders)
_DECODERS.update(_goal_decoders)
_DECODERS.update(_param_decoders)


def is_from_us(msg, component_id: int) -> bool:
    """A message sent by a companion with our component id (for tlog replay)."""
    return msg.get_srcComponent() == component_id and msg.get_type() != "BAD_DATA"


def message_type(msg) -> str:
    return msg.get_type()


def sender_component(msg) -> int:
    """The component id a received or recorded message came from."""
    return msg.get_srcComponent()


def vehicle_time_s(msg) -> float | None:
    """The vehicle time (time_boot_ms / 1000) a message carries, None if it has no time_boot_ms."""
    t_ms = getattr(msg, "time_boot_ms", None)
    return None if t_ms is None else t_ms / 1000.0


def packet_bytes(msg) -> bytes:
    """The message as it came over the wire (header, payload, CRC, signature): for the tlog."""
    return bytes(msg.get_msgbuf())
