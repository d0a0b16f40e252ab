"""The ``px4:`` section: how OFFBOARD is entered on a PX4 vehicle (companion/onboard/autopilot_dialect.py).

PX4 takes SET_POSITION_TARGET_LOCAL_NED only in OFFBOARD, and enters OFFBOARD only after the
setpoint stream has flowed for more than a second (PX4 docs, flight_modes/offboard.md;
src/modules/commander/HealthAndArmingChecks/checks/offboardCheck.cpp: the signal is lost once
older than COM_OF_LOSS_T). Who switches is the operator's choice, never the service's guess.
"""
from __future__ import annotations

from dataclasses import dataclass

from companion.config.checks import require_positive
from companion.config.loader import require
from companion.onboard.autopilot_dialect import OFFBOARD_ENTRIES, OffboardParams


@dataclass(frozen=True)
class Px4Config:
    """``offboard``: 'operator': the service streams hold setpoints while the vehicle is armed and
    airborne, so the pilot's or ground station's switch to OFFBOARD is accepted, and steers once
    in it; it never changes the mode. 'companion': it also asks for OFFBOARD itself once airborne
    and the stream has flowed ``offboard_request_after_s`` (as MAVSDK's offboard.start()), at most
    ``offboard_request_attempts`` times ``offboard_request_retry_s`` apart, never again in that
    flight once the vehicle has left OFFBOARD (the operator took over); on a clean stop while in
    the OFFBOARD it engaged, it hands the vehicle to Hold (AUTO.LOITER)."""
    offboard: str = "operator"
    offboard_request_after_s: float = 1.5    # > 1 s: PX4's own wait for the stream
    offboard_request_retry_s: float = 1.0
    offboard_request_attempts: int = 5

    def __post_init__(self) -> None:
        require(self.offboard in OFFBOARD_ENTRIES, "offboard", self.offboard,
                " | ".join(OFFBOARD_ENTRIES))
        require(self.offboard_request_after_s > 1.0, "offboard_request_after_s",
                self.offboard_request_after_s, "seconds > 1 (PX4 waits for 1 s of stream)")
        require_positive("offboard_request_retry_s", self.offboard_request_retry_s)
        require(isinstance(self.offboard_request_attempts, int)
                and self.offboard_request_attempts >= 1, "offboard_request_attempts",
                self.offboard_request_attempts, "an integer >= 1")

    def params(self) -> OffboardParams:
        return OffboardParams(self.offboard, self.offboard_request_after_s,
                              self.offboard_request_retry_s, self.offboard_request_attempts)
