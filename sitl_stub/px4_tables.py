"""PX4's tables for the stub's PX4 face: modes, parameters, default streams, the mission store.

Facts from PX4-Autopilot (release 1.15), cited where used:
- src/modules/commander/px4_custom_mode.h: HEARTBEAT.custom_mode = main mode << 16 | sub << 24.
- src/modules/mavlink/mavlink_main.cpp, configure_streams_to_default, MAVLINK_MODE_ONBOARD: what
  an onboard link gets unasked (ATTITUDE 100 Hz, LOCAL_POSITION_NED 30 Hz, GLOBAL_POSITION_INT
  50 Hz, EXTENDED_SYS_STATE 5 Hz, ESTIMATOR_STATUS 1 Hz, GPS_RAW_INT every fix, ...). The stub
  emits on its physics steps, so anything faster than 1 / dt comes once a step.
- Parameters (src/modules/commander/commander_params.c, mc_pos_control, navigator): COM_OF_LOSS_T
  1 s, COM_OBL_RC_ACT 0 (Position), COM_RC_IN_MODE 3, COM_DISARM_PRFLT 10 s, COM_DISARM_LAND 2 s,
  MIS_TAKEOFF_ALT 2.5 m, MPC_TKO_SPEED 1.5 m/s, MPC_LAND_SPEED 0.7 m/s, MPC_XY_CRUISE 5 m/s.
  PX4 carries integer parameters bytewise in PARAM_VALUE's float (MAV_PROTOCOL_CAPABILITY_
  PARAM_ENCODE_BYTEWISE): the int32's bits, not its value.
- src/modules/mavlink/mavlink_mission.cpp: the mission's item 0 is a mission item (home is kept
  apart and sent as HOME_POSITION); MISSION_CURRENT.total is the item count.
"""
from __future__ import annotations

import struct

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from .mission_store import MissionStore
from .params import MAV_PARAM_TYPE_INT32, MAV_PARAM_TYPE_REAL32, ParamTable, ParamValue
from . import streams

MAIN_MANUAL, MAIN_ALTCTL, MAIN_POSCTL, MAIN_AUTO, MAIN_ACRO, MAIN_OFFBOARD = 1, 2, 3, 4, 5, 6
SUB_TAKEOFF, SUB_LOITER, SUB_MISSION, SUB_RTL, SUB_LAND = 2, 3, 4, 5, 6


def custom_mode(main: int, sub: int = 0) -> int:
    return (main << 16) | (sub << 24)


POSCTL = custom_mode(MAIN_POSCTL)
ALTCTL = custom_mode(MAIN_ALTCTL)
MANUAL = custom_mode(MAIN_MANUAL)
OFFBOARD = custom_mode(MAIN_OFFBOARD)
TAKEOFF = custom_mode(MAIN_AUTO, SUB_TAKEOFF)
HOLD = custom_mode(MAIN_AUTO, SUB_LOITER)           # AUTO.LOITER, "Hold"
MISSION = custom_mode(MAIN_AUTO, SUB_MISSION)
RTL = custom_mode(MAIN_AUTO, SUB_RTL)
LAND = custom_mode(MAIN_AUTO, SUB_LAND)
MODE_NAMES = {POSCTL: "POSCTL", ALTCTL: "ALTCTL", MANUAL: "MANUAL", OFFBOARD: "OFFBOARD",
              TAKEOFF: "AUTO.TAKEOFF", HOLD: "AUTO.LOITER", MISSION: "AUTO.MISSION",
              RTL: "AUTO.RTL", LAND: "AUTO.LAND"}
# Modes needing manual control (sticks): without RC (the stub has none) they cannot run.
MANUAL_MODES = (POSCTL, ALTCTL, MANUAL)

# COM_OBL_RC_ACT (failsafe.cpp fromOffboardLossActParam): 0 Position, 1 Altitude, 2 Manual,
# 3 Return, 4 Land, 5 Hold, 6 Terminate, 7 Disarm. The manual fallbacks need sticks; without
# them checkModeFallback ends at "Last, check can_run for intended mode": Return.
OBL_ACTIONS = {0: RTL, 1: RTL, 2: RTL, 3: RTL, 4: LAND, 5: HOLD, 6: None, 7: None}

MSG_ESTIMATOR_STATUS = mavlink.MAVLINK_MSG_ID_ESTIMATOR_STATUS      # 230
# Onboard-mode defaults (mavlink_main.cpp), Hz; GPS_RAW_INT: "unlimited", every fix (5 Hz here).
ONBOARD_RATES_HZ = {
    streams.MSG_HEARTBEAT: 1.0,
    streams.MSG_ATTITUDE: 100.0,
    streams.MSG_LOCAL_POSITION_NED: 30.0,
    streams.MSG_GLOBAL_POSITION_INT: 50.0,
    streams.MSG_EXTENDED_SYS_STATE: 5.0,
    MSG_ESTIMATOR_STATUS: 1.0,
    streams.MSG_SYS_STATUS: 5.0,
    streams.MSG_GPS_RAW_INT: 5.0,
    streams.MSG_HOME_POSITION: 0.5,
    streams.MSG_GPS_GLOBAL_ORIGIN: 1.0,
    streams.MSG_BATTERY_STATUS: 0.5,
    streams.MSG_SYSTEM_TIME: 1.0,
    streams.MSG_POSITION_TARGET_LOCAL_NED: 10.0,
    streams.MSG_MISSION_CURRENT: 1.0,          # the mission manager's own, not a stream
}
STREAMABLE = tuple(ONBOARD_RATES_HZ)


