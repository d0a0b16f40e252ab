"""The paper's 2D kinematic model as truth, its control limits, and odometry as a vehicle reports it.

Pure functions on frozen dataclasses: no I/O, no clock, no random generator (noise samples are
passed in). Frame: x north, y east (metres), yaw clockwise from north (radians, wrapped to
(-pi, pi]). The vehicle flies along its heading: velocity direction == yaw.

One physics step of length dt_s, given a control (new speed, heading change gamma):

    yaw'   = wrap(yaw + gamma)
    north' = north + v' dt cos(yaw')
    east'  = east  + v' dt sin(yaw')

which is the paper's `x' = x + v dt cos(psi + gamma)`, `psi' = psi + gamma`.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from .world import wrap_pi

_EPS_SPEED_MPS = 1e-3


@dataclass(frozen=True)
class TruthState:
    north_m: float
    east_m: float
    yaw_rad: float
    speed_mps: float


@dataclass(frozen=True)
class Limits:
    max_turn_rate_rad_s: float
    max_accel_mps2: float


@dataclass(frozen=True)
class Demand:
    """What the autopilot asks of the airframe for one step, in the autopilot's own frame.

    speed_mps: desired speed (>= 0).
    yaw_rad: desired heading, or None to keep the current one.
    turn_rate_limit_rad_s: an extra limit on the turn rate (a commanded yaw rate), or None.
    yaw_rate_rad_s: turn at this rate instead of towards yaw_rad (yaw-rate command while
        hovering); None if not used.
    """
    speed_mps: float
    yaw_rad: float | None = None
    turn_rate_limit_rad_s: float | None = None
    yaw_rate_rad_s: float | None = None


HOLD = Demand(speed_mps=0.0)


@dataclass(frozen=True)
class Control:
    """The paper's control for one step: the speed after the step and the heading change."""
    speed_mps: float
    yaw_change_rad: float


@dataclass(frozen=True)
class Odometry:
    """What the vehicle reports: gyro-integrated heading and dead-reckoned position (they drift)."""
    north_m: float
    east_m: float
    yaw_rad: float
    speed_mps: float
    yaw_rate_rad_s: float
    vel_north_mps: float
    vel_east_mps: float


def steer(demand: Demand, yaw_est_rad: float, speed_mps: float, limits: Limits,
          dt_s: float) -> Control:
    """Turn a demand into a control, applying the acceleration and turn-rate limits.

    The heading error is measured against the autopilot's own heading estimate (yaw_est_rad):
    a real autopilot steers by what its gyro says. The speed limit acts on the true speed.
    """
    max_dv = limits.max_accel_mps2 * dt_s
    target_speed = max(0.0, demand.speed_mps)
    new_speed = speed_mps + min(max(target_speed - speed_mps, -max_dv), max_dv)
    new_speed = max(0.0, new_speed)

    max_turn = limits.max_turn_rate_rad_s
    if demand.turn_rate_limit_rad_s is not None:
        max_turn = min(max_turn, abs(demand.turn_rate_limit_rad_s))
    max_dyaw = max_turn * dt_s
    if demand.yaw_rate_rad_s is not None:
        dyaw = demand.yaw_rate_rad_s * dt_s
    elif demand.yaw_rad is not None:
        dyaw = wrap_pi(demand.yaw_rad - yaw_est_rad)
    else:
        dyaw = 0.0
    dyaw = min(max(dyaw, -max_dyaw), max_dyaw)
    return Control(speed_mps=new_speed, yaw_change_rad=dyaw)


def step_truth(state: TruthState, control: Control, dt_s: float) -> TruthState:
    """Advance the true state by one step of the paper's model."""
    yaw = wrap_pi(state.yaw_rad + control.yaw_change_rad)
    v = control.speed_mps
    return TruthState(north_m=state.north_m + v * dt_s * math.cos(yaw),
                      east_m=state.east_m + v * dt_s * math.sin(yaw),
                      yaw_rad=yaw, speed_mps=v)


def initial_odometry(start: TruthState) -> Odometry:
    """Odometry starts at the true start pose and at rest."""
    return Odometry(north_m=start.north_m, east_m=start.east_m, yaw_rad=start.yaw_rad,
                    speed_mps=0.0, yaw_rate_rad_s=0.0, vel_north_mps=0.0, vel_east_mps=0.0)


def step_odometry(odom: Odometry, true_yaw_change_rad: float, true_speed_mps: float,
                  speed_noise_mps: float, heading_noise_rad: float, dt_s: float) -> Odometry:
    """Dead-reckon one step from noisy speed and heading change.

    reported speed = true speed + speed noise; reported yaw rate = (true heading change +
    heading noise) / dt; reported yaw = integral of the reported yaw rate; reported velocity =
    reported speed along the reported yaw; reported position = integral of reported velocity.
    The same ordering as step_truth (turn first, then move), so with zero noise odometry equals
    truth. A resting vehicle is reported with zero noise by the caller.
    """
    speed = true_speed_mps + speed_noise_mps
    dyaw = true_yaw_change_rad + heading_noise_rad
    yaw = wrap_pi(odom.yaw_rad + dyaw)
    vn = speed * math.cos(yaw)
    ve = speed * math.sin(yaw)
    return Odometry(north_m=odom.north_m + vn * dt_s, east_m=odom.east_m + ve * dt_s,
                    yaw_rad=yaw, speed_mps=speed, yaw_rate_rad_s=dyaw / dt_s,
                    vel_north_mps=vn, vel_east_mps=ve)


def velocity_demand(vel_north_mps: float, vel_east_mps: float, yaw_rad: float | None,
                    yaw_rate_rad_s: float | None) -> Demand:
    """Demand for a velocity target (autopilot frame).

    The vehicle flies along its heading, so a non-zero velocity sets the heading to the
    velocity's direction and the speed to its magnitude; a commanded yaw that differs is not
    followed (the velocity wins). A commanded non-zero yaw rate limits how fast it turns towards
    that direction. With zero velocity the vehicle hovers and a yaw or yaw rate turns it in place.
    """
    speed = math.hypot(vel_north_mps, vel_east_mps)
    if speed > _EPS_SPEED_MPS:
        limit = abs(yaw_rate_rad_s) if yaw_rate_rad_s else None
        return Demand(speed_mps=speed, yaw_rad=math.atan2(vel_east_mps, vel_north_mps),
                      turn_rate_limit_rad_s=limit)
    if yaw_rad is not None:
        return Demand(speed_mps=0.0, yaw_rad=yaw_rad)
    if yaw_rate_rad_s is not None:
        return Demand(speed_mps=0.0, yaw_rate_rad_s=yaw_rate_rad_s)
    return HOLD


def position_demand(north_m: float, east_m: float, target_north_m: float, target_east_m: float,
                    yaw_est_rad: float, cruise_mps: float, max_accel_mps2: float,
                    arrive_radius_m: float = 0.05) -> Demand:
    """Demand for flying to a point and stopping there (autopilot frame).

    Speed: cruise_mps, reduced so that the vehicle can stop at the point with max_accel_mps2
    (v = sqrt(2 a d)), and scaled by cos(heading error) so that a vehicle facing away turns
    first instead of circling the point.
    """
    dn = target_north_m - north_m
    de = target_east_m - east_m
    dist = math.hypot(dn, de)
    if dist <= arrive_radius_m:
        return HOLD
    bearing = math.atan2(de, dn)
    speed = min(cruise_mps, math.sqrt(2.0 * max_accel_mps2 * dist))
    speed *= max(0.0, math.cos(wrap_pi(bearing - yaw_est_rad)))
    return Demand(speed_mps=speed, yaw_rad=bearing)
