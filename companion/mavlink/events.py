"""The service's inbound events: frozen, SI units (seconds, metres, radians), one per message kind.

mavlink/inbound.py (and obstacle_forms.py for the obstacle messages) makes them from received
messages; nothing here reads a message. Times: ``t_s`` is the vehicle's time since boot
(time_boot_ms / 1000), the estimator's clock.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from companion.core.estimation.slam_types import Observation
from companion.mavlink.dialect import mavlink

# MAV_LANDED_STATE
LANDED_STATE_UNDEFINED = mavlink.MAV_LANDED_STATE_UNDEFINED      # 0
LANDED_STATE_ON_GROUND = mavlink.MAV_LANDED_STATE_ON_GROUND      # 1
LANDED_STATE_IN_AIR = mavlink.MAV_LANDED_STATE_IN_AIR            # 2
LANDED_STATE_TAKEOFF = mavlink.MAV_LANDED_STATE_TAKEOFF          # 3
LANDED_STATE_LANDING = mavlink.MAV_LANDED_STATE_LANDING          # 4


@dataclass(frozen=True)
class TimeSyncReply:
    """TIMESYNC with tc1 != 0: a reply (tc1 the responder's clock, ts1 our request's, both ns).
    Requests to us (tc1 = 0) are not decoded: we do not answer them."""
    system_id: int
    component_id: int
    tc1_ns: int
    ts1_ns: int


@dataclass(frozen=True)
class Heartbeat:
    system_id: int
    component_id: int
    mav_type: int
    is_autopilot: bool        # autopilot field is not MAV_AUTOPILOT_INVALID
    armed: bool
    custom_mode: int
    autopilot: int = 0        # MAV_AUTOPILOT: 3 ArduPilot, 12 PX4 (the dialect, link.autopilot auto)


@dataclass(frozen=True)
class Attitude:
    """ATTITUDE: the yaw and its rate (odometry's heading); roll and pitch level a depth
    camera's points (onboard/depth_intake.py); a hand-built event without them is level."""
    system_id: int
    component_id: int
    t_s: float
    yaw_rad: float
    yaw_rate_rad_s: float
    roll_rad: float = 0.0
    pitch_rad: float = 0.0


@dataclass(frozen=True)
class LocalPosition:
    system_id: int
    component_id: int
    t_s: float
    north_m: float
    east_m: float
    vel_north_mps: float
    vel_east_mps: float
    down_m: float = math.nan          # z: metres below the EKF origin
    vel_down_mps: float = math.nan    # vz


@dataclass(frozen=True)
class GlobalPosition:
    """GLOBAL_POSITION_INT: the altitude above home (relative_alt) and the climb rate."""
    system_id: int
    component_id: int
    t_s: float
    lat_deg: float
    lon_deg: float
    relative_alt_m: float
    vel_down_mps: float


@dataclass(frozen=True)
class LandedState:
    """EXTENDED_SYS_STATE (no time field of its own)."""
    system_id: int
    component_id: int
    landed_state: int                 # MAV_LANDED_STATE_*
    vtol_state: int


@dataclass(frozen=True)
class GeoReference:
    """A point known both on the globe and in LOCAL_NED: the EKF origin (GPS_GLOBAL_ORIGIN,
    at north = east = 0) or HOME_POSITION (at its x, y)."""
    system_id: int
    component_id: int
    kind: str                         # 'origin' or 'home'
    lat_deg: float
    lon_deg: float
    north_m: float
    east_m: float


@dataclass(frozen=True)
class ObstacleFrame:
    """Observations of one obstacle message (one OBSTACLE_DISTANCE_3D or all valid sectors)."""
    system_id: int
    component_id: int
    t_s: float
    observations: tuple[Observation, ...]
    rejected: str | None = None      # why the message gave no observation (frame, NaN, range)
    # OBSTACLE_DISTANCE: every element as (ranges_m with NaN where nothing, bearings_rad,
    # increment_rad), for core/perception/blobs.py; None for other messages
    sectors: tuple | None = None


@dataclass(frozen=True)
class CommandAck:
    system_id: int
    component_id: int
    command: int
    accepted: bool
    result: int


@dataclass(frozen=True)
class StatusText:
    system_id: int
    component_id: int
    severity: int
    text: str


@dataclass(frozen=True)
class GpsFix:
    """GPS_RAW_INT: the fix type (GPS_FIX_TYPE: 3 = 3D), HDOP (None: unknown) and the receiver's
    horizontal accuracy (None: not reported)."""
    system_id: int
    component_id: int
    fix_type: int
    hdop: float | None
    h_acc_m: float | None
    satellites: int | None


# EKF_STATUS_REPORT.flags (ESTIMATOR_STATUS_FLAGS) the position-fusion rule reads.
EKF_POS_HORIZ_ABS = mavlink.ESTIMATOR_POS_HORIZ_ABS
EKF_CONST_POS_MODE = mavlink.ESTIMATOR_CONST_POS_MODE
EKF_GPS_GLITCH = mavlink.ESTIMATOR_GPS_GLITCH


@dataclass(frozen=True)
class EkfStatus:
    """EKF_STATUS_REPORT (ArduPilot) or ESTIMATOR_STATUS (PX4; the same ESTIMATOR_STATUS_FLAGS
    bits): is the autopilot's absolute horizontal position good?"""
    system_id: int
    component_id: int
    flags: int

    @property
    def horizontal_position_ok(self) -> bool:
        """An absolute horizontal position, not the constant-position fallback, no GPS glitch."""
        bad = EKF_CONST_POS_MODE | EKF_GPS_GLITCH
        return bool(self.flags & EKF_POS_HORIZ_ABS) and not self.flags & bad


Event = Heartbeat | Attitude | LocalPosition | ObstacleFrame | CommandAck | StatusText \
    | GlobalPosition | LandedState | GeoReference | GpsFix | EkfStatus
