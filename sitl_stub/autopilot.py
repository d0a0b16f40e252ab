"""ArduCopter-like MAVLink behaviour: modes, arming, parameters, streams, commands, GUIDED.

`Autopilot` consumes decoded messages and returns messages to send, with simulated time passed
in; it touches no sockets or clocks, so it is unit-testable. Every returned item is
(component id, message); the links send it to every client.
"""
from __future__ import annotations

import dataclasses
import logging
import math

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from . import flight, guided, streams, telemetry as tm
from .mission_store import MissionStore
from .params import ParamTable
from .sim import ClimbLimits, Simulation
from .vehicle import GROUNDED, Demand

log = logging.getLogger(__name__)

Outgoing = tuple[int, object]

SUPPORTED_MODES = tuple(tm.MODE_NAMES)
# Modes from which ArduCopter allows arming (Mode::allows_arming): not AUTO, RTL, LAND.
ARMABLE_MODES = (tm.MODE_STABILIZE, tm.MODE_ALT_HOLD, tm.MODE_GUIDED, tm.MODE_LOITER,
                 tm.MODE_POSHOLD, tm.MODE_BRAKE)
# Modes with a user takeoff (Mode::has_user_takeoff): NAV_TAKEOFF climbs in them.
USER_TAKEOFF_MODES = (tm.MODE_GUIDED, tm.MODE_LOITER, tm.MODE_ALT_HOLD, tm.MODE_POSHOLD)
# Modes whose position controllers run (SYS_STATUS Z/XY control enabled when flying).
POSITION_CONTROL_MODES = (tm.MODE_GUIDED, tm.MODE_LOITER, tm.MODE_POSHOLD, tm.MODE_BRAKE,
                          tm.MODE_RTL, tm.MODE_AUTO, tm.MODE_LAND)
