"""The stub behind PX4's face (``sitl-stub --autopilot px4``): PX4's modes, arming, take-off, OFFBOARD.

The same airframe, world and camera as the ArduCopter face (sitl_stub/autopilot.py), with PX4's
rules, each from PX4-Autopilot (release 1.15) and pinned by tests/stub/test_stub_px4.py:

- HEARTBEAT: autopilot MAV_AUTOPILOT_PX4 (12), custom_mode = main << 16 | sub << 24
  (src/modules/commander/px4_custom_mode.h); boots in POSCTL; the mode shown is the one flown
  (a failsafe's fallback while armed, else the user's mode: after landing and disarming PX4
  shows the mode the user last chose, OFFBOARD included).
- Arming (MAV_CMD_COMPONENT_ARM_DISARM) is TEMPORARILY_REJECTED until the preflight checks pass,
  ``arm_delay_s`` after boot (the estimator converging; about 35 s in PX4's SIH SITL); not in
  AUTO.LAND, AUTO.RTL, nor in OFFBOARD without the offboard signal. Disarm in the air needs the
  force magic 21196. Armed but never taken off: disarmed after COM_DISARM_PRFLT; landed: after
  COM_DISARM_LAND.
- MAV_CMD_NAV_TAKEOFF: param7 is an AMSL altitude (NaN: MIS_TAKEOFF_ALT above home); the mode
  becomes AUTO.TAKEOFF, which climbs at MPC_TKO_SPEED and then holds (AUTO.LOITER, "Hold").
- MAV_CMD_DO_SET_MODE: param2 main mode, param3 sub mode (Commander::handle_command); SET_MODE
  likewise. OFFBOARD is TEMPORARILY_REJECTED unless the offboard signal has flowed for at least
  OFFBOARD_ENTRY_S (PX4 docs, flight_modes/offboard.md: "only after receiving the signal for
  more than a second").
- SET_POSITION_TARGET_LOCAL_NED (src/modules/mavlink/mavlink_receiver.cpp): frames LOCAL_NED and
  BODY_NED only; any used position, velocity or acceleration refreshes the offboard signal, but
  the setpoint is flown only in OFFBOARD ("only publish setpoint once in OFFBOARD").
- Offboard loss: OFFBOARD without a setpoint for COM_OF_LOSS_T flies COM_OBL_RC_ACT's fallback
  (failsafe.cpp checkModeFallback: the manual fallbacks need sticks, which the stub never has, so
  0-2 end in Return; 3 Return, 4 Land, 5 Hold, 6-7 disarm) while OFFBOARD stays the user's mode:
  once the signal is back, OFFBOARD is flown again.
- AUTO.LAND descends at MPC_LAND_SPEED and disarms COM_DISARM_LAND after touching down;
  AUTO.RTL flies home at the altitude it has and lands there.
- Streams: PX4's onboard-link defaults unasked (sitl_stub/px4_tables.py); ESTIMATOR_STATUS, no
  EKF_STATUS_REPORT; LOCAL_POSITION_NED's origin ``LOCAL_Z_OFFSET_M`` above the ground.
- Parameters served bytewise (INT32 bits in the float), the mission without a home item.
POSCTL and the other stick modes fly as a hold with centred sticks.
"""
from __future__ import annotations

import logging
import math

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from . import flight, guided, streams, telemetry as tm
from . import px4_tables as px4
from .autopilot import (ACCEPTED, DENIED, FAILED, FORCE_DISARM_MAGIC, Autopilot, Outgoing,
                        _param_name)
from .sim import ClimbLimits, Simulation
from .vehicle import GROUNDED, Demand, position_demand

log = logging.getLogger(__name__)

