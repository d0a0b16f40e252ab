"""The ground station's view of an ArduPilot SITL: the messages `companion demo --autopilot` reads.

The service never uses these (its messages are in events.py and outbound.py); the demo's ground station needs the
simulator's truth (SIMSTATE), the EKF's readiness (EKF_STATUS_REPORT, GPS_GLOBAL_ORIGIN) and the
flight state (GLOBAL_POSITION_INT, LOCAL_POSITION_NED altitude, EXTENDED_SYS_STATE), so that the
flight can be scored and checked independently of what the companion believed. Same rules as
the rest of mavlink/: field names and scalings stay here, events are frozen and in SI units.
"""
from __future__ import annotations

from dataclasses import dataclass

from companion.mavlink.dialect import mavlink

LANDED_STATE_NAMES = {mavlink.MAV_LANDED_STATE_UNDEFINED: "undefined",
                      mavlink.MAV_LANDED_STATE_ON_GROUND: "on_ground",
                      mavlink.MAV_LANDED_STATE_IN_AIR: "in_air",
                      mavlink.MAV_LANDED_STATE_TAKEOFF: "takeoff",
                      mavlink.MAV_LANDED_STATE_LANDING: "landing"}
# A horizontal and vertical absolute position, no constant-position fallback: GUIDED can fly.
_EKF_NEEDED = (mavlink.EKF_ATTITUDE | mavlink.EKF_VELOCITY_HORIZ | mavlink.EKF_POS_HORIZ_ABS
               | mavlink.EKF_POS_VERT_ABS)
_EKF_BAD = mavlink.EKF_CONST_POS_MODE | mavlink.EKF_UNINITIALIZED


@dataclass(frozen=True)
class SimState:
    """The simulator's true attitude and position (no time field: pair it with ATTITUDE's)."""
    lat_deg: float
    lon_deg: float
    yaw_rad: float


@dataclass(frozen=True)
class GlobalPosition:
    t_s: float
    relative_alt_m: float          # above home
    vel_north_mps: float
    vel_east_mps: float


@dataclass(frozen=True)
class LocalAltitude:
    """LOCAL_POSITION_NED as the ground station reads it: the full position, altitude up."""
    t_s: float
    north_m: float
    east_m: float
    up_m: float


@dataclass(frozen=True)
class LandedState:
    state: int

    @property
    def name(self) -> str:
        return LANDED_STATE_NAMES.get(self.state, str(self.state))


@dataclass(frozen=True)
class EkfStatus:
    flags: int

    @property
    def can_fly_guided(self) -> bool:
        return (self.flags & _EKF_NEEDED) == _EKF_NEEDED and not self.flags & _EKF_BAD


@dataclass(frozen=True)
class GlobalOrigin:
    """Where LOCAL_NED's origin is (the EKF origin)."""
    lat_deg: float
    lon_deg: float


GcsEvent = SimState | GlobalPosition | LocalAltitude | LandedState | EkfStatus | GlobalOrigin


def decode_gcs(msg) -> GcsEvent | None:
    """The ground-station event of a message from the autopilot, or None."""
    kind = msg.get_type()
    if kind == "SIMSTATE":
        return SimState(msg.lat / 1e7, msg.lng / 1e7, msg.yaw)
    if kind == "GLOBAL_POSITION_INT":
        return GlobalPosition(msg.time_boot_ms / 1000.0, msg.relative_alt / 1000.0,
                              msg.vx / 100.0, msg.vy / 100.0)
    if kind == "LOCAL_POSITION_NED":
        return LocalAltitude(msg.time_boot_ms / 1000.0, msg.x, msg.y, -msg.z)
    if kind == "EXTENDED_SYS_STATE":
        return LandedState(msg.landed_state)
    if kind == "EKF_STATUS_REPORT":
        return EkfStatus(msg.flags)
    if kind == "GPS_GLOBAL_ORIGIN":
        return GlobalOrigin(msg.latitude / 1e7, msg.longitude / 1e7)
    return None


def is_setpoint(msg) -> bool:
    return msg.get_type() == "SET_POSITION_TARGET_LOCAL_NED"


def setpoint_time_s(msg) -> float:
    """The vehicle time (time_boot_ms) a companion setpoint was decided at."""
    return msg.time_boot_ms / 1000.0

