"""The autopilot's dialect: which mode the service steers in, and, on PX4, how OFFBOARD is entered.

Pure: no I/O, time passed in. ``link.autopilot`` 'auto' takes the dialect from the vehicle's
HEARTBEAT.autopilot (12, MAV_AUTOPILOT_PX4: PX4; anything else: ArduPilot, as before).

ArduPilot: the service steers in GUIDED (``link.guided_custom_mode``, ArduCopter 4); the mission's
item 0 is home.

PX4 (facts from PX4-Autopilot, cited where used):
- the mode is HEARTBEAT.custom_mode's main mode (bits 16-23), OFFBOARD = 6
  (src/modules/commander/px4_custom_mode.h); the mission's item 0 is a mission item
  (src/modules/mavlink/mavlink_mission.cpp keeps home apart, in HOME_POSITION).
- SET_POSITION_TARGET_LOCAL_NED outside OFFBOARD only refreshes the offboard signal: the receiver
  publishes offboard_control_mode on every valid setpoint and the trajectory setpoint "only ...
  once in OFFBOARD" (src/modules/mavlink/mavlink_receiver.cpp,
  handle_message_set_position_target_local_ned). Streaming before the switch moves nothing.
- OFFBOARD is refused (COMMAND_ACK TEMPORARILY_REJECTED) until that signal has flowed for more
  than a second (PX4 docs, flight_modes/offboard.md; the signal counts as lost once older than
  COM_OF_LOSS_T: src/modules/commander/HealthAndArmingChecks/checks/offboardCheck.cpp, a mode
  requirement of OFFBOARD in src/modules/commander/ModeUtil/mode_requirements.cpp); once it stops
  for COM_OF_LOSS_T, the failsafe takes COM_OBL_RC_ACT's action.

So on PX4 the service streams a hold (velocity 0, its yaw) while the vehicle is armed and
airborne but not in OFFBOARD (:class:`OffboardEntry` ``stream``), and steers once in OFFBOARD.
``px4.offboard`` 'companion' also asks for OFFBOARD after the take-off, as MAVSDK's
offboard.start() does after its first setpoint, and hands the vehicle to Hold (AUTO.LOITER) on a
clean stop while in the OFFBOARD it engaged. Never a mode change that is not configured: with
'operator' the service never asks for a mode; with 'companion' it asks for OFFBOARD only before
the vehicle's first OFFBOARD of the flight (once the pilot has left OFFBOARD it does not ask
again until the next arming) and for Hold only on its own clean stop.
"""
from __future__ import annotations

from dataclasses import dataclass

from companion.mavlink import px4_modes

AUTOPILOTS = ("auto", "ardupilot", "px4")
OFFBOARD_ENTRIES = ("operator", "companion")


@dataclass(frozen=True)
class Dialect:
    """What differs between the autopilots for the service."""
    name: str                     # 'ardupilot' or 'px4'
    steering_custom_mode: int     # GUIDED's number, or OFFBOARD's custom_mode (main 6)
    steering_name: str            # 'GUIDED' or 'OFFBOARD'
    home_seq: int | None          # the mission item that is home (ArduPilot 0), None: none

    def steering(self, custom_mode: int | None) -> bool:
        """In the mode the service's setpoints are flown in."""
        if custom_mode is None:
            return False
        if self.name == "px4":    # the sub mode is 0 in OFFBOARD; judge the main mode alone
            return px4_modes.main_mode(custom_mode) == px4_modes.MAIN_OFFBOARD
        return custom_mode == self.steering_custom_mode

    def mode_name(self, custom_mode: int | None) -> str:
        if custom_mode is None:
            return "unknown"
        if self.name == "px4":
            return px4_modes.mode_name(custom_mode)
        return self.steering_name if self.steering(custom_mode) else str(custom_mode)


def ardupilot(guided_custom_mode: int) -> Dialect:
    return Dialect("ardupilot", guided_custom_mode, "GUIDED", 0)


PX4 = Dialect("px4", px4_modes.OFFBOARD, "OFFBOARD", None)


def resolve(setting: str, heartbeat_autopilot: int | None, guided_custom_mode: int) -> Dialect:
    """``link.autopilot`` with the vehicle's HEARTBEAT.autopilot (None: not seen yet)."""
    if setting == "px4" or (setting == "auto"
                            and heartbeat_autopilot == px4_modes.MAV_AUTOPILOT_PX4):
        return PX4
    return ardupilot(guided_custom_mode)


@dataclass(frozen=True)
class OffboardParams:
    entry: str = "operator"                  # 'operator' or 'companion'
    request_after_s: float = 1.5             # of stream before asking (PX4 wants > 1 s)
    request_retry_s: float = 1.0
    request_attempts: int = 5


@dataclass(frozen=True)
class OffboardStep:
    """One decision while not steering: stream a hold? ask for OFFBOARD now? and why."""
    stream: bool
    request: bool
    reason: str


class OffboardEntry:
    """PX4's OFFBOARD entry over one flight (reset at each arming); vehicle time ``t_s``."""

    def __init__(self, params: OffboardParams = OffboardParams()) -> None:
        self.params = params
        self.reset()

    def reset(self) -> None:
        self._stream_since_s: float | None = None
        self._last_request_s: float | None = None
        self.requests = 0                    # this flight
        self.in_offboard = False
        self.seen_offboard = False           # this flight
        self.engaged_by_us = False           # we asked, and it is in OFFBOARD now
        self.gave_up = False

    def on_armed(self, armed: bool) -> None:
        if not armed:
            self.reset()                     # a new flight starts at the next arming

    def on_mode(self, in_offboard: bool) -> None:
        """The vehicle's heartbeat: in OFFBOARD or not."""
        if in_offboard and not self.in_offboard:
            self.engaged_by_us = self.requests > 0 and not self.seen_offboard
            self.seen_offboard = True
        elif not in_offboard:
            self.engaged_by_us = False       # the pilot (or a failsafe) took it: not ours to hand
        self.in_offboard = in_offboard

    def step(self, t_s: float, airborne: bool) -> OffboardStep:
        """Not in OFFBOARD: stream a hold while airborne; with 'companion', ask for OFFBOARD
        once the stream has flowed long enough, until it comes or the attempts run out."""
        p = self.params
        if not airborne:
            self._stream_since_s = None
            return OffboardStep(False, False, "not airborne")
        if self._stream_since_s is None or t_s < self._stream_since_s:
            self._stream_since_s = t_s
        if p.entry != "companion":
            return OffboardStep(True, False, "operator switches to OFFBOARD")
        if self.seen_offboard:
            return OffboardStep(True, False, "left OFFBOARD this flight: the operator's")
        if self.gave_up:
            return OffboardStep(True, False, "OFFBOARD not entered after the attempts")
        if t_s - self._stream_since_s < p.request_after_s:
            return OffboardStep(True, False, "stream not long enough yet")
        if self._last_request_s is not None and t_s - self._last_request_s < p.request_retry_s:
            return OffboardStep(True, False, "waiting for OFFBOARD")
        if self.requests >= p.request_attempts:
            self.gave_up = True
            return OffboardStep(True, False, "OFFBOARD not entered after the attempts")
        self.requests += 1
        self._last_request_s = t_s
        return OffboardStep(True, True, f"asking for OFFBOARD ({self.requests}/"
                                        f"{p.request_attempts})")

    def hand_to_hold(self) -> bool:
        """On a clean stop: True if the vehicle is in the OFFBOARD we engaged (give it to Hold)."""
        return self.params.entry == "companion" and self.engaged_by_us and self.in_offboard
