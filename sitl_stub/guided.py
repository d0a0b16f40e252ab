"""GUIDED-mode targets from SET_POSITION_TARGET_LOCAL_NED, with ArduCopter's semantics. No I/O.

Follows ArduCopter/GCS_Mavlink.cpp handle_message_set_position_target_local_ned:
- frames LOCAL_NED, LOCAL_OFFSET_NED, BODY_NED, BODY_OFFSET_NED; any other frame stops the
  vehicle (mode_guided.init: hold);
- a group (position x/y/z, velocity, acceleration) counts as ignored if ANY of its bits is set;
- body frames rotate x/y by the vehicle's heading (rotate_body_frame_to_NE); offset and body
  frames add the current position to a position; in body frames the yaw is relative;
- position+velocity, velocity(+acceleration), position only are accepted; anything else stops;
- FORCE_SET with acceleration used stops (force is not supported);
- a velocity component that is NaN or |v| > 1000 m/s stops (sane_vel_or_acc_vector).
The stub is stricter in two places: a non-finite value in ANY used field stops, and so does an
acceleration-only target (the 2D model has no acceleration control).

GUID_TIMEOUT (ModeGuided velaccel/posvelaccel control): if no new target arrives for
max(GUID_TIMEOUT, 0.1) s, velocity (and yaw rate) targets are zeroed; a position target stays.
After a velocity target times out the vehicle stops (vz too) and keeps its current heading.

Vertical: a velocity target's vz is a climb rate (vz = 0 holds the altitude), within
WPNAV_SPEED_UP / WPNAV_SPEED_DN; a position target's z is an altitude (LOCAL_NED: -z above the
origin, the ground), offset by the current one in offset/body frames; a hold keeps the altitude
it was created at.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from .vehicle import HOLD, Demand, Odometry, position_demand, velocity_demand

MAV_FRAME_LOCAL_NED = 1
MAV_FRAME_LOCAL_OFFSET_NED = 7
MAV_FRAME_BODY_NED = 8
MAV_FRAME_BODY_OFFSET_NED = 9
SUPPORTED_FRAMES = (MAV_FRAME_LOCAL_NED, MAV_FRAME_LOCAL_OFFSET_NED, MAV_FRAME_BODY_NED,
                    MAV_FRAME_BODY_OFFSET_NED)
BODY_FRAMES = (MAV_FRAME_BODY_NED, MAV_FRAME_BODY_OFFSET_NED)

MASK_POS_IGNORE = 0x0007
MASK_VEL_IGNORE = 0x0038
MASK_ACC_IGNORE = 0x01C0
MASK_FORCE_SET = 0x0200
MASK_YAW_IGNORE = 0x0400
MASK_YAW_RATE_IGNORE = 0x0800

MAX_VEL_COMPONENT_MPS = 1000.0   # ArduCopter sane_vel_or_acc_vector
MAX_POS_COMPONENT_M = 1.0e6      # the stub's own sanity bound for positions
POSVEL_GAIN_PER_S = 1.0          # position error -> velocity correction (ArduCopter PSC_POSXY_P default 1)

KIND_HOLD = "hold"
KIND_VELOCITY = "velocity"
KIND_POSITION = "position"
KIND_POSVEL = "posvel"


@dataclass(frozen=True)
class GuidedTarget:
    """A target in force, in the autopilot's LOCAL_NED frame (already rotated/offset)."""
    kind: str
    set_t_s: float
    north_m: float = 0.0
    east_m: float = 0.0
    vel_north_mps: float = 0.0
    vel_east_mps: float = 0.0
    yaw_rad: float | None = None
    yaw_rate_rad_s: float | None = None
    reason: str = ""
    up_m: float | None = None          # altitude target (position, hold); None: keep the climb 0
    vel_up_mps: float = 0.0            # climb rate of a velocity target (-vz)


def hold_target(t_s: float, reason: str, up_m: float | None = None) -> GuidedTarget:
    return GuidedTarget(kind=KIND_HOLD, set_t_s=t_s, reason=reason, up_m=up_m)


def parse_target(msg, odom: Odometry, t_s: float) -> GuidedTarget:
    """Turn a SET_POSITION_TARGET_LOCAL_NED into the target in force (a hold if invalid).

    odom: the autopilot's own estimate, used for body-frame rotation and offsets.
    """
    target = _parse(msg, odom, t_s)
    if target.kind == KIND_HOLD:
        return hold_target(t_s, target.reason, odom.up_m)
    return target


