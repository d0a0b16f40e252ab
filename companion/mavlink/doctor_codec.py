"""What ``companion doctor`` reads off the wire beyond the service's events, and what it asks.

Inbound (``decode``): the vehicle's HEARTBEAT in full (autopilot, type, modes), AUTOPILOT_VERSION,
PARAM_VALUE, and the obstacle messages' layout (frame, sectors, bounds), each as a frozen record
in SI units; ``is_signed`` says whether a packet carried a signature. Outbound: PARAM_REQUEST_READ
and the request for AUTOPILOT_VERSION. Nothing here commands the vehicle: no mode, no arming, no
setpoint.
"""
from __future__ import annotations

from dataclasses import dataclass

from companion.mavlink.commands import request_message
from companion.mavlink.dialect import mavlink

AUTOPILOT_ARDUPILOT = mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA      # 3
AUTOPILOT_PX4 = mavlink.MAV_AUTOPILOT_PX4                      # 12
MSG_ID_AUTOPILOT_VERSION = mavlink.MAVLINK_MSG_ID_AUTOPILOT_VERSION
MSG_ID_OBSTACLE_DISTANCE = mavlink.MAVLINK_MSG_ID_OBSTACLE_DISTANCE
MSG_ID_OBSTACLE_DISTANCE_3D = mavlink.MAVLINK_MSG_ID_OBSTACLE_DISTANCE_3D
FRAME_BODY_FRD = mavlink.MAV_FRAME_BODY_FRD                    # 12
MODE_FLAG_CUSTOM_MODE_ENABLED = mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
UINT16_MAX = 65535          # an OBSTACLE_DISTANCE element with no data
MAVLINK2_MAGIC, IFLAG_SIGNED = 0xFD, 0x01
_FIRMWARE_TYPES = {mavlink.FIRMWARE_VERSION_TYPE_DEV: "dev",
                   mavlink.FIRMWARE_VERSION_TYPE_ALPHA: "alpha",
                   mavlink.FIRMWARE_VERSION_TYPE_BETA: "beta",
                   mavlink.FIRMWARE_VERSION_TYPE_RC: "rc",
                   mavlink.FIRMWARE_VERSION_TYPE_OFFICIAL: "official"}


def autopilot_name(autopilot: int) -> str:
    if autopilot in (AUTOPILOT_ARDUPILOT, AUTOPILOT_PX4):
        return "ArduPilot" if autopilot == AUTOPILOT_ARDUPILOT else "PX4"
    entry = mavlink.enums["MAV_AUTOPILOT"].get(autopilot)
    return entry.name.removeprefix("MAV_AUTOPILOT_") if entry else str(autopilot)


def vehicle_type_name(mav_type: int) -> str:
    entry = mavlink.enums["MAV_TYPE"].get(mav_type)
    return entry.name.removeprefix("MAV_TYPE_") if entry else str(mav_type)


def copter_mode_name(custom_mode: int) -> str:
    """ArduCopter's name of a custom mode (the dialect's COPTER_MODE)."""
    entry = mavlink.enums["COPTER_MODE"].get(custom_mode)
    return entry.name.removeprefix("COPTER_MODE_") if entry else f"mode {custom_mode}"


def message_name(msg_id: int) -> str:
    cls = mavlink.mavlink_map.get(msg_id)
    return cls.msgname if cls is not None else str(msg_id)


@dataclass(frozen=True)
class HeartbeatInfo:
    system_id: int
    component_id: int
    autopilot: int              # MAV_AUTOPILOT: 3 ArduPilot, 12 PX4, 8 invalid (not an autopilot)
    mav_type: int
    base_mode: int
    custom_mode: int
    system_status: int

    @property
    def custom_modes(self) -> bool:
        return bool(self.base_mode & MODE_FLAG_CUSTOM_MODE_ENABLED)


@dataclass(frozen=True)
class FirmwareVersion:
    system_id: int
    component_id: int
    major: int
    minor: int
    patch: int
    release: str                # official, beta, dev...
    capabilities: int

    def __str__(self) -> str:
        return f"{self.major}.{self.minor}.{self.patch} {self.release}"


@dataclass(frozen=True)
class ParamReading:
    system_id: int
    component_id: int
    name: str
    value: float


@dataclass(frozen=True)
class ObstacleLayout:
    """An obstacle message's shape: its frame and, for OBSTACLE_DISTANCE, the sectors (degrees,
    clockwise from the nose: element 0 at angle_offset_deg, each increment_deg further)."""
    system_id: int
    component_id: int
    msg_id: int
    frame: int
    min_distance_m: float
    max_distance_m: float
    angle_offset_deg: float = 0.0
    increment_deg: float = 0.0
    count: int = 0
    data_first: int = -1        # the first and last element holding data (not UINT16_MAX)
    data_last: int = -1

    @property
    def data_centre_deg(self) -> float | None:
        """The bearing midway between the first and the last element holding data."""
        if self.data_first < 0:
            return None
        return self.angle_offset_deg + 0.5 * (self.data_first + self.data_last) * self.increment_deg


