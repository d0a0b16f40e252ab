"""The MAVLink mission protocol's messages <-> typed events and intents (the mission's part of
mavlink/: field names and scalings stay in mavlink/). Pure translation, no state.

Scalings (MISSION_ITEM_INT): x, y are latitude/longitude in 1e-7 degrees in global frames and
metres x 1e4 in local frames; z is metres. Mission type 0 (MAV_MISSION_TYPE_MISSION) only.
"""
from __future__ import annotations

from dataclasses import dataclass

from companion.mavlink.dialect import mavlink

MISSION_TYPE_MISSION = mavlink.MAV_MISSION_TYPE_MISSION
MISSION_ACCEPTED = mavlink.MAV_MISSION_ACCEPTED
MISSION_OPERATION_CANCELLED = mavlink.MAV_MISSION_OPERATION_CANCELLED
CMD_NAV_WAYPOINT = mavlink.MAV_CMD_NAV_WAYPOINT
FRAME_GLOBAL = mavlink.MAV_FRAME_GLOBAL
FRAME_GLOBAL_INT = mavlink.MAV_FRAME_GLOBAL_INT
FRAME_GLOBAL_RELATIVE_ALT = mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT
FRAME_GLOBAL_RELATIVE_ALT_INT = mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT
FRAME_LOCAL_NED = mavlink.MAV_FRAME_LOCAL_NED
GLOBAL_FRAMES = (FRAME_GLOBAL, FRAME_GLOBAL_INT, FRAME_GLOBAL_RELATIVE_ALT,
                 FRAME_GLOBAL_RELATIVE_ALT_INT)
LOCAL_FRAMES = (FRAME_LOCAL_NED,)
LOCAL_INT_SCALE = 1e4          # MISSION_ITEM_INT local x, y: metres x 1e4


def command_name(command: int) -> str:
    entry = mavlink.enums["MAV_CMD"].get(command)
    return entry.name if entry is not None else f"MAV_CMD {command}"


def frame_name(frame: int) -> str:
    entry = mavlink.enums["MAV_FRAME"].get(frame)
    return entry.name if entry is not None else f"frame {frame}"


# ------------------------------------------------------------------ inbound events
@dataclass(frozen=True)
class MissionCount:
    system_id: int
    component_id: int
    count: int
    mission_type: int
    target_system: int
    target_component: int


@dataclass(frozen=True)
class MissionItem:
    """One MISSION_ITEM_INT, decoded: lat/lon in degrees for global frames, north/east in metres
    for local ones (``x``/``y`` keep the scaled values as sent)."""
    system_id: int
    component_id: int
    seq: int
    frame: int
    command: int
    params: tuple[float, float, float, float]
    x: int
    y: int
    z: float
    mission_type: int
    target_system: int
    target_component: int

    @property
    def lat_deg(self) -> float:
        return self.x / 1e7

    @property
    def lon_deg(self) -> float:
        return self.y / 1e7

    @property
    def north_m(self) -> float:
        return self.x / LOCAL_INT_SCALE

    @property
    def east_m(self) -> float:
        return self.y / LOCAL_INT_SCALE


@dataclass(frozen=True)
class MissionAck:
    system_id: int
    component_id: int
    result: int
    mission_type: int
    target_system: int
    target_component: int


@dataclass(frozen=True)
class MissionCurrent:
    """MISSION_CURRENT: the autopilot's current item; ``total`` (items without home, 0 not
    supported, 65535 none) and ``mission_id`` (0: not supported) change when the mission does."""
    system_id: int
    component_id: int
    seq: int
    total: int
    mission_id: int


@dataclass(frozen=True)
class MissionItemReached:
    system_id: int
    component_id: int
    seq: int


@dataclass(frozen=True)
class MissionRequestSeen:
    """MISSION_REQUEST or MISSION_REQUEST_INT from the vehicle: it is receiving an upload from
    (target_system, target_component)."""
    system_id: int
    component_id: int
    seq: int
    mission_type: int
    target_system: int
    target_component: int


def _request(msg, sysid: int, compid: int) -> MissionRequestSeen:
    return MissionRequestSeen(sysid, compid, int(msg.seq), int(getattr(msg, "mission_type", 0)),
                              int(msg.target_system), int(msg.target_component))


def _count(msg, sysid: int, compid: int) -> MissionCount:
    return MissionCount(sysid, compid, int(msg.count), int(getattr(msg, "mission_type", 0)),
                        int(msg.target_system), int(msg.target_component))


def _item_int(msg, sysid: int, compid: int) -> MissionItem:
    return MissionItem(sysid, compid, int(msg.seq), int(msg.frame), int(msg.command),
                       (float(msg.param1), float(msg.param2), float(msg.param3),
                        float(msg.param4)), int(msg.x), int(msg.y), float(msg.z),
                       int(getattr(msg, "mission_type", 0)), int(msg.target_system),
                       int(msg.target_component))