FORCE_DISARM_MAGIC = 21196.0
BATTERY_CAPACITY_MAH = 5200.0
BATTERY_FULL_MV, BATTERY_EMPTY_MV = 12600.0, 10500.0
CURRENT_IDLE_A, CURRENT_ARMED_A, CURRENT_FLYING_A = 0.5, 2.0, 28.0   # 28 A: the SITL binary hovering

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
        self.streams = streams.LinkSchedulers(params)
        self._link: str | None = None   # the link of the message being handled
        self.mode = tm.MODE_STABILIZE
        self.armed = False
        self.target: guided.GuidedTarget | None = None
        self.cruise_override_mps: float | None = None
        self.start_unix_s = start_unix_s
        self.home = (sim.truth.north_m, sim.truth.east_m, sim.truth.up_m)
        self.ignored_targets = 0
        self.flight = flight.FlightState()
        self.hold_up_m = 0.0            # altitude held outside GUIDED (and by LOITER & co.)
        self.consumed_mah = 0.0
        self.on_signing_request = None  # set by the links: SETUP_SIGNING(key bytes, timestamp)
        self.mission = MissionStore(self._home_lat_lon_alt)

    def _home_lat_lon_alt(self) -> tuple[float, float, float]:
        origin = self.sim.scenario.world.origin
        return (*origin.to_lat_lon_deg(self.home[0], self.home[1]), origin.alt_m + self.home[2])

    # ----------------------------------------------------------------- physics interface
    def demand(self, t_s: float) -> Demand:
        """What the airframe is asked to do during the next step."""
        if not self.armed or self.flight.motors_idle:
            return GROUNDED     # disarmed, or landed: ground handling, motors idle
        if self.mode == tm.MODE_LAND:
            return Demand(climb_mps=-self._land_speed_mps())
        takeoff = self.flight.takeoff
        if takeoff is not None:
            if not takeoff.climbing(t_s):
                return GROUNDED     # spooling up: still standing on the ground, nothing moves
            return Demand(target_up_m=takeoff.target_up_m)
        if self.mode != tm.MODE_GUIDED:
            return Demand(target_up_m=self.hold_up_m)   # decelerate and hold
        cruise = self.cruise_override_mps or self.params.get("WPNAV_SPEED") / 100.0
        return guided.demand_for(self.target, self.sim.odometry, t_s, self._guid_timeout_s(),
                                 cruise, self.sim.limits.max_accel_mps2)

    def climb_limits(self) -> ClimbLimits:
        """WPNAV_SPEED_UP / WPNAV_SPEED_DN, or the landing speed in LAND."""
        down = self._land_speed_mps() if self.mode == tm.MODE_LAND else \
            self.params.get("WPNAV_SPEED_DN") / 100.0
        return ClimbLimits(max_up_mps=self.params.get("WPNAV_SPEED_UP") / 100.0,
                           max_down_mps=down)

    def _land_speed_mps(self) -> float:
        """mode_land.cpp: LAND_SPEED below LAND_ALT_LOW, above it LAND_SPEED_HIGH (0: WPNAV_SPEED_DN)."""
        if self.sim.truth.up_m > self.params.get("LAND_ALT_LOW") / 100.0:
            high = self.params.get("LAND_SPEED_HIGH") or self.params.get("WPNAV_SPEED_DN")
            return high / 100.0
        return self.params.get("LAND_SPEED") / 100.0

    def after_step(self, t_s: float) -> list[Outgoing]:
        """State changes that follow the physics: takeoff complete, land detector, auto-disarm,
        LAND disarming once landed; the battery drains."""
        truth = self.sim.truth
        limits = self.climb_limits()
        was_landed = self.flight.land_complete
        reason = self.flight.update(t_s, truth.up_m, truth.vel_up_mps, self.armed,
                                    limits.max_up_mps, self.sim.limits.accel_up_mps2,
                                    self.params.get("DISARM_DELAY"))
        if self.flight.land_complete != was_landed:
            log.info("%s at %.1f m", "landed" if self.flight.land_complete else "airborne",
                     truth.up_m)
        if self.armed and self.mode == tm.MODE_LAND and self.flight.land_complete:
            self._set_armed(False, "landed")
        elif reason is not None:
            self._set_armed(False, reason)
        current_a = self._current_a()
        self.consumed_mah += current_a * 1000.0 * self.sim.dt_s / 3600.0
        return []

    def _current_a(self) -> float:
        if not self.armed:
            return CURRENT_IDLE_A
        return CURRENT_ARMED_A if self.flight.motors_idle else CURRENT_FLYING_A

    def _battery(self) -> tuple[int, int, int]:
        """(voltage mV, current cA, remaining %): a linear pack."""
        used = min(self.consumed_mah / BATTERY_CAPACITY_MAH, 1.0)
        voltage = BATTERY_FULL_MV - (BATTERY_FULL_MV - BATTERY_EMPTY_MV) * used
        return int(voltage), int(round(self._current_a() * 100)), int(round(100 * (1 - used)))

    @property
    def scheduler(self) -> streams.StreamScheduler:
        """The streams of every link that never asked for its own."""
        return self.streams.shared

    def periodic(self, t_s: float) -> list[Outgoing]:
        """Heartbeat and the telemetry streams due at t_s (the shared scheduler's), then the
        mission protocol's resends."""
        return self.stream_items(self.streams.shared, t_s) + self.mission_ticks(t_s)

    def stream_items(self, scheduler: streams.StreamScheduler, t_s: float) -> list[Outgoing]:
        out: list[Outgoing] = []
        origin = self.sim.scenario.world.origin
        for msg_id in scheduler.due(t_s):
            msg = self._stream_message(msg_id, t_s, origin)
            if msg is not None:
                out.append((tm.COMP_AUTOPILOT, msg))
        return out

    def mission_ticks(self, t_s: float) -> list[Outgoing]:
        return [(tm.COMP_AUTOPILOT, m) for m in self.mission.tick(t_s)]

    def link_streams(self, t_s: float) -> dict[str, list[Outgoing]]:
        """The streams due at t_s on each link that asked for its own rates."""
        return {link: self.stream_items(scheduler, t_s)
                for link, scheduler in self.streams.own.items()}

    def _stream_message(self, msg_id: int, t_s: float, origin):
        sim = self.sim
        has_gps = sim.scenario.noise.has_gps
        if msg_id == streams.MSG_HEARTBEAT:
            return tm.heartbeat_autopilot(self.mode, self.armed, self.flight.land_complete)
        if msg_id == streams.MSG_SYS_STATUS:
            voltage, current, remaining = self._battery()
            active = self.armed and not self.flight.motors_idle \
                and self.mode in POSITION_CONTROL_MODES
            return tm.sys_status(has_gps, active, voltage, current, remaining)
        if msg_id == streams.MSG_BATTERY_STATUS:
            voltage, current, remaining = self._battery()
            return tm.battery_status(voltage, current, int(self.consumed_mah), remaining)
        if msg_id == streams.MSG_EXTENDED_SYS_STATE:
            return tm.extended_sys_state(self.flight.landed_state(self.mode == tm.MODE_LAND),
                                         flight.MAV_VTOL_STATE_MC)
        if msg_id == streams.MSG_GPS_RAW_INT:
            lat, lon = origin.to_lat_lon_deg(*sim.reported_position_ne_m())
            return tm.gps_raw_int(t_s, has_gps, lat, lon, origin.alt_m + sim.truth.up_m,
                                  sim.position_error.total_sigma_m, sim.truth.speed_mps,
                                  math.atan2(sim.truth.vel_east_mps, sim.truth.vel_north_mps),
                                  fix=sim.gps_fix())
        if msg_id == streams.MSG_EKF_STATUS_REPORT:
            return tm.ekf_status_report(sim.gps_fix())
        if msg_id == streams.MSG_GPS_GLOBAL_ORIGIN:
            return tm.gps_global_origin(origin, t_s)
        if msg_id == streams.MSG_SYSTEM_TIME:
            return tm.system_time(t_s, self.start_unix_s)
        if msg_id == streams.MSG_ATTITUDE:
            return tm.attitude(t_s, sim.reported_yaw_rad(), sim.reported_yaw_rate_rad_s(),
                               *sim.tilt_rad)
        if msg_id == streams.MSG_LOCAL_POSITION_NED:
            return tm.local_position_ned(t_s, sim.odometry, *sim.reported_position_ne_m(),
                                         sim.reported_velocity_ne_mps())
        if msg_id == streams.MSG_GLOBAL_POSITION_INT:
            return tm.global_position_int(t_s, sim.odometry, *sim.reported_position_ne_m(),
                                          origin, self.home[2])
        if msg_id == streams.MSG_SIMSTATE:
            return tm.simstate(sim.truth, origin)
        if msg_id == streams.MSG_MISSION_CURRENT:
            return self.mission.mission_current()
        if msg_id == streams.MSG_HOME_POSITION:
            return tm.home_position(origin, *self.home, t_s)
        if msg_id == streams.MSG_POSITION_TARGET_LOCAL_NED:
            if self.mode != tm.MODE_GUIDED or self.target is None:
                return None
            fields = guided.report_fields(self.target, t_s, self._guid_timeout_s())
            return tm.position_target_local_ned(t_s, fields)
        return None

    # ----------------------------------------------------------------- message handling
    def handle(self, msg, t_s: float, link: str | None = None) -> list[Outgoing]:
        """Handle one decoded message from a client (on ``link``, the hub's client name: stream
        requests apply to it); returns the replies."""
        mtype = msg.get_type()
        if not self._for_us(msg):
            return []
        handler = getattr(self, "_on_" + mtype.lower(), None)
        if handler is None:
            return []   # includes PARAM_EXT_* and anything else the stub does not implement
        self._link = link
        try:
            return handler(msg, t_s)
        finally:
            self._link = None

    def _for_us(self, msg) -> bool:
        target_system = getattr(msg, "target_system", 0)
        if target_system not in (0, self.sysid):
            return False
        return True

    def _addressed_to_camera(self, msg) -> bool:
        return getattr(msg, "target_component", 0) == tm.COMP_CAMERA

    def _ack(self, msg, command: int, result: int, comp: int = tm.COMP_AUTOPILOT) -> Outgoing:
        return (comp, tm.command_ack(command, result, msg.get_srcSystem(), msg.get_srcComponent()))

    def _on_timesync(self, msg, t_s: float) -> list[Outgoing]:
        """As ArduPilot's GCS_MAVLINK::handle_timesync: a request (tc1 = 0) is answered with
        tc1 = the time since boot in ns and ts1 mirrored; a reply (tc1 != 0) is ignored."""
        if msg.tc1 != 0:
            return []
        return [(tm.COMP_AUTOPILOT, mavlink.MAVLink_timesync_message(int(round(t_s * 1e9)),
                                                                     int(msg.ts1)))]

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
            self.streams.rates_changed()
        return [(tm.COMP_AUTOPILOT, tm.param_value(record))]

    def _on_request_data_stream(self, msg, t_s: float) -> list[Outgoing]:
        self.streams.for_link(self._link).request_data_stream(
            int(msg.req_stream_id), int(msg.req_message_rate), bool(msg.start_stop))
        return []

    def _mission(self, msg, t_s: float) -> list[Outgoing]:
        """The mission protocol (sitl_stub/mission_store.py), for the autopilot only."""
        if self._addressed_to_camera(msg):
            return []
        return [(tm.COMP_AUTOPILOT, reply) for reply in self.mission.handle(msg, t_s)]

    _on_mission_request_list = _on_mission_count = _on_mission_item_int = _on_mission_item = \
        _on_mission_request_int = _on_mission_request = _on_mission_clear_all = \
        _on_mission_set_current = _mission

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
        if self.flight.takeoff is not None:
            # A new target replaces the TakeOff submode; on the ground the motors stay idle.
            log.info("takeoff replaced by a %s target%s", target.kind,
                     " while landed: motors idle" if self.flight.land_complete else "")
            self.flight.cancel_takeoff()
        self.target = target
        return []

    def _on_setup_signing(self, msg, t_s: float) -> list[Outgoing]:
        """GCS_MAVLINK::handle_setup_signing: store the key and use it at once on every link;
        an all-zero key turns signing off."""
        if self.on_signing_request is not None:
            self.on_signing_request(bytes(msg.secret_key), int(msg.initial_timestamp))
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
            result = self._takeoff(p[6], t_s)
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
                  and self.streams.for_link(self._link).set_message_interval(_as_int(p[0]),
                                                                             p[1]))
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
        interval = (self.streams.of(self._link) if self._link is not None
                    else self.streams.shared).interval_s(msg_id)
        return -1 if interval is None else int(round(interval * 1e6))

    def _requested_message(self, msg_id: int, t_s: float):
        if msg_id == mavlink.MAVLINK_MSG_ID_AUTOPILOT_VERSION:
            return tm.autopilot_version()
        if msg_id in streams.STREAMABLE:
            return self._stream_message(msg_id, t_s, self.sim.scenario.world.origin)
        return None

    def _takeoff(self, alt_m: float, t_s: float) -> int:
        """GCS_MAVLINK_Copter::handle_MAV_CMD_NAV_TAKEOFF -> Mode::do_user_takeoff: param7 is the
        altitude above home (m)."""
        if not math.isfinite(alt_m):
            return DENIED
        target_up_m = self.home[2] + alt_m
        refused = self.flight.start_takeoff(target_up_m, self.sim.truth.up_m, self.armed,
                                            self.mode in USER_TAKEOFF_MODES, t_s)
        if refused is not None:
            log.warning("takeoff refused: %s", refused)
            return FAILED
        log.info("takeoff to %.1f m", alt_m)
        return ACCEPTED

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
            flying = not self.flight.land_complete
            if flying and param2 != FORCE_DISARM_MAGIC:
                return FAILED       # ArduCopter refuses to disarm in flight unless forced
            self._set_armed(False, "forced" if flying else "command")
            return ACCEPTED
        return UNSUPPORTED

    def _set_armed(self, armed: bool, reason: str) -> None:
        if armed != self.armed:
            log.info("%s (%s)", "armed" if armed else "disarmed", reason)
        self.armed = armed
        if armed:
            self.home = (*self.sim.reported_position_ne_m(), self.sim.truth.up_m)
        else:
            if self.sim.truth.up_m > flight.GROUND_ALT_M:
                log.warning("disarmed at %.1f m: the vehicle falls", self.sim.truth.up_m)
                self.sim.truth = dataclasses.replace(self.sim.truth, up_m=0.0, vel_up_mps=0.0,
                                                     vel_north_mps=0.0, vel_east_mps=0.0)
            self.flight.on_disarmed(self.sim.truth.up_m)

    def _set_mode_common(self, base_mode: int, custom_mode: int, t_s: float) -> int:
        """GCS_MAVLINK::_set_mode_common: only custom modes; unknown custom mode -> FAILED."""
        if not base_mode & mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED:
            return DENIED
        if custom_mode not in SUPPORTED_MODES:
            log.warning("mode %d not supported", custom_mode)
            return FAILED
        if custom_mode != self.mode:
            log.info("mode %s -> %s", tm.MODE_NAMES[self.mode], tm.MODE_NAMES[custom_mode])
        if custom_mode != self.mode:
            # A mode change ends a takeoff in progress; the new mode holds the altitude.
            self.flight.cancel_takeoff()
            self.hold_up_m = self.sim.truth.up_m
        if custom_mode == tm.MODE_GUIDED and self.mode != tm.MODE_GUIDED:
            # ModeGuided::init: start with a hold (position and altitude) until told otherwise.
            self.target = guided.hold_target(t_s, "entered GUIDED", self.sim.truth.up_m)
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
