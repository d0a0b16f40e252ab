"""Landed state, user takeoff, land detector and auto-disarm, as ArduCopter 4.6 does them. No I/O.

Sources (ArduPilot, ArduCopter/):
- takeoff.cpp ``Mode::do_user_takeoff``: refused unless armed, landed (``land_complete``), in a
  mode with a user takeoff (GUIDED, LOITER, ALT_HOLD, POSHOLD, ...) and the target above the
  current altitude. ``_AutoTakeoff::run``: the vehicle stays "landed" until it climbs faster
  than 10 % of the maximum climb rate, then climbs to the target; the takeoff is complete when
  it is within the stopping distance of the target and climbing slower than 10 % of the maximum.
- mode_guided.cpp ``is_taking_off`` (TakeOff submode, not complete); any new target replaces the
  submode. ``velaccel_control_run`` et al.: ``is_disarmed_or_landed()`` -> motors idle
  (``make_safe_ground_handling``), so a velocity target while landed never lifts off.
- GCS_MAVLink_Copter.cpp ``landed_state``: ON_GROUND if land_complete, LANDING in a landing
  mode, TAKEOFF while taking off, else IN_AIR. ``vtol_state``: MC (3), as the binary sends it.
- land_detector.cpp: landed after LAND_DETECTOR_TRIGGER_SEC (1 s) at rest on the ground.
- motors.cpp ``auto_disarm_check``: disarm after DISARM_DELAY s landed with idle motors
  (0 disables). mode_land.cpp: LAND disarms as soon as it has landed.
"""
from __future__ import annotations

from dataclasses import dataclass

LAND_DETECTOR_TRIGGER_S = 1.0
GROUND_ALT_M = 0.02                  # below this the vehicle stands on the ground
TAKEOFF_VEL_FRACTION = 0.1           # _AutoTakeoff::run: 10 % of the maximum climb rate

MAV_LANDED_STATE_ON_GROUND = 1
MAV_LANDED_STATE_IN_AIR = 2
MAV_LANDED_STATE_TAKEOFF = 3
MAV_LANDED_STATE_LANDING = 4
MAV_VTOL_STATE_MC = 3                # what the ArduCopter 4.6 SITL binary sends
# Motors spool up (MOT_SPOOL_TIME 0.5 s) and the throttle ramps (TKOFF_SLEW_TIME 2 s) before the
# climb: the 4.6 binary said ON_GROUND for 2.8 s after accepting NAV_TAKEOFF, then TAKEOFF.
TAKEOFF_SPOOL_UP_S = 2.5


@dataclass(frozen=True)
class Takeoff:
    target_up_m: float
    start_t_s: float = 0.0
    complete: bool = False

    def climbing(self, t_s: float) -> bool:
        """Spooled up: the climb has begun."""
        return t_s - self.start_t_s >= TAKEOFF_SPOOL_UP_S - 1e-9


class FlightState:
    """land_complete, the user takeoff in progress and the auto-disarm timer."""

    def __init__(self) -> None:
        self.land_complete = True
        self.takeoff: Takeoff | None = None
        self._at_rest_since_s: float | None = None
        self._disarm_timer_s: float | None = None

    @property
    def taking_off(self) -> bool:
        return self.takeoff is not None and not self.takeoff.complete

    @property
    def motors_idle(self) -> bool:
        """Landed and not taking off: ArduCopter's ground handling, nothing moves."""
        return self.land_complete and not self.taking_off

    def start_takeoff(self, target_up_m: float, up_m: float, armed: bool,
                      mode_allows: bool, t_s: float = 0.0) -> str | None:
        """Mode::do_user_takeoff. Returns None if started, else why it was refused."""
        if not armed:
            return "not armed"
        if not self.land_complete:
            return "already flying"
        if not mode_allows:
            return "mode has no user takeoff"
        if not target_up_m > up_m:
            return "cannot take off downwards"
        # A repeated takeoff while spooling up keeps the motors' spool-up (they are running).
        start = self.takeoff.start_t_s if self.taking_off else t_s
        self.takeoff = Takeoff(target_up_m, start)
        self._disarm_timer_s = None
        return None

    def cancel_takeoff(self) -> None:
        """A new guided target or a mode change replaces the takeoff."""
        self.takeoff = None

    def landed_state(self, landing_mode: bool) -> int:
        if self.land_complete:
            return MAV_LANDED_STATE_ON_GROUND
        if landing_mode:
            return MAV_LANDED_STATE_LANDING
        if self.taking_off:
            return MAV_LANDED_STATE_TAKEOFF
        return MAV_LANDED_STATE_IN_AIR

    def update(self, t_s: float, up_m: float, vel_up_mps: float, armed: bool,
               max_up_mps: float, accel_up_mps2: float, disarm_delay_s: float) -> str | None:
        """After a physics step. Returns a reason to disarm ("landed"-type events), or None."""
        if not armed:
            self.land_complete = up_m <= GROUND_ALT_M or self.land_complete
            self.takeoff = None
            self._disarm_timer_s = self._at_rest_since_s = None
            return None
        takeoff = self.takeoff
        if takeoff is not None and not takeoff.complete:
            if self.land_complete and vel_up_mps >= TAKEOFF_VEL_FRACTION * max_up_mps:
                self.land_complete = False
            stop_m = 0.5 * (TAKEOFF_VEL_FRACTION * max_up_mps) ** 2 / accel_up_mps2
            if up_m >= takeoff.target_up_m - stop_m and vel_up_mps < TAKEOFF_VEL_FRACTION * max_up_mps:
                self.takeoff = Takeoff(takeoff.target_up_m, takeoff.start_t_s, complete=True)
        if not self.land_complete and not self.taking_off:
            at_rest = up_m <= GROUND_ALT_M and abs(vel_up_mps) < 0.05
            if not at_rest:
                self._at_rest_since_s = None
            elif self._at_rest_since_s is None:
                self._at_rest_since_s = t_s
            elif t_s - self._at_rest_since_s >= LAND_DETECTOR_TRIGGER_S - 1e-9:
                self.land_complete = True
                self.takeoff = None
                self._at_rest_since_s = None
        if not self.motors_idle or disarm_delay_s <= 0.0:
            self._disarm_timer_s = None
            return None
        if self._disarm_timer_s is None:
            self._disarm_timer_s = t_s
        if t_s - self._disarm_timer_s >= disarm_delay_s - 1e-9:
            self._disarm_timer_s = None
            return "DISARM_DELAY"
        return None

    def on_disarmed(self, up_m: float) -> None:
        self.takeoff = None
        self._disarm_timer_s = self._at_rest_since_s = None
        if up_m <= GROUND_ALT_M:
            self.land_complete = True