def _parse(msg, odom: Odometry, t_s: float) -> GuidedTarget:
    frame = int(msg.coordinate_frame)
    if frame not in SUPPORTED_FRAMES:
        return hold_target(t_s, f"unsupported frame {frame}")
    mask = int(msg.type_mask)
    pos_used = not (mask & MASK_POS_IGNORE)
    vel_used = not (mask & MASK_VEL_IGNORE)
    acc_used = not (mask & MASK_ACC_IGNORE)
    yaw_used = not (mask & MASK_YAW_IGNORE)
    yaw_rate_used = not (mask & MASK_YAW_RATE_IGNORE)
    if (mask & MASK_FORCE_SET) and acc_used:
        return hold_target(t_s, "force setpoints are not supported")

    used = []
    if pos_used:
        used += [msg.x, msg.y, msg.z]
    if vel_used:
        used += [msg.vx, msg.vy, msg.vz]
    if acc_used:
        used += [msg.afx, msg.afy, msg.afz]
    if yaw_used:
        used.append(msg.yaw)
    if yaw_rate_used:
        used.append(msg.yaw_rate)
    if not all(math.isfinite(v) for v in used):
        return hold_target(t_s, "non-finite value in a used field")
    if vel_used and max(abs(msg.vx), abs(msg.vy), abs(msg.vz)) > MAX_VEL_COMPONENT_MPS:
        return hold_target(t_s, "velocity out of range")
    if pos_used and max(abs(msg.x), abs(msg.y)) > MAX_POS_COMPONENT_M:
        return hold_target(t_s, "position out of range")

    body = frame in BODY_FRAMES
    cos_y, sin_y = math.cos(odom.yaw_rad), math.sin(odom.yaw_rad)
    north = east = 0.0
    up = None
    if pos_used:
        north, east, up = float(msg.x), float(msg.y), -float(msg.z)
        if body:
            north, east = north * cos_y - east * sin_y, north * sin_y + east * cos_y
        if frame != MAV_FRAME_LOCAL_NED:
            north += odom.north_m
            east += odom.east_m
            up += odom.up_m
    vn = ve = 0.0
    if vel_used:
        vn, ve = float(msg.vx), float(msg.vy)
        if body:
            vn, ve = vn * cos_y - ve * sin_y, vn * sin_y + ve * cos_y
    yaw = None
    if yaw_used:
        yaw = float(msg.yaw) + (odom.yaw_rad if body else 0.0)
    yaw_rate = float(msg.yaw_rate) if yaw_rate_used else None

    if pos_used and vel_used:
        kind = KIND_POSVEL
    elif vel_used:
        kind = KIND_VELOCITY
    elif pos_used and not acc_used:
        kind = KIND_POSITION
    else:
        return hold_target(t_s, "unsupported type_mask combination 0x%04x" % mask)
    return GuidedTarget(kind=kind, set_t_s=t_s, north_m=north, east_m=east, vel_north_mps=vn,
                        vel_east_mps=ve, yaw_rad=yaw, yaw_rate_rad_s=yaw_rate, up_m=up,
                        vel_up_mps=-float(msg.vz) if vel_used else 0.0)


def timeout_s(guid_timeout_param_s: float) -> float:
    """ModeGuided::get_timeout_ms: MAX(GUID_TIMEOUT, 0.1) seconds."""
    return max(guid_timeout_param_s, 0.1)


def demand_for(target: GuidedTarget | None, odom: Odometry, t_s: float, guid_timeout_s: float,
               cruise_mps: float, max_accel_mps2: float) -> Demand:
    """The demand that a target in force makes at simulated time t_s."""
    if target is None:
        return HOLD
    if target.kind == KIND_HOLD:
        return Demand(target_up_m=target.up_m)
    age_s = t_s - target.set_t_s
    timed_out = age_s > guid_timeout_s
    if target.kind == KIND_VELOCITY:
        if timed_out:
            # Velocity, climb and yaw rate zeroed; a yaw angle target is kept (ModeGuided).
            return Demand(yaw_rad=target.yaw_rad, climb_mps=0.0)
        return velocity_demand(target.vel_north_mps, target.vel_east_mps, target.yaw_rad,
                               target.yaw_rate_rad_s, climb_mps=target.vel_up_mps)
    if target.kind == KIND_POSITION:
        return position_demand(odom.north_m, odom.east_m, target.north_m, target.east_m,
                               cruise_mps, max_accel_mps2, target.up_m, target.yaw_rad)
    # position + velocity: the position target moves with the velocity until the timeout,
    # then freezes (velocity zeroed, position kept), and the vehicle converges on it.
    run_s = min(age_s, guid_timeout_s)
    vff_n, vff_e = (0.0, 0.0) if timed_out else (target.vel_north_mps, target.vel_east_mps)
    pt_n = target.north_m + target.vel_north_mps * run_s
    pt_e = target.east_m + target.vel_east_mps * run_s
    pt_up = None if target.up_m is None else target.up_m + target.vel_up_mps * run_s
    if timed_out:
        return position_demand(odom.north_m, odom.east_m, pt_n, pt_e, cruise_mps,
                               max_accel_mps2, pt_up, target.yaw_rad)
    cmd_n = vff_n + POSVEL_GAIN_PER_S * (pt_n - odom.north_m)
    cmd_e = vff_e + POSVEL_GAIN_PER_S * (pt_e - odom.east_m)
    cap = max(math.hypot(vff_n, vff_e), cruise_mps)
    norm = math.hypot(cmd_n, cmd_e)
    if norm > cap:
        cmd_n, cmd_e = cmd_n * cap / norm, cmd_e * cap / norm
    demand = velocity_demand(cmd_n, cmd_e, target.yaw_rad, None)
    return Demand(vel_north_mps=demand.vel_north_mps, vel_east_mps=demand.vel_east_mps,
                  yaw_rad=demand.yaw_rad, target_up_m=pt_up)


def report_fields(target: GuidedTarget, t_s: float, guid_timeout_s: float) -> dict:
    """Fields of POSITION_TARGET_LOCAL_NED for the target in force (ArduCopter's type masks)."""
    timed_out = (t_s - target.set_t_s) > guid_timeout_s
    vn, ve = (0.0, 0.0) if timed_out else (target.vel_north_mps, target.vel_east_mps)
    if target.kind == KIND_POSITION:
        return dict(type_mask=0x0FF8, x=target.north_m, y=target.east_m, vx=0.0, vy=0.0)
    if target.kind == KIND_POSVEL:
        run_s = min(t_s - target.set_t_s, guid_timeout_s)
        return dict(type_mask=0x0FC0, x=target.north_m + target.vel_north_mps * run_s,
                    y=target.east_m + target.vel_east_mps * run_s, vx=vn, vy=ve)
    if target.kind == KIND_VELOCITY:
        return dict(type_mask=0x0FC7, x=0.0, y=0.0, vx=vn, vy=ve)
    return dict(type_mask=0x0FC7, x=0.0, y=0.0, vx=0.0, vy=0.0)
