"""The service's own messages out: intents (frozen, SI units) and the messages they become.

Setpoints (SET_POSITION_TARGET_LOCAL_NED), our pose (ODOMETRY), identity (HEARTBEAT, SYS_STATUS),
notices (STATUSTEXT) and TIMESYNC requests; with each, the reader of the recorded message that
must agree with it (tlog replay compares the two). Commands to the vehicle are in commands.py,
the obstacle messages in obstacle_forms.py.
"""
from __future__ import annotations

import math
import struct
from dataclasses import dataclass

from companion.mavlink.dialect import mavlink

# SET_POSITION_TARGET_LOCAL_NED.type_mask: ignore position (0x7), acceleration (0x1C0) and yaw
# rate (0x800); use velocity (vx, vy and vz: ArduCopter flies vz as a climb rate) and yaw.
VELOCITY_YAW_TYPE_MASK = 0x09C7
STATUSTEXT_MAX_CHARS = 50


@dataclass(frozen=True)
class VelocitySetpoint:
    """Velocity (LOCAL_NED, autopilot frame) and yaw for the vehicle; t_s is the vehicle's time.
    vel_down_mps: the vertical term (ArduCopter flies vz as a climb rate; 0 holds the altitude)."""
    target_system: int
    target_component: int
    t_s: float
    vel_north_mps: float
    vel_east_mps: float
    yaw_rad: float
    reason: str                 # 'goal', 'avoid', 'escape', 'arrived', 'hold: ...'
    vel_down_mps: float = 0.0


@dataclass(frozen=True)
class PoseEstimate:
    """The SLAM pose [north_m, east_m, yaw_rad] with its (3,3) covariance at vehicle time t_s."""
    t_s: float
    north_m: float
    east_m: float
    yaw_rad: float
    cov: tuple[tuple[float, ...], ...]
    reset_counter: int
    quality: int = 0            # ODOMETRY.quality: 100 best, 1 worst, 0 unknown, -1 failed


@dataclass(frozen=True)
class Notice:
    """A STATUSTEXT to the ground station."""
    severity: int
    text: str


def ms_of(t_s: float) -> int:
    """Vehicle time in whole milliseconds, as MAVLink carries it."""
    return int(round(t_s * 1000.0)) & 0xFFFFFFFF


def timesync_request(ts1_ns: int) -> mavlink.MAVLink_timesync_message:
    """A TIMESYNC request: tc1 = 0, ts1 = our clock in ns (safety/timesync.py)."""
    return mavlink.MAVLink_timesync_message(0, int(ts1_ns))


def heartbeat(system_status: int = mavlink.MAV_STATE_ACTIVE) -> mavlink.MAVLink_heartbeat_message:
    """Our HEARTBEAT: an onboard controller, not an autopilot; system_status a MAV_STATE
    (companion/onboard/health.py: standby, active, critical)."""
    return mavlink.MAVLink_heartbeat_message(
        mavlink.MAV_TYPE_ONBOARD_CONTROLLER, mavlink.MAV_AUTOPILOT_INVALID, 0, 0,
        system_status, 3)


def sys_status(enabled: bool, healthy: bool) -> mavlink.MAVLink_sys_status_message:
    """Our SYS_STATUS: only MAV_SYS_STATUS_OBSTACLE_AVOIDANCE, present, enabled and healthy as
    companion/onboard/health.py judges; no battery (voltage UINT16_MAX, current and remaining -1)."""
    bit = mavlink.MAV_SYS_STATUS_OBSTACLE_AVOIDANCE
    return mavlink.MAVLink_sys_status_message(
        bit, bit if enabled else 0, bit if healthy else 0, 0, 0xFFFF, -1, -1, 0, 0, 0, 0, 0, 0)


def gcs_heartbeat() -> mavlink.MAVLink_heartbeat_message:
    return mavlink.MAVLink_heartbeat_message(
        mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, mavlink.MAV_STATE_ACTIVE, 3)


