"""The truth model of a multicopter and the odometry it reports. Pure functions, no I/O.

Frame: x north, y east, up (metres above the start, the ground), yaw clockwise from north.

A multicopter's course is independent of its heading: the horizontal velocity vector moves
toward the demanded velocity by at most ``max_accel_mps2 * dt`` (the vector change, so turning
a fast velocity costs acceleration too), the heading turns toward the demanded yaw by at most
``max_turn_rate_rad_s * dt``, and the climb rate moves toward the demanded climb by at most
``accel_up_mps2 * dt``. Then ``north' = north + vn' dt``, ``east' = east + ve' dt``,
``up' = max(0, up + vu' dt)``. A grounded step (disarmed, or landed with idle motors) does not
move at all.

With the velocity along the heading (what the companion commands), this is the paper's
``x' = x + v dt cos(psi + gamma)``, ``psi' = psi + gamma`` up to the acceleration limit.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from .world import wrap_pi

_EPS_SPEED_MPS = 1e-3
FACE_VELOCITY_MIN_MPS = 0.5    # slower than this, a velocity without yaw keeps the heading
POS_XY_GAIN_PER_S = 1.0        # position error -> velocity (ArduCopter PSC_POSXY_P default 1.0)
POS_Z_GAIN_PER_S = 1.0         # altitude error -> climb rate (ArduCopter PSC_POSZ_P default 1.0)


@dataclass(frozen=True)
class TruthState:
    north_m: float
    east_m: float
    yaw_rad: float
    vel_north_mps: float = 0.0
    vel_east_mps: float = 0.0
    up_m: float = 0.0
    vel_up_mps: float = 0.0

    @property
    def speed_mps(self) -> float:
        """Horizontal speed."""
        return math.hypot(self.vel_north_mps, self.vel_east_mps)


@dataclass(frozen=True)
class Limits:
    max_turn_rate_rad_s: float
    max_accel_mps2: float
    accel_up_mps2: float = 1.0          # WPNAV_ACCEL_Z default 100 cm/s/s


@dataclass(frozen=True)
class Demand:
    """What the autopilot asks of the airframe for one step, in the autopilot's own frame.

    vel_north_mps, vel_east_mps: demanded horizontal velocity.
    yaw_rad: heading to turn toward; None: face the velocity when it is fast enough, else keep.
    yaw_rate_rad_s: turn at this rate instead (a yaw-rate command); None if not used.
    turn_rate_limit_rad_s: an extra limit on the turn rate (a commanded yaw rate), or None.
    climb_mps: demanded climb rate (up positive), or None to hold ``target_up_m``.
    target_up_m: altitude to go to (and hold) when climb_mps is None; None: hold the climb at 0.
    grounded: motors idle on the ground (or disarmed): nothing moves.
    """
    vel_north_mps: float = 0.0
    vel_east_mps: float = 0.0
    yaw_rad: float | None = None
    yaw_rate_rad_s: float | None = None
    turn_rate_limit_rad_s: float | None = None
    climb_mps: float | None = None
    target_up_m: float | None = None
    grounded: bool = False

    @property
    def speed_mps(self) -> float:
        return math.hypot(self.vel_north_mps, self.vel_east_mps)


HOLD = Demand()
GROUNDED = Demand(grounded=True)


@dataclass(frozen=True)
class Odometry:
    """What the vehicle reports: a gyro-integrated heading (drifts) and a dead-reckoned position
    from its noisy body-frame velocity rotated by that heading (drifts too)."""
    north_m: float
    east_m: float
    yaw_rad: float
    speed_mps: float
    yaw_rate_rad_s: float
    vel_north_mps: float
    vel_east_mps: float
    up_m: float = 0.0
    vel_up_mps: float = 0.0


def desired_climb_mps(demand: Demand, up_m: float, max_up_mps: float, max_down_mps: float,
                      accel_up_mps2: float) -> float:
    """The climb rate a demand asks for: its own rate, or a square-root controller toward its
    altitude (ArduCopter's sqrt_controller: linear near the target, sqrt(2 a e) further out)."""
    if demand.climb_mps is not None:
        return min(max(demand.climb_mps, -max_down_mps), max_up_mps)
    if demand.target_up_m is None:
        return 0.0
    error = demand.target_up_m - up_m
    rate = min(POS_Z_GAIN_PER_S * abs(error), math.sqrt(2.0 * accel_up_mps2 * abs(error)))
    return min(max(math.copysign(rate, error), -max_down_mps), max_up_mps)


def step_truth(state: TruthState, demand: Demand, limits: Limits, dt_s: float,
               yaw_est_rad: float, climb_mps: float) -> TruthState:
    """Advance the true state one step.

    yaw_est_rad: the autopilot's own heading; the heading error is measured against it, as a
    real autopilot steers by what its gyro says. climb_mps: the climb rate to move toward
    (``desired_climb_mps``).
    """
    if demand.grounded:
        return TruthState(state.north_m, state.east_m, state.yaw_rad, up_m=state.up_m)
    dvn = demand.vel_north_mps - state.vel_north_mps
    dve = demand.vel_east_mps - state.vel_east_mps
    dv = math.hypot(dvn, dve)
    max_dv = limits.max_accel_mps2 * dt_s
    if dv > max_dv:
        dvn, dve = dvn * max_dv / dv, dve * max_dv / dv
    vn, ve = state.vel_north_mps + dvn, state.vel_east_mps + dve

    dyaw = yaw_change(demand, yaw_est_rad, limits, dt_s)
    yaw = wrap_pi(state.yaw_rad + dyaw)

    max_dvu = limits.accel_up_mps2 * dt_s
    vu = state.vel_up_mps + min(max(climb_mps - state.vel_up_mps, -max_dvu), max_dvu)
    up = state.up_m + vu * dt_s
    if up <= 0.0:
        up, vu = 0.0, max(vu, 0.0)
    return TruthState(state.north_m + vn * dt_s, state.east_m + ve * dt_s, yaw, vn, ve, up, vu)


def yaw_change(demand: Demand, yaw_est_rad: float, limits: Limits, dt_s: float) -> float:
    """Heading change this step: toward the demanded yaw (or the velocity's direction), or at
    the demanded rate, limited by the turn rate (and a commanded yaw rate)."""
    max_turn = limits.max_turn_rate_rad_s
    if demand.turn_rate_limit_rad_s is not None:
        max_turn = min(max_turn, abs(demand.turn_rate_limit_rad_s))
    max_dyaw = max_turn * dt_s
    if demand.yaw_rate_rad_s is not None:
        dyaw = demand.yaw_rate_rad_s * dt_s
    elif demand.yaw_rad is not None:
        dyaw = wrap_pi(demand.yaw_rad - yaw_est_rad)
    elif demand.speed_mps > FACE_VELOCITY_MIN_MPS:
        dyaw = wrap_pi(math.atan2(demand.vel_east_mps, demand.vel_north_mps) - yaw_est_rad)
    else:
        dyaw = 0.0
    return min(max(dyaw, -max_dyaw), max_dyaw)


GRAVITY_MPS2 = 9.80665


def thrust_tilt_rad(before: TruthState, after: TruthState, dt_s: float) -> tuple[float, float]:
    """(roll, pitch) of a multicopter that accelerated from ``before`` to ``after``: its thrust
    carries the acceleration and holds it up, so the body's z axis lies along (-a_n, -a_e,
    g + a_up) and, at the heading of ``after``, the nose goes down by atan(a_forward / g) and the
    right side by asin(a_right / |thrust|)."""
    a_n = (after.vel_north_mps - before.vel_north_mps) / dt_s
    a_e = (after.vel_east_mps - before.vel_east_mps) / dt_s
    a_up = (after.vel_up_mps - before.vel_up_mps) / dt_s
    cos_y, sin_y = math.cos(after.yaw_rad), math.sin(after.yaw_rad)
    forward, right = a_n * cos_y + a_e * sin_y, -a_n * sin_y + a_e * cos_y
    lift = GRAVITY_MPS2 + a_up
    return math.asin(right / math.sqrt(forward ** 2 + right ** 2 + lift ** 2)), \
        math.atan2(-forward, lift)


def initial_odometry(start: TruthState) -> Odometry:
    """Odometry starts at the true start pose and at rest."""
    return Odometry(north_m=start.north_m, east_m=start.east_m, yaw_rad=start.yaw_rad,
                    speed_mps=0.0, yaw_rate_rad_s=0.0, vel_north_mps=0.0, vel_east_mps=0.0,
                    up_m=start.up_m)


def step_odometry(odom: Odometry, before: TruthState, after: TruthState, speed_noise_mps: float,
                  heading_noise_rad: float, vel_noise_ne_mps: tuple[float, float],
                  dt_s: float) -> Odometry:
    """Dead-reckon one step.

    reported yaw rate = (true heading change + heading noise) / dt; reported yaw = its integral;
    body-frame velocity = the true velocity seen from the true heading, plus the speed noise
    along it (forward when hovering); reported velocity = that, rotated by the reported yaw,
    plus per-axis noise; reported position = integral of the reported velocity. With the
    velocity along the heading this is the paper's model (speed + noise along the reported yaw);
    with zero noise odometry equals truth. A resting vehicle is reported with zero noise by the
    caller. Altitude and climb are reported as they are (a barometer, no noise).
    """
    dyaw = wrap_pi(after.yaw_rad - before.yaw_rad) + heading_noise_rad
    yaw = wrap_pi(odom.yaw_rad + dyaw)
    cos_t, sin_t = math.cos(after.yaw_rad), math.sin(after.yaw_rad)
    fwd = after.vel_north_mps * cos_t + after.vel_east_mps * sin_t
    right = -after.vel_north_mps * sin_t + after.vel_east_mps * cos_t
    speed = math.hypot(fwd, right)
    ux, uy = (fwd / speed, right / speed) if speed > _EPS_SPEED_MPS else (1.0, 0.0)
    fwd += speed_noise_mps * ux
    right += speed_noise_mps * uy
    cos_r, sin_r = math.cos(yaw), math.sin(yaw)
    vn = fwd * cos_r - right * sin_r + vel_noise_ne_mps[0]
    ve = fwd * sin_r + right * cos_r + vel_noise_ne_mps[1]
    return Odometry(north_m=odom.north_m + vn * dt_s, east_m=odom.east_m + ve * dt_s,
                    yaw_rad=yaw, speed_mps=math.hypot(vn, ve), yaw_rate_rad_s=dyaw / dt_s,
                    vel_north_mps=vn, vel_east_mps=ve, up_m=after.up_m,
                    vel_up_mps=after.vel_up_mps)


def velocity_demand(vel_north_mps: float, vel_east_mps: float, yaw_rad: float | None,
                    yaw_rate_rad_s: float | None, climb_mps: float | None = None) -> Demand:
    """Demand for a velocity target (ArduCopter's velocity controller with auto yaw).

    The velocity is flown as given, whatever the heading; a commanded yaw is turned to
    independently (course and heading differ while it turns, or for good if they differ); a
    commanded yaw rate turns at that rate; with neither, the vehicle faces its velocity.
    """
    return Demand(vel_north_mps=vel_north_mps, vel_east_mps=vel_east_mps, yaw_rad=yaw_rad,
                  yaw_rate_rad_s=None if yaw_rad is not None else yaw_rate_rad_s,
                  turn_rate_limit_rad_s=(abs(yaw_rate_rad_s) if (yaw_rad is not None
                                                                 and yaw_rate_rad_s) else None),
                  climb_mps=climb_mps)


def position_demand(north_m: float, east_m: float, target_north_m: float, target_east_m: float,
                    cruise_mps: float, max_accel_mps2: float, target_up_m: float | None,
                    yaw_rad: float | None = None, arrive_radius_m: float = 0.05) -> Demand:
    """Demand for flying to a point and stopping there (autopilot frame).

    Speed: cruise_mps, reduced so that the vehicle can stop at the point with max_accel_mps2
    (v = sqrt(2 a d)) and, close in, proportional to the distance (ArduCopter's sqrt_controller
    with PSC_POSXY_P = 1); the vehicle faces the point unless a yaw is given (ArduCopter's default
    yaw behaviour, "face next waypoint").
    """
    dn = target_north_m - north_m
    de = target_east_m - east_m
    dist = math.hypot(dn, de)
    if dist <= arrive_radius_m:
        return Demand(yaw_rad=yaw_rad, target_up_m=target_up_m)
    speed = min(cruise_mps, math.sqrt(2.0 * max_accel_mps2 * dist), POS_XY_GAIN_PER_S * dist)
    return Demand(vel_north_mps=speed * dn / dist, vel_east_mps=speed * de / dist,
                  yaw_rad=yaw_rad if yaw_rad is not None else math.atan2(de, dn),
                  target_up_m=target_up_m)
