"""ArduCopter-like MAVLink behaviour: modes, arming, parameters, streams, commands, GUIDED.

`Autopilot` consumes decoded messages and returns messages to send, with simulated time passed
in; it touches no sockets or clocks, so it is unit-testable. Every returned item is
(component id, message); the links send it to every client.
"""
from __future__ import annotations

import logging
import math

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from . import guided, streams, telemetry as tm
from .params import ParamTable
from .sim import Simulation
from .vehicle import HOLD, Demand

log = logging.getLogger(__name__)

Outgoing = tuple[int, object]

SUPPORTED_MODES = tuple(tm.MODE_NAMES)
# Modes from which ArduCopter allows arming (Mode::allows_arming): not AUTO, RTL, LAND.
ARMABLE_MODES = (tm.MODE_STABILIZE, tm.MODE_ALT_HOLD, tm.MODE_GUIDED, tm.MODE_LOITER,
                 tm.MODE_POSHOLD, tm.MODE_BRAKE)
FORCE_DISARM_MAGIC = 21196.0
REST_SPEED_MPS = 0.05

ACCEPTED = mavlink.MAV_RESULT_ACCEPTED
DENIED = mavlink.MAV_RESULT_DENIED
FAILED = mavlink.MAV_RESULT_FAILED
UNSUPPORTED = mavlink.MAV_RESULT_UNSUPPORTED

# MAVLink FTP error codes (mavlink.io/en/services/ftp.html)
FTP_ERR_UNKNOWN_COMMAND = 7
FTP_ERR_FILE_NOT_FOUND = 10