class Px4Streams(streams.StreamScheduler):
    """The stub's scheduler with PX4's onboard defaults instead of ArduPilot's SRn_ streams."""

    streamable = STREAMABLE

    def default_interval_s(self, msg_id: int) -> float | None:
        rate = ONBOARD_RATES_HZ.get(msg_id)
        return None if rate is None else 1.0 / rate

    def set_message_interval(self, msg_id: int, interval_us: float) -> bool:
        """MAV_CMD_SET_MESSAGE_INTERVAL: -1 stops, 0 restores the default, > 0 sets it."""
        if msg_id not in STREAMABLE:
            return False
        if interval_us == -1:
            self._override_s[msg_id] = -1.0
        elif interval_us == 0:
            self._override_s.pop(msg_id, None)
        elif interval_us > 0:
            self._override_s[msg_id] = interval_us / 1e6
        else:
            return False
        self._next_due_s.pop(msg_id, None)
        return True

    def request_data_stream(self, stream_id: int, rate_hz: int, start: bool) -> bool:
        return False               # PX4 ignores REQUEST_DATA_STREAM (deprecated)


class Px4Params(ParamTable):
    """A few of PX4's parameters, with their 1.15 defaults (see the module docstring)."""

    def __init__(self, sysid: int = 1) -> None:
        entries = [
            ("MAV_SYS_ID", float(sysid), MAV_PARAM_TYPE_INT32),
            ("MAV_COMP_ID", 1.0, MAV_PARAM_TYPE_INT32),
            ("MAV_1_MODE", 2.0, MAV_PARAM_TYPE_INT32),        # onboard (the companion's port)
            ("COM_OF_LOSS_T", 1.0, MAV_PARAM_TYPE_REAL32),    # s
            ("COM_OBL_RC_ACT", 0.0, MAV_PARAM_TYPE_INT32),    # 0: Position
            ("COM_RC_IN_MODE", 3.0, MAV_PARAM_TYPE_INT32),
            ("COM_DISARM_PRFLT", 10.0, MAV_PARAM_TYPE_REAL32),
            ("COM_DISARM_LAND", 2.0, MAV_PARAM_TYPE_REAL32),
            ("MIS_TAKEOFF_ALT", 2.5, MAV_PARAM_TYPE_REAL32),
            ("MPC_TKO_SPEED", 1.5, MAV_PARAM_TYPE_REAL32),
            ("MPC_Z_VEL_MAX_UP", 3.0, MAV_PARAM_TYPE_REAL32),
            ("MPC_Z_VEL_MAX_DN", 1.5, MAV_PARAM_TYPE_REAL32),
            ("MPC_LAND_SPEED", 0.7, MAV_PARAM_TYPE_REAL32),
            ("MPC_XY_CRUISE", 5.0, MAV_PARAM_TYPE_REAL32),
            ("RTL_RETURN_ALT", 30.0, MAV_PARAM_TYPE_REAL32),
            ("NAV_DLL_ACT", 0.0, MAV_PARAM_TYPE_INT32),
        ]
        self._names = [name for name, _, _ in entries]
        self._values = {name: value for name, value, _ in entries}
        self._types = {name: ptype for name, _, ptype in entries}

    def get(self, name: str) -> float:
        if name == "SYSID_THISMAV":         # the base Autopilot reads ArduPilot's name
            name = "MAV_SYS_ID"
        return self._values[name]

    def stream_rate_hz(self, suffix: str) -> float:
        return 0.0


def param_value_bytewise(p: ParamValue) -> mavlink.MAVLink_param_value_message:
    """PARAM_VALUE as PX4 sends it: an INT32's bits in the float field."""
    value = p.value
    if p.param_type == MAV_PARAM_TYPE_INT32:
        value = struct.unpack("<f", struct.pack("<i", int(value)))[0]
    return mavlink.MAVLink_param_value_message(p.name.encode("ascii"), value, p.param_type,
                                               p.count, p.index)


def decode_bytewise(raw: float, param_type: int) -> float:
    """PARAM_SET's value as PX4 reads it (an INT32's bits in the float)."""
    if param_type == MAV_PARAM_TYPE_INT32:
        return float(struct.unpack("<i", struct.pack("<f", raw))[0])
    return raw


class Px4MissionStore(MissionStore):
    """PX4 keeps no home item: item 0 is the first mission item, and it asks for items with
    MISSION_REQUEST_INT."""

    @property
    def count(self) -> int:
        return len(self.items)

    def item(self, seq: int):
        return self.items[seq]

    def _complete(self, src, items) -> list:
        self.items = list(items)
        self.current_seq = 0
        self.uploads += 1
        return [self._ack(src, mavlink.MAV_MISSION_ACCEPTED), self.mission_current()]

    def _request(self, dest, seq: int):
        return mavlink.MAVLink_mission_request_int_message(*dest, seq, 0)