Fact = HeartbeatInfo | FirmwareVersion | ParamReading | ObstacleLayout


def _heartbeat(msg, sysid: int, compid: int) -> HeartbeatInfo:
    return HeartbeatInfo(sysid, compid, int(msg.autopilot), int(msg.type), int(msg.base_mode),
                         int(msg.custom_mode), int(msg.system_status))


def _autopilot_version(msg, sysid: int, compid: int) -> FirmwareVersion:
    """flight_sw_version: major << 24 | minor << 16 | patch << 8 | FIRMWARE_VERSION_TYPE."""
    v = int(msg.flight_sw_version)
    return FirmwareVersion(sysid, compid, (v >> 24) & 0xFF, (v >> 16) & 0xFF, (v >> 8) & 0xFF,
                           _FIRMWARE_TYPES.get(v & 0xFF, f"type {v & 0xFF}"),
                           int(msg.capabilities))


def _param_value(msg, sysid: int, compid: int) -> ParamReading:
    name = msg.param_id
    if isinstance(name, (bytes, bytearray)):
        name = bytes(name).split(b"\0", 1)[0].decode("ascii", "replace")
    return ParamReading(sysid, compid, str(name).split("\0", 1)[0], float(msg.param_value))


def _obstacle_distance(msg, sysid: int, compid: int) -> ObstacleLayout:
    """distances, min/max in centimetres; increment_f (degrees) overrides the integer one."""
    step = msg.increment_f if msg.increment_f > 0.0 else float(msg.increment)
    data = [i for i, cm in enumerate(msg.distances) if cm != UINT16_MAX]
    return ObstacleLayout(sysid, compid, MSG_ID_OBSTACLE_DISTANCE, int(msg.frame),
                          msg.min_distance / 100.0, msg.max_distance / 100.0,
                          float(msg.angle_offset), float(step), len(msg.distances),
                          data[0] if data else -1, data[-1] if data else -1)


def _obstacle_distance_3d(msg, sysid: int, compid: int) -> ObstacleLayout:
    return ObstacleLayout(sysid, compid, MSG_ID_OBSTACLE_DISTANCE_3D, int(msg.frame),
                          float(msg.min_distance), float(msg.max_distance))


_DECODERS = {"HEARTBEAT": _heartbeat, "AUTOPILOT_VERSION": _autopilot_version,
             "PARAM_VALUE": _param_value, "OBSTACLE_DISTANCE": _obstacle_distance,
             "OBSTACLE_DISTANCE_3D": _obstacle_distance_3d}


def decode(msg) -> Fact | None:
    handler = _DECODERS.get(msg.get_type())
    return handler(msg, msg.get_srcSystem(), msg.get_srcComponent()) if handler else None


def message_id(msg) -> int:
    return msg.get_msgId()


def is_signed(msg) -> bool:
    """The packet carried a MAVLink 2 signature (its incompat flag; verified too if we hold a
    key: the parser refuses a bad one before this). Read off the bytes, since without a key
    pymavlink does not mark a signed message as such."""
    buf = msg.get_msgbuf()
    return len(buf) > 2 and buf[0] == MAVLINK2_MAGIC and bool(buf[2] & IFLAG_SIGNED)


def param_request_read(target_system: int, target_component: int,
                       name: str) -> mavlink.MAVLink_param_request_read_message:
    return mavlink.MAVLink_param_request_read_message(target_system, target_component,
                                                      name.encode("ascii"), -1)


def request_autopilot_version(target_system: int, target_component: int):
    """MAV_CMD_REQUEST_MESSAGE for AUTOPILOT_VERSION (what ArduPilot and PX4 both answer)."""
    return request_message(target_system, target_component, MSG_ID_AUTOPILOT_VERSION)


_LISTEN_ONLY_TYPES = {"HEARTBEAT", "TIMESYNC", "PARAM_REQUEST_READ", "REQUEST_DATA_STREAM"}
_LISTEN_ONLY_COMMANDS = {mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, mavlink.MAV_CMD_REQUEST_MESSAGE}


def is_listen_only(msg) -> bool:
    """May the doctor send this? Our heartbeat, TIMESYNC, parameter reads and stream or message
    requests only: nothing that changes a mode, arms, moves or sets a parameter."""
    kind = msg.get_type()
    if kind == "COMMAND_LONG":
        return int(msg.command) in _LISTEN_ONLY_COMMANDS
    return kind in _LISTEN_ONLY_TYPES