class Autopilot:
    """Component 1 of the simulated vehicle."""

    def __init__(self, sim: Simulation, params: ParamTable, start_unix_s: float = 0.0) -> None:
        self.sim = sim
        self.params = params
        self.sysid = int(params.get("SYSID_THISMAV"))
        self.scheduler = streams.StreamScheduler(params)
        self.mode = tm.MODE_STABILIZE
        self.armed = False
        self.target: guided.GuidedTarget | None = None
        self.cruise_override_mps: float | None = None
        self.start_unix_s = start_unix_s
        self.home = (sim.truth.north_m, sim.truth.east_m)
        self.ignored_targets = 0

    # ----------------------------------------------------------------- physics interface
    def demand(self, t_s: float) -> Demand:
        """What the airframe is asked to do during the next step."""
        if not self.armed or self.mode != tm.MODE_GUIDED:
            return HOLD   # every other mode of the 2D vehicle decelerates to a stop and holds
        cruise = self.cruise_override_mps or self.params.get("WPNAV_SPEED") / 100.0
        return guided.demand_for(self.target, self.sim.odometry, t_s, self._guid_timeout_s(),
                                 cruise, self.sim.limits.max_accel_mps2)

    def after_step(self, t_s: float) -> list[Outgoing]:
        """State changes that follow the physics (LAND disarms once the vehicle is at rest)."""
        if self.armed and self.mode == tm.MODE_LAND and self.sim.truth.speed_mps == 0.0:
            self._set_armed(False, "landed")
        return []

    def periodic(self, t_s: float) -> list[Outgoing]:
        """Heartbeat and the telemetry streams due at t_s."""
        out: list[Outgoing] = []
        sim = self.sim
        origin = sim.scenario.world.origin
        for msg_id in self.scheduler.due(t_s):
            msg = self._stream_message(msg_id, t_s, origin)
            if msg is not None:
                out.append((tm.COMP_AUTOPILOT, msg))
        return out

    def _stream_message(self, msg_id: int, t_s: float, origin):
        sim = self.sim
        if msg_id == streams.MSG_HEARTBEAT:
            return tm.heartbeat_autopilot(self.mode, self.armed)
        if msg_id == streams.MSG_SYS_STATUS:
            return tm.sys_status()
        if msg_id == streams.MSG_SYSTEM_TIME:
            return tm.system_time(t_s, self.start_unix_s)
        if msg_id == streams.MSG_ATTITUDE:
            return tm.attitude(t_s, sim.odometry)
        if msg_id == streams.MSG_LOCAL_POSITION_NED:
            return tm.local_position_ned(t_s, sim.odometry)
        if msg_id == streams.MSG_GLOBAL_POSITION_INT:
            return tm.global_position_int(t_s, sim.odometry, origin)
        if msg_id == streams.MSG_SIMSTATE:
            return tm.simstate(sim.truth, origin)
        if msg_id == streams.MSG_HOME_POSITION:
            return tm.home_position(origin, *self.home, t_s)
        if msg_id == streams.MSG_POSITION_TARGET_LOCAL_NED:
            if self.mode != tm.MODE_GUIDED or self.target is None:
                return None
            fields = guided.report_fields(self.target, t_s, self._guid_timeout_s())
            return tm.position_target_local_ned(t_s, fields)
        return None

    # ----------------------------------------------------------------- message handling
    def handle(self, msg, t_s: float) -> list[Outgoing]:
        """Handle one decoded message from a client; returns the replies."""
        mtype = msg.get_type()
        if not self._for_us(msg):
            return []
        handler = getattr(self, "_on_" + mtype.lower(), None)
        if handler is None:
            return []   # includes PARAM_EXT_* and anything else the stub does not implement
        return handler(msg, t_s)

    def _for_us(self, msg) -> bool:
        target_system = getattr(msg, "target_system", 0)
        if target_system not in (0, self.sysid):
            return False
        return True

    def _addressed_to_camera(self, msg) -> bool:
        return getattr(msg, "target_component", 0) == tm.COMP_CAMERA

    def _ack(self, msg, command: int, result: int, comp: int = tm.COMP_AUTOPILOT) -> Outgoing:
        return (comp, tm.command_ack(command, result, msg.get_srcSystem(), msg.get_srcComponent()))

    def _on_set_mode(self, msg, t_s: float) -> list[Outgoing]:
        # ArduPilot answers SET_MODE with a COMMAND_ACK whose command is the message id (11).
        result = self._set_mode_common(int(msg.base_mode), int(msg.custom_mode), t_s)
        return [self._ack(msg, mavlink.MAVLINK_MSG_ID_SET_MODE, result)]

    def _on_param_request_list(self, msg, t_s: float) -> list[Outgoing]:
        if self._addressed_to_camera(msg):
            return []
        return [(tm.COMP_AUTOPILOT, tm.param_value(p)) for p in self.params.all()]

    def _on_param_request_read(self, msg, t_s: float) -> list[Outgoing]:
        if self._addressed_to_camera(msg):
            return []
        if msg.param_index >= 0:
            record = self.params.by_index(int(msg.param_index))
        else:
            record = self.params.by_name(_param_name(msg.param_id))
        return [] if record is None else [(tm.COMP_AUTOPILOT, tm.param_value(record))]

    def _on_param_set(self, msg, t_s: float) -> list[Outgoing]:
        if self._addressed_to_camera(msg):
            return []
        name = _param_name(msg.param_id)
        record = self.params.set(name, float(msg.param_value))
        if record is None:
            log.warning("PARAM_SET ignored: %r = %r", name, msg.param_value)
            return []
        log.info("parameter %s set to %g", name, record.value)
        if name.startswith("SR"):
            self.scheduler.rates_changed()
        return [(tm.COMP_AUTOPILOT, tm.param_value(record))]

    def _on_request_data_stream(self, msg, t_s: float) -> list[Outgoing]:
        self.scheduler.request_data_stream(int(msg.req_stream_id), int(msg.req_message_rate),
                                           bool(msg.start_stop))
        return []

    def _on_mission_request_list(self, msg, t_s: float) -> list[Outgoing]:
        return [(tm.COMP_AUTOPILOT, tm.mission_count(msg.get_srcSystem(), msg.get_srcComponent(),
                                                     getattr(msg, "mission_type", 0)))]

    def _on_file_transfer_protocol(self, msg, t_s: float) -> list[Outgoing]:
        payload = bytes(msg.payload)
        opcode = payload[3] if len(payload) > 3 else 0
        # ListDirectory (3) and OpenFileRO (4): "no such file" lets a GCS fall back to
        # PARAM_REQUEST_LIST; anything else is an unknown command for the stub.
        error = FTP_ERR_FILE_NOT_FOUND if opcode in (3, 4) else FTP_ERR_UNKNOWN_COMMAND
        return [(tm.COMP_AUTOPILOT, tm.ftp_nak(payload, error, msg.get_srcSystem(),
                                               msg.get_srcComponent()))]

    def _on_set_position_target_local_ned(self, msg, t_s: float) -> list[Outgoing]:
        if self._addressed_to_camera(msg):
            return []
        if self.mode != tm.MODE_GUIDED or not self.armed:
            self.ignored_targets += 1
            return []
        target = guided.parse_target(msg, self.sim.odometry, t_s)
        if target.kind == guided.KIND_HOLD:
            log.warning("GUIDED target refused, holding: %s", target.reason)
        self.target = target
        return []

    def _on_command_long(self, msg, t_s: float) -> list[Outgoing]:
        params = [msg.param1, msg.param2, msg.param3, msg.param4, msg.param5, msg.param6,
                  msg.param7]
        return self._command(msg, int(msg.command), params, t_s)

    def _on_command_int(self, msg, t_s: float) -> list[Outgoing]:
        params = [msg.param1, msg.param2, msg.param3, msg.param4, float(msg.x), float(msg.y),
                  msg.z]
        return self._command(msg, int(msg.command), params, t_s)

    # ----------------------------------------------------------------- commands
    def _command(self, msg, command: int, p: list[float], t_s: float) -> list[Outgoing]:
        if self._addressed_to_camera(msg):
            return [self._ack(msg, command, UNSUPPORTED, comp=tm.COMP_CAMERA)]
        extra: list[Outgoing] = []
        if command == mavlink.MAV_CMD_COMPONENT_ARM_DISARM:
            result = self._arm_disarm(p[0], p[1])
        elif command == mavlink.MAV_CMD_DO_SET_MODE:
            result = self._set_mode_common(_as_int(p[0]), _as_int(p[1]), t_s)
        elif command == mavlink.MAV_CMD_NAV_TAKEOFF:
            # 2D model: no altitude; accepted where ArduCopter would start a takeoff.
            result = ACCEPTED if (self.armed and self.mode == tm.MODE_GUIDED) else FAILED
        elif command == mavlink.MAV_CMD_NAV_LAND:
            result = self._set_mode_common(mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, tm.MODE_LAND, t_s)
        elif command == mavlink.MAV_CMD_NAV_RETURN_TO_LAUNCH:
            result = self._set_mode_common(mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, tm.MODE_RTL, t_s)
        elif command == mavlink.MAV_CMD_NAV_LOITER_UNLIM:
            result = self._set_mode_common(mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, tm.MODE_LOITER, t_s)
        elif command == mavlink.MAV_CMD_DO_CHANGE_SPEED:
            if math.isfinite(p[1]) and p[1] > 0.0:
                self.cruise_override_mps = float(p[1])
                result = ACCEPTED
            else:
                result = FAILED
        elif command == mavlink.MAV_CMD_SET_MESSAGE_INTERVAL:
            ok = (math.isfinite(p[0]) and math.isfinite(p[1])
                  and self.scheduler.set_message_interval(_as_int(p[0]), p[1]))
            result = ACCEPTED if ok else FAILED
        elif command == mavlink.MAV_CMD_GET_MESSAGE_INTERVAL:
            msg_id = _as_int(p[0])
            extra.append((tm.COMP_AUTOPILOT, tm.message_interval(msg_id, self._interval_us(msg_id))))
            result = ACCEPTED
        elif command == mavlink.MAV_CMD_REQUEST_MESSAGE:
            reply = self._requested_message(_as_int(p[0]), t_s)
            result = ACCEPTED if reply is not None else FAILED
            if reply is not None:
                extra.append((tm.COMP_AUTOPILOT, reply))
        elif command == mavlink.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES:
            extra.append((tm.COMP_AUTOPILOT, tm.autopilot_version()))
            result = ACCEPTED
        elif command == mavlink.MAV_CMD_GET_HOME_POSITION:
            extra.append((tm.COMP_AUTOPILOT, self._stream_message(streams.MSG_HOME_POSITION, t_s,
                                                                  self.sim.scenario.world.origin)))
            result = ACCEPTED
        else:
            result = UNSUPPORTED
        return [self._ack(msg, command, result)] + extra

    def _interval_us(self, msg_id: int) -> int:
        if msg_id not in streams.STREAMABLE:
            return 0          # not available
        interval = self.scheduler.interval_s(msg_id)
        return -1 if interval is None else int(round(interval * 1e6))

    def _requested_message(self, msg_id: int, t_s: float):
        if msg_id == mavlink.MAVLINK_MSG_ID_AUTOPILOT_VERSION:
            return tm.autopilot_version()
        if msg_id in streams.STREAMABLE:
            return self._stream_message(msg_id, t_s, self.sim.scenario.world.origin)
        return None

    def _arm_disarm(self, param1: float, param2: float) -> int:
        if param1 == 1.0:
            if self.armed:
                return ACCEPTED
            if self.mode not in ARMABLE_MODES:
                log.warning("arming refused in mode %s", tm.MODE_NAMES[self.mode])
                return FAILED
            self._set_armed(True, "command")
            return ACCEPTED
        if param1 == 0.0:
            moving = self.sim.truth.speed_mps > REST_SPEED_MPS
            if moving and param2 != FORCE_DISARM_MAGIC:
                return FAILED       # ArduCopter refuses to disarm in flight unless forced
            self._set_armed(False, "forced" if moving else "command")
            return ACCEPTED
        return UNSUPPORTED

    def _set_armed(self, armed: bool, reason: str) -> None:
        if armed != self.armed:
            log.info("%s (%s)", "armed" if armed else "disarmed", reason)
        self.armed = armed
        if armed:
            self.home = (self.sim.odometry.north_m, self.sim.odometry.east_m)

    def _set_mode_common(self, base_mode: int, custom_mode: int, t_s: float) -> int:
        """GCS_MAVLINK::_set_mode_common: only custom modes; unknown custom mode -> FAILED."""
        if not base_mode & mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED:
            return DENIED
        if custom_mode not in SUPPORTED_MODES:
            log.warning("mode %d not supported", custom_mode)
            return FAILED
        if custom_mode != self.mode:
            log.info("mode %s -> %s", tm.MODE_NAMES[self.mode], tm.MODE_NAMES[custom_mode])
        if custom_mode == tm.MODE_GUIDED and self.mode != tm.MODE_GUIDED:
            # ModeGuided::init: start with a zero-velocity target (hold) until told otherwise.
            self.target = guided.hold_target(t_s, "entered GUIDED")
        elif custom_mode != tm.MODE_GUIDED:
            self.target = None
        self.mode = custom_mode
        return ACCEPTED

    def _guid_timeout_s(self) -> float:
        return guided.timeout_s(self.params.get("GUID_TIMEOUT"))


def _param_name(raw) -> str:
    if isinstance(raw, (bytes, bytearray)):
        raw = raw.decode("ascii", errors="replace")
    return str(raw).rstrip("\x00")


def _as_int(value: float) -> int:
    return int(value) if math.isfinite(value) else -1
