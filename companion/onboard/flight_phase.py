"""Flight phases: may the companion command the vehicle at all? Pure: no I/O, time passed in.

ArduCopter answers a GUIDED velocity setpoint sent while the vehicle is still on the ground by
replacing its takeoff, idling the motors and disarming DISARM_DELAY (10 s) later (issue 13). So
no setpoint, a hold included, leaves while the vehicle is landed, taking off (until the target
altitude is reached, or the climb has stopped) or landing.

Sources of the phase, best first:
1. EXTENDED_SYS_STATE.landed_state (the companion asks for it with SET_MESSAGE_INTERVAL):
   ArduCopter's own view (GCS_MAVLINK_Copter::landed_state: ON_GROUND, TAKEOFF until the
   takeoff completes, IN_AIR, LANDING). Used while fresh (``landed_state_timeout_s`` of vehicle
   time).
2. Else the altitude above the takeoff point: GLOBAL_POSITION_INT.relative_alt (above home), or
   LOCAL_POSITION_NED -z relative to where the vehicle stood while disarmed (the EKF origin if
   it was never seen disarmed). A small state
   machine: landed -> taking off (climbing, or above ``airborne_alt_m``) -> airborne (at
   ``takeoff_alt_m`` if configured, else above ``airborne_alt_m`` with the climb stopped for
   ``climb_stopped_s``) -> landing (back below ``airborne_alt_m``) -> landed (at rest there).

A disarmed vehicle is always landed.

Vertical hold: the setpoints hold the altitude at which commanding began (or ``hold_alt_m``
above the takeoff point) with vz = clamp(gain x altitude error, +-max_vertical_speed_mps),
not a bare vz = 0 that lets the altitude wander with the autopilot's own drift.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

LANDED = "landed"
TAKING_OFF = "taking off"
AIRBORNE = "airborne"
LANDING = "landing"

# MAV_LANDED_STATE -> phase (0, UNDEFINED, means: use the altitude)
_FROM_LANDED_STATE = {1: LANDED, 2: AIRBORNE, 3: TAKING_OFF, 4: LANDING}


@dataclass(frozen=True)
class FlightPhaseParams:
    landed_state_timeout_s: float = 3.0
    airborne_alt_m: float = 2.0
    takeoff_alt_m: float | None = None
    takeoff_alt_tolerance_m: float = 0.5
    climb_stopped_mps: float = 0.3
    climb_stopped_s: float = 1.0
    altitude_timeout_s: float = 1.0
    hold_alt_m: float | None = None
    vertical_gain_per_s: float = 0.5
    max_vertical_speed_mps: float = 1.0


@dataclass(frozen=True)
class PhaseDecision:
    """Whether a setpoint may go out, with the phase, where it came from, and why."""
    phase: str
    may_command: bool
    source: str                    # 'landed_state', 'altitude', 'disarmed' or 'unknown'
    reason: str


class FlightPhase:
    """Tracks the phase from the vehicle's messages; ``decide(t_s)`` answers "may we command?"."""

    def __init__(self, params: FlightPhaseParams = FlightPhaseParams()) -> None:
        self.params = params
        self.armed = False
        self._landed_state: int | None = None
        self._landed_state_t_s: float | None = None
        self._alt_phase = LANDED
        self._up_m: float | None = None            # above the takeoff point
        self._climb_mps = 0.0
        self._alt_t_s: float | None = None
        self._relative_alt_t_s: float | None = None
        self._ground_local_up_m: float | None = None
        self._steady_since_s: float | None = None

    # ------------------------------------------------------------ inputs
    def on_armed(self, armed: bool) -> None:
        self.armed = armed
        if not armed:
            self._alt_phase = LANDED

    def on_landed_state(self, t_s: float, landed_state: int) -> None:
        """EXTENDED_SYS_STATE, stamped with the vehicle's latest time (it has none)."""
        if landed_state in _FROM_LANDED_STATE:
            self._landed_state, self._landed_state_t_s = landed_state, t_s

    def on_relative_alt(self, t_s: float, relative_alt_m: float, vel_down_mps: float) -> None:
        """GLOBAL_POSITION_INT: altitude above home (the takeoff point)."""
        if not (math.isfinite(relative_alt_m) and math.isfinite(vel_down_mps)):
            return
        self._relative_alt_t_s = t_s
        self._on_altitude(t_s, relative_alt_m, -vel_down_mps)

    def on_local_position(self, t_s: float, down_m: float, vel_down_mps: float) -> None:
        """LOCAL_POSITION_NED z, vz: used when relative_alt is not coming."""
        if not (math.isfinite(down_m) and math.isfinite(vel_down_mps)):
            return
        local_up = -down_m
        if not self.armed:
            self._ground_local_up_m = local_up      # where it stands: the takeoff point
        fresh_relative = (self._relative_alt_t_s is not None
                          and t_s - self._relative_alt_t_s <= self.params.altitude_timeout_s)
        if not fresh_relative:
            # Never seen on the ground: the EKF origin (ArduCopter sets it where the EKF
            # first had a position, normally on the ground at boot).
            ground = self._ground_local_up_m if self._ground_local_up_m is not None else 0.0
            self._on_altitude(t_s, local_up - ground, -vel_down_mps)

    # ------------------------------------------------------------ the altitude state machine
    def _on_altitude(self, t_s: float, up_m: float, climb_mps: float) -> None:
        p = self.params
        self._up_m, self._climb_mps, self._alt_t_s = up_m, climb_mps, t_s
        steady = abs(climb_mps) < p.climb_stopped_mps
        if not steady:
            self._steady_since_s = None
        elif self._steady_since_s is None:
            self._steady_since_s = t_s
        steady_long = steady and t_s - self._steady_since_s >= p.climb_stopped_s - 1e-9
        high = up_m >= p.airborne_alt_m
        phase = self._alt_phase
        if not self.armed:
            phase = LANDED
        elif phase == LANDED:
            if high or climb_mps >= p.climb_stopped_mps:
                phase = TAKING_OFF
        elif phase == TAKING_OFF:
            reached = (p.takeoff_alt_m is not None
                       and up_m >= p.takeoff_alt_m - p.takeoff_alt_tolerance_m)
            if reached or (high and steady_long and p.takeoff_alt_m is None):
                phase = AIRBORNE
            elif not high and steady_long:
                phase = LANDED
        elif phase == AIRBORNE:
            if not high:
                phase = LANDING
        elif phase == LANDING:
            if high:
                phase = AIRBORNE
            elif steady_long:
                phase = LANDED
        self._alt_phase = phase

    # ------------------------------------------------------------ outputs
    def decide(self, t_s: float) -> PhaseDecision:
        if not self.armed:
            return PhaseDecision(LANDED, False, "disarmed", "vehicle disarmed")
        if self._landed_state_t_s is not None and \
                t_s - self._landed_state_t_s <= self.params.landed_state_timeout_s:
            phase = _FROM_LANDED_STATE[self._landed_state]
            return PhaseDecision(phase, phase == AIRBORNE, "landed_state",
                                 f"EXTENDED_SYS_STATE says {phase}")
        if self._alt_t_s is not None and t_s - self._alt_t_s <= self.params.altitude_timeout_s:
            phase = self._alt_phase
            return PhaseDecision(phase, phase == AIRBORNE, "altitude",
                                 f"{phase} at {self._up_m:.1f} m, climbing {self._climb_mps:.1f} m/s")
        return PhaseDecision(LANDED, False, "unknown", "no landed state or altitude from the vehicle")

    @property
    def up_m(self) -> float | None:
        """The latest altitude above the takeoff point (None before any)."""
        return self._up_m

    def up_at(self, t_s: float) -> float | None:
        """The latest altitude carried to ``t_s`` by its climb rate (GLOBAL_POSITION_INT comes
        at 2 Hz: 1.25 m stale in a 2.5 m/s climb); None before any, or when it is older than
        ``altitude_timeout_s``."""
        if self._up_m is None or self._alt_t_s is None \
                or abs(t_s - self._alt_t_s) > self.params.altitude_timeout_s:
            return None
        return self._up_m + self._climb_mps * (t_s - self._alt_t_s)


class VerticalHold:
    """The vertical term of the setpoints: hold the altitude at which commanding began."""

    def __init__(self, params: FlightPhaseParams = FlightPhaseParams()) -> None:
        self.params = params
        self.target_up_m: float | None = None

    def reset(self) -> None:
        """Commanding stopped: the next session holds the altitude it begins at."""
        self.target_up_m = None

    def vel_down_mps(self, up_m: float | None) -> float:
        """vz (down positive) toward the held altitude; 0 while the altitude is unknown."""
        if up_m is None or not math.isfinite(up_m):
            return 0.0
        if self.target_up_m is None:
            self.target_up_m = self.params.hold_alt_m if self.params.hold_alt_m is not None \
                else up_m
        p = self.params
        climb = p.vertical_gain_per_s * (self.target_up_m - up_m)
        climb = min(max(climb, -p.max_vertical_speed_mps), p.max_vertical_speed_mps)
        return -climb