def set_position_target(sp: VelocitySetpoint) -> mavlink.MAVLink_set_position_target_local_ned_message:
    """SET_POSITION_TARGET_LOCAL_NED, MAV_FRAME_LOCAL_NED, velocity (vx, vy, vz) + yaw."""
    return mavlink.MAVLink_set_position_target_local_ned_message(
        ms_of(sp.t_s), sp.target_system, sp.target_component, mavlink.MAV_FRAME_LOCAL_NED,
        VELOCITY_YAW_TYPE_MASK, 0.0, 0.0, 0.0, sp.vel_north_mps, sp.vel_east_mps,
        sp.vel_down_mps, 0.0, 0.0, 0.0, sp.yaw_rad, 0.0)


_FLOAT32 = struct.Struct("<f")


def float32(value: float) -> float:
    """A float as a MAVLink float field carries it (IEEE single, round to nearest)."""
    return _FLOAT32.unpack(_FLOAT32.pack(value))[0]


def setpoint_key_of(sp: VelocitySetpoint) -> tuple:
    """``setpoint_key`` of the message ``set_position_target(sp)`` once sent and parsed, without
    packing it (replay compares thousands of them)."""
    return (ms_of(sp.t_s), sp.target_system, sp.target_component, mavlink.MAV_FRAME_LOCAL_NED,
            VELOCITY_YAW_TYPE_MASK, float32(sp.vel_north_mps), float32(sp.vel_east_mps),
            float32(sp.vel_down_mps), float32(sp.yaw_rad))


def setpoint_key(msg) -> tuple:
    """The fields of a SET_POSITION_TARGET_LOCAL_NED that define it, for comparisons (float32)."""
    return (msg.time_boot_ms, msg.target_system, msg.target_component, msg.coordinate_frame,
            msg.type_mask, msg.vx, msg.vy, msg.vz, msg.yaw)


# ODOMETRY.pose_covariance: upper triangle, row-major, of the 6x6 covariance of
# (x, y, z, roll, pitch, yaw): 21 floats. Our (north, east, yaw) rows and columns land here.
_POSE_COV_INDEX = {(0, 0): 0, (0, 1): 1, (0, 2): 5, (1, 1): 6, (1, 2): 10, (2, 2): 20}


def pose_covariance_21(cov: tuple[tuple[float, ...], ...]) -> list[float]:
    """The 21-float upper triangle from a (3,3) covariance over (north, east, yaw); NaN elsewhere
    (z, roll, pitch are not estimated)."""
    out = [math.nan] * 21
    for (i, j), k in _POSE_COV_INDEX.items():
        out[k] = float(cov[i][j])
    return out


def odometry(pose: PoseEstimate) -> mavlink.MAVLink_odometry_message:
    """ODOMETRY: the SLAM pose in MAV_FRAME_LOCAL_NED, body FRD child frame, estimator VIO.

    z, velocities and rates are not estimated: NaN, with velocity_covariance[0] = NaN (the spec's
    'unknown'). time_usec is the vehicle's time since boot.
    """
    half = 0.5 * pose.yaw_rad
    nan = math.nan
    return mavlink.MAVLink_odometry_message(
        int(round(pose.t_s * 1e6)), mavlink.MAV_FRAME_LOCAL_NED, mavlink.MAV_FRAME_BODY_FRD,
        pose.north_m, pose.east_m, nan, [math.cos(half), 0.0, 0.0, math.sin(half)],
        nan, nan, nan, nan, nan, nan, pose_covariance_21(pose.cov), [nan] * 21,
        pose.reset_counter & 0xFF, mavlink.MAV_ESTIMATOR_TYPE_VIO, max(-1, min(100, pose.quality)))


def odometry_key(msg) -> tuple[int, float, float]:
    """(time_usec, north_m, east_m) of a recorded ODOMETRY, as ``odometry`` wrote them."""
    return msg.time_usec, msg.x, msg.y


def statustext(notice: Notice) -> mavlink.MAVLink_statustext_message:
    text = notice.text[:STATUSTEXT_MAX_CHARS].encode("ascii", "replace")
    return mavlink.MAVLink_statustext_message(notice.severity, text, 0, 0)