def _ack(msg, sysid: int, compid: int) -> MissionAck:
    return MissionAck(sysid, compid, int(msg.type), int(getattr(msg, "mission_type", 0)),
                      int(msg.target_system), int(msg.target_component))


def _current(msg, sysid: int, compid: int) -> MissionCurrent:
    return MissionCurrent(sysid, compid, int(msg.seq), int(getattr(msg, "total", 0)),
                          int(getattr(msg, "mission_id", 0)))


def _reached(msg, sysid: int, compid: int) -> MissionItemReached:
    return MissionItemReached(sysid, compid, int(msg.seq))


DECODERS = {
    "MISSION_COUNT": _count,
    "MISSION_ITEM_INT": _item_int,
    "MISSION_ACK": _ack,
    "MISSION_CURRENT": _current,
    "MISSION_ITEM_REACHED": _reached,
    "MISSION_REQUEST": _request,
    "MISSION_REQUEST_INT": _request,
}

MissionEvent = MissionCount | MissionItem | MissionAck | MissionCurrent | MissionItemReached \
    | MissionRequestSeen


# ------------------------------------------------------------------ outbound intents
@dataclass(frozen=True)
class RequestList:
    target_system: int
    target_component: int


@dataclass(frozen=True)
class RequestItem:
    target_system: int
    target_component: int
    seq: int


@dataclass(frozen=True)
class AckDownload:
    target_system: int
    target_component: int
    result: int


MissionRequest = RequestList | RequestItem | AckDownload


def encode(request: MissionRequest):
    """The pymavlink message of a mission intent (mission type MISSION)."""
    if isinstance(request, RequestList):
        return mavlink.MAVLink_mission_request_list_message(
            request.target_system, request.target_component, MISSION_TYPE_MISSION)
    if isinstance(request, RequestItem):
        return mavlink.MAVLink_mission_request_int_message(
            request.target_system, request.target_component, request.seq, MISSION_TYPE_MISSION)
    return mavlink.MAVLink_mission_ack_message(
        request.target_system, request.target_component, request.result, MISSION_TYPE_MISSION)


# ------------------------------------------------------------------ "fly to here"
POSITION_IGNORED_BITS = 0x7         # POSITION_TARGET_TYPEMASK X, Y, Z ignore
CMD_DO_REPOSITION = mavlink.MAV_CMD_DO_REPOSITION
GOAL_FRAMES_INT = (mavlink.MAV_FRAME_GLOBAL_INT, mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
                   mavlink.MAV_FRAME_GLOBAL_TERRAIN_ALT_INT, *GLOBAL_FRAMES)


@dataclass(frozen=True)
class GoalRequest:
    """A ground station's "fly to here" addressed to the vehicle: SET_POSITION_TARGET_GLOBAL_INT
    with a position, or MAV_CMD_DO_REPOSITION (COMMAND_INT x/y in 1e-7 degrees; COMMAND_LONG
    param5/6 in degrees). ``problem``: why it carries no usable position."""
    system_id: int
    component_id: int
    target_system: int
    target_component: int
    kind: str                       # 'position_target' or 'reposition'
    lat_deg: float
    lon_deg: float
    problem: str | None = None


def _position_target_global(msg, sysid: int, compid: int) -> GoalRequest:
    problem = None
    if msg.type_mask & POSITION_IGNORED_BITS:
        problem = "target has no position"
    elif msg.coordinate_frame not in GOAL_FRAMES_INT:
        problem = f"frame {msg.coordinate_frame} not global"
    return GoalRequest(sysid, compid, int(msg.target_system), int(msg.target_component),
                       "position_target", msg.lat_int / 1e7, msg.lon_int / 1e7, problem)


def _command_int(msg, sysid: int, compid: int) -> GoalRequest | None:
    if msg.command != CMD_DO_REPOSITION:
        return None
    problem = None if msg.frame in GOAL_FRAMES_INT else f"frame {msg.frame} not global"
    return GoalRequest(sysid, compid, int(msg.target_system), int(msg.target_component),
                       "reposition", msg.x / 1e7, msg.y / 1e7, problem)


def _command_long(msg, sysid: int, compid: int) -> GoalRequest | None:
    """param5/6 are float32 degrees: about 1 m of resolution (COMMAND_INT carries 1e-7 deg)."""
    if msg.command != CMD_DO_REPOSITION:
        return None
    return GoalRequest(sysid, compid, int(msg.target_system), int(msg.target_component),
                       "reposition", float(msg.param5), float(msg.param6))


GOAL_DECODERS = {
    "SET_POSITION_TARGET_GLOBAL_INT": _position_target_global,
    "COMMAND_INT": _command_int,
    "COMMAND_LONG": _command_long,
}