TEMPORARILY_REJECTED = mavlink.MAV_RESULT_TEMPORARILY_REJECTED
ARM_DELAY_S = 35.0             # seen on PX4 1.15 SIH: arming refused for ~35 s after boot
OFFBOARD_ENTRY_S = 1.0         # the stream must have flowed this long before OFFBOARD
LOCAL_Z_OFFSET_M = 1.5         # LOCAL_POSITION_NED z on the ground (its origin above it)
RTL_ARRIVED_M = 1.0
SETPOINT_FRAMES = (mavlink.MAV_FRAME_LOCAL_NED, mavlink.MAV_FRAME_BODY_NED)
NOT_ARMABLE = (px4.LAND, px4.RTL)


class Px4Autopilot(Autopilot):
    """Component 1 with PX4's face (see the module docstring)."""

    def __init__(self, sim: Simulation, params: px4.Px4Params, start_unix_s: float = 0.0,
                 arm_delay_s: float = ARM_DELAY_S) -> None:
        super().__init__(sim, params, start_unix_s)
        self.streams = streams.LinkSchedulers(params, px4.Px4Streams)
        self.mission = px4.Px4MissionStore(self._home_lat_lon_alt)
        self.mode = px4.POSCTL               # the user's intended mode
        self.fallback: int | None = None     # flown instead of OFFBOARD while its signal is lost
        self.arm_delay_s = arm_delay_s
        self.signal_since_s: float | None = None   # the offboard signal's unbroken stream
        self.signal_last_s: float | None = None
        self.offboard_rejections = 0
        self.setpoints_while_landed = 0      # SET_POSITION_TARGET_LOCAL_NED on the ground
        self._flown = False

    # ----------------------------------------------------------------- state
    @property
    def nav_mode(self) -> int:
        """The mode flown and shown in the heartbeat."""
        return self.fallback if self.armed and self.fallback is not None else self.mode

    @property
    def mode_name(self) -> str:
        return px4.MODE_NAMES.get(self.nav_mode, str(self.nav_mode))

    def truth_extras(self) -> dict:
        return {"user_mode": px4.MODE_NAMES.get(self.mode, str(self.mode)),
                "setpoints_while_landed": self.setpoints_while_landed}

    def signal_ok(self, t_s: float) -> bool:
        return self.signal_last_s is not None and \
            t_s - self.signal_last_s <= self.params.get("COM_OF_LOSS_T") + 1e-9

    def offboard_available(self, t_s: float) -> bool:
        return self.signal_ok(t_s) and t_s - self.signal_since_s >= OFFBOARD_ENTRY_S - 1e-9

    # ----------------------------------------------------------------- physics interface
    def demand(self, t_s: float) -> Demand:
        if not self.armed or self.flight.motors_idle:
            return GROUNDED
        mode, odom = self.nav_mode, self.sim.odometry
        if mode == px4.LAND:
            return Demand(climb_mps=-self.params.get("MPC_LAND_SPEED"))
        if mode == px4.TAKEOFF and self.flight.takeoff is not None:
            if not self.flight.takeoff.climbing(t_s):
                return GROUNDED
            return Demand(target_up_m=self.flight.takeoff.target_up_m)
        if mode == px4.RTL:
            north, east = self.home[0], self.home[1]
            if math.hypot(odom.north_m - north, odom.east_m - east) <= RTL_ARRIVED_M:
                return Demand(climb_mps=-self.params.get("MPC_LAND_SPEED"))
            return position_demand(odom.north_m, odom.east_m, north, east,
                                   self.params.get("MPC_XY_CRUISE"),
                                   self.sim.limits.max_accel_mps2, self.hold_up_m, None)
        if mode == px4.OFFBOARD:
            return guided.demand_for(self.target, odom, t_s, math.inf,
                                     self.params.get("MPC_XY_CRUISE"),
                                     self.sim.limits.max_accel_mps2)
        return Demand(target_up_m=self.hold_up_m)      # Hold, and stick modes, sticks centred

    def climb_limits(self) -> ClimbLimits:
        landing = self.nav_mode in (px4.LAND, px4.RTL)
        up = self.params.get("MPC_TKO_SPEED") if self.nav_mode == px4.TAKEOFF \
            else self.params.get("MPC_Z_VEL_MAX_UP")
        down = self.params.get("MPC_LAND_SPEED") if landing \
            else self.params.get("MPC_Z_VEL_MAX_DN")
        return ClimbLimits(max_up_mps=up, max_down_mps=down)

    def after_step(self, t_s: float) -> list[Outgoing]:
        truth = self.sim.truth
        delay = self.params.get("COM_DISARM_LAND" if self._flown else "COM_DISARM_PRFLT")
        reason = self.flight.update(t_s, truth.up_m, truth.vel_up_mps, self.armed,
                                    self.climb_limits().max_up_mps,
                                    self.sim.limits.accel_up_mps2, delay)
        if self.armed and not self.flight.land_complete:
            self._flown = True
        takeoff = self.flight.takeoff
        if self.armed and self.mode == px4.TAKEOFF and takeoff is not None and takeoff.complete:
            log.info("takeoff complete at %.1f m: Hold", truth.up_m)
            self.mode, self.hold_up_m = px4.HOLD, takeoff.target_up_m
            self.flight.cancel_takeoff()
        if self.armed and self.mode == px4.OFFBOARD:
            self._watch_offboard_signal(t_s)
        if reason is not None:
            self._set_armed(False, reason)
        return []

    def _watch_offboard_signal(self, t_s: float) -> None:
        if self.signal_ok(t_s):
            if self.fallback is not None:
                log.info("offboard signal back: OFFBOARD")
                self.fallback = None
                self.target = guided.hold_target(t_s, "offboard back", self.sim.truth.up_m)
            return
        if self.fallback is not None:
            return
        action = int(self.params.get("COM_OBL_RC_ACT"))
        fallback = px4.OBL_ACTIONS.get(action, px4.RTL)
        log.warning("offboard signal lost for COM_OF_LOSS_T: COM_OBL_RC_ACT %d -> %s", action,
                    px4.MODE_NAMES.get(fallback, "disarm"))
        if fallback is None:
            self._set_armed(False, "offboard loss")
            return
        self.fallback, self.hold_up_m = fallback, self.sim.truth.up_m

    def _set_armed(self, armed: bool, reason: str) -> None:
        super()._set_armed(armed, reason)
        if not armed:
            self.fallback, self._flown = None, False

    # ----------------------------------------------------------------- telemetry
    def _stream_message(self, msg_id: int, t_s: float, origin):
        sim = self.sim
        if msg_id == streams.MSG_HEARTBEAT:
            return self._heartbeat()
        if msg_id == streams.MSG_EXTENDED_SYS_STATE:
            landing = self.nav_mode == px4.LAND or (self.nav_mode == px4.RTL
                                                    and sim.truth.vel_up_mps < -0.1)
            return tm.extended_sys_state(self.flight.landed_state(landing),
                                         flight.MAV_VTOL_STATE_MC)
        if msg_id == px4.MSG_ESTIMATOR_STATUS:
            absolute = sim.scenario.noise.has_gps and sim.gps_fix()
            flags = tm.EKF_FLAGS_ABSOLUTE if absolute else tm.EKF_FLAGS_RELATIVE
            return mavlink.MAVLink_estimator_status_message(int(t_s * 1e6), flags, 0.1, 0.1,
                                                            0.1, 0.1, 0.0, 0.0, 0.5, 0.5)
        if msg_id == streams.MSG_LOCAL_POSITION_NED:
            msg = tm.local_position_ned(t_s, sim.odometry, *sim.reported_position_ne_m(),
                                        sim.reported_velocity_ne_mps())
            msg.z += LOCAL_Z_OFFSET_M
            return msg
        if msg_id == streams.MSG_POSITION_TARGET_LOCAL_NED:
            if self.nav_mode != px4.OFFBOARD or self.target is None:
                return None
            return tm.position_target_local_ned(t_s, guided.report_fields(self.target, t_s,
                                                                          math.inf))
        if msg_id == streams.MSG_EKF_STATUS_REPORT:
            return None                              # ArduPilot's; PX4 sends ESTIMATOR_STATUS
        return super()._stream_message(msg_id, t_s, origin)

    def _heartbeat(self):
        mode = self.nav_mode
        base = mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
        if self.armed:
            base |= mavlink.MAV_MODE_FLAG_SAFETY_ARMED
        if mode == px4.OFFBOARD or (mode >> 16) & 0xFF == px4.MAIN_AUTO:
            base |= mavlink.MAV_MODE_FLAG_GUIDED_ENABLED | mavlink.MAV_MODE_FLAG_STABILIZE_ENABLED
        status = mavlink.MAV_STATE_ACTIVE if self.armed else mavlink.MAV_STATE_STANDBY
        return mavlink.MAVLink_heartbeat_message(mavlink.MAV_TYPE_QUADROTOR,
                                                 mavlink.MAV_AUTOPILOT_PX4, base, mode, status, 3)

    # ----------------------------------------------------------------- messages
    def _on_set_position_target_local_ned(self, msg, t_s: float) -> list[Outgoing]:
        if self.flight.land_complete and not self._addressed_to_camera(msg):
            self.setpoints_while_landed += 1
        if self._addressed_to_camera(msg) or int(msg.coordinate_frame) not in SETPOINT_FRAMES:
            self.ignored_targets += 1
            return []
        mask = int(msg.type_mask)
        if mask & guided.MASK_POS_IGNORE == guided.MASK_POS_IGNORE and \
                mask & guided.MASK_VEL_IGNORE == guided.MASK_VEL_IGNORE and \
                mask & guided.MASK_ACC_IGNORE == guided.MASK_ACC_IGNORE:
            self.ignored_targets += 1              # "SET_POSITION_TARGET_LOCAL_NED invalid"
            return []
        if not self.signal_ok(t_s):
            self.signal_since_s = t_s
        self.signal_last_s = t_s
        if self.armed and self.nav_mode == px4.OFFBOARD:
            self.target = guided.parse_target(msg, self.sim.odometry, t_s)
        else:
            self.ignored_targets += 1              # the signal only, not flown
        return []

    def _on_set_mode(self, msg, t_s: float) -> list[Outgoing]:
        result = self._set_px4_mode(int(msg.custom_mode), t_s) \
            if msg.base_mode & mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED else DENIED
        return [self._ack(msg, mavlink.MAV_CMD_DO_SET_MODE, result)]

    def _on_param_request_list(self, msg, t_s: float) -> list[Outgoing]:
        if self._addressed_to_camera(msg):
            return []
        return [(tm.COMP_AUTOPILOT, px4.param_value_bytewise(p)) for p in self.params.all()]

    def _on_param_request_read(self, msg, t_s: float) -> list[Outgoing]:
        if self._addressed_to_camera(msg):
            return []
        record = self.params.by_index(int(msg.param_index)) if msg.param_index >= 0 \
            else self.params.by_name(_param_name(msg.param_id))
        return [] if record is None else [(tm.COMP_AUTOPILOT, px4.param_value_bytewise(record))]

    def _on_param_set(self, msg, t_s: float) -> list[Outgoing]:
        if self._addressed_to_camera(msg):
            return []
        name = _param_name(msg.param_id)
        known = self.params.by_name(name)
        if known is None:
            return []
        record = self.params.set(name, px4.decode_bytewise(float(msg.param_value),
                                                           known.param_type))
        log.info("parameter %s set to %g", name, record.value)
        return [(tm.COMP_AUTOPILOT, px4.param_value_bytewise(record))]

    def _command(self, msg, command: int, p: list[float], t_s: float) -> list[Outgoing]:
        if self._addressed_to_camera(msg):
            return super()._command(msg, command, p, t_s)
        if command == mavlink.MAV_CMD_COMPONENT_ARM_DISARM:
            result = self._arm_disarm_px4(p[0], p[1], t_s)
        elif command == mavlink.MAV_CMD_DO_SET_MODE:
            main, sub = int(p[1]) if math.isfinite(p[1]) else -1, \
                int(p[2]) if math.isfinite(p[2]) else 0
            result = self._set_px4_mode(px4.custom_mode(main & 0xFF, sub & 0xFF), t_s) \
                if int(p[0]) & mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED else DENIED
        elif command == mavlink.MAV_CMD_NAV_TAKEOFF:
            result = self._takeoff_amsl(p[6], t_s)
        elif command == mavlink.MAV_CMD_NAV_LAND:
            result = self._set_px4_mode(px4.LAND, t_s)
        elif command == mavlink.MAV_CMD_NAV_RETURN_TO_LAUNCH:
            result = self._set_px4_mode(px4.RTL, t_s)
        elif command == mavlink.MAV_CMD_NAV_LOITER_UNLIM:
            result = self._set_px4_mode(px4.HOLD, t_s)
        else:
            return super()._command(msg, command, p, t_s)
        return [self._ack(msg, command, result)]

    # ----------------------------------------------------------------- commands
    def _arm_disarm_px4(self, param1: float, param2: float, t_s: float) -> int:
        if param1 == 0.0:
            flying = not self.flight.land_complete
            if flying and param2 != FORCE_DISARM_MAGIC:
                return DENIED
            self._set_armed(False, "forced" if flying else "command")
            return ACCEPTED
        if param1 != 1.0:
            return DENIED
        if self.armed:
            return ACCEPTED
        if t_s < self.arm_delay_s - 1e-9:
            log.warning("arming refused: preflight checks not passed yet (%.0f s more)",
                        self.arm_delay_s - t_s)
            return TEMPORARILY_REJECTED
        if self.mode in NOT_ARMABLE or (self.mode == px4.OFFBOARD
                                        and not self.offboard_available(t_s)):
            log.warning("arming refused in %s", self.mode_name)
            return TEMPORARILY_REJECTED
        self._set_armed(True, "command")
        self.hold_up_m = self.sim.truth.up_m
        return ACCEPTED

    def _takeoff_amsl(self, alt_amsl_m: float, t_s: float) -> int:
        origin_alt = self.sim.scenario.world.origin.alt_m
        home_amsl = origin_alt + self.home[2]
        target_amsl = alt_amsl_m if math.isfinite(alt_amsl_m) \
            else home_amsl + self.params.get("MIS_TAKEOFF_ALT")
        refused = self.flight.start_takeoff(target_amsl - origin_alt, self.sim.truth.up_m,
                                            self.armed, True, t_s)
        if refused is not None:
            log.warning("takeoff refused: %s (target %.1f m AMSL, home %.1f m)", refused,
                        target_amsl, home_amsl)
            return TEMPORARILY_REJECTED if refused == "not armed" else FAILED
        log.info("takeoff to %.1f m AMSL (%.1f m above home)", target_amsl,
                 target_amsl - home_amsl)
        self.mode, self.fallback = px4.TAKEOFF, None
        return ACCEPTED

    def _set_px4_mode(self, mode: int, t_s: float) -> int:
        if mode not in px4.MODE_NAMES:
            log.warning("mode %d not supported", mode)
            return FAILED
        if mode == px4.OFFBOARD and not self.offboard_available(t_s):
            self.offboard_rejections += 1
            log.warning("OFFBOARD refused: no offboard signal for %.1f s", OFFBOARD_ENTRY_S)
            return TEMPORARILY_REJECTED
        if mode == px4.TAKEOFF and self.flight.land_complete:
            return self._takeoff_amsl(math.nan, t_s)
        if mode != self.nav_mode:
            log.info("mode %s -> %s", self.mode_name, px4.MODE_NAMES[mode])
            self.flight.cancel_takeoff()
            self.hold_up_m = self.sim.truth.up_m
        if mode == px4.OFFBOARD and self.nav_mode != px4.OFFBOARD:
            # until the next setpoint (PX4 publishes it only once in OFFBOARD): hold
            self.target = guided.hold_target(t_s, "entered OFFBOARD", self.sim.truth.up_m)
        elif mode != px4.OFFBOARD:
            self.target = None
        self.mode, self.fallback = mode, None
        return ACCEPTED
