"""A multicopter's velocity as ArduCopter's GUIDED flies a velocity setpoint: jerk-limited.

ArduCopter does not move its velocity toward a new setpoint at the acceleration limit at once
(arc._fly_copter without a jerk limit, and the stub's truth). Its position controller
(AC_PosControl::input_vel_accel_xy, AP_Math control.cpp shape_vel_accel_xy) shapes the target:

- the acceleration wanted is a square-root controller on the velocity error with gain
  KPa = jerk_max / accel_max (1/s): linear, KPa x error, up to an error of accel_max^2 / jerk_max,
  then sqrt(2 jerk_max (error - that / 2)); at most accel_max as a vector;
- the acceleration itself moves toward that at most jerk_max x dt (shape_accel_xy).

With GUIDED's limits (WPNAV_ACCEL 250 cm/s/s, PSC_JERK_XY 5 m/s/s/s: neither set in
copter-4.6.parm, so the defaults) KPa is 2/s: the velocity follows the setpoint like a first-order
lag of 0.5 s, and the acceleration takes 0.5 s to reach its limit. Measured on ArduCopter 4.6 SITL
(tests/core/data/arducopter_guided_velocity.csv, from the service's tlog of the ceiling flight):
this model, started from the vehicle's velocity, reproduces LOCAL_POSITION_NED's velocity from
the sent setpoints within 0.14 m/s RMS over 62 s of flight (0.47 m/s for the unshaped step); the
same setpoints flown unshaped round the wall's end 2.6 m wider than ArduCopter did.

``shaped_step`` is one roll-out step on (J,) arrays; the acceleration starts at zero (the
vehicle's own is not measured), which the 0.5 s ramp then dominates. Pure numpy, SI units.
"""
from __future__ import annotations

import math

import numpy as np

from companion.core.geometry import TWO_PI

SUBSTEPS = 2          # per roll-out step (arc.STEP_S = 0.25 s): 0.125 s, KPa x dt = 0.25


def extra_brake_steps(max_accel_mps2: float, max_jerk_mps3: float, step_s: float) -> int:
    """Roll-out steps a jerk-limited stop takes beyond the unshaped one: the acceleration's
    ramp (accel / jerk) and the first-order tail near rest (twice the time constant)."""
    return int(math.ceil(3.0 * (max_accel_mps2 / max_jerk_mps3) / step_s))


def shaped_step(north, east, vel_n, vel_e, acc_n, acc_e, set_n, set_e, max_accel_mps2: float,
                max_jerk_mps3: float, step_s: float):
    """Advance (J,) states one ``step_s`` toward the setpoints (set_n, set_e), SUBSTEPS at a time:
    returns north, east, vel_n, vel_e, acc_n, acc_e."""
    dt = step_s / SUBSTEPS
    kpa = max_jerk_mps3 / max_accel_mps2
    linear = max_accel_mps2 * max_accel_mps2 / max_jerk_mps3     # error where sqrt takes over
    max_da = max_jerk_mps3 * dt
    for _ in range(SUBSTEPS):
        err_n, err_e = set_n - vel_n, set_e - vel_e
        err = np.sqrt(err_n * err_n + err_e * err_e)
        wanted = np.where(err <= linear, kpa * err,
                          np.sqrt(2.0 * max_jerk_mps3 * np.maximum(err - 0.5 * linear, 0.0)))
        wanted = np.minimum(np.minimum(wanted, err / dt), max_accel_mps2)
        scale = np.where(err > 1e-9, wanted / np.maximum(err, 1e-9), 0.0)
        want_n, want_e = err_n * scale, err_e * scale
        da_n, da_e = want_n - acc_n, want_e - acc_e
        da = np.sqrt(da_n * da_n + da_e * da_e)
        limit = np.where(da > max_da, max_da / np.maximum(da, 1e-12), 1.0)
        acc_n, acc_e = acc_n + da_n * limit, acc_e + da_e * limit
        north = north + (vel_n + 0.5 * acc_n * dt) * dt
        east = east + (vel_e + 0.5 * acc_e * dt) * dt
        vel_n, vel_e = vel_n + acc_n * dt, vel_e + acc_e * dt
    return north, east, vel_n, vel_e, acc_n, acc_e


def turn_setpoint(headings: np.ndarray, commanded: np.ndarray, nose: np.ndarray,
                  gate: np.ndarray, split: bool, max_turn: float, fov_rad: float):
    """One cruise step of a multicopter's roll-out (arrays of J): the setpoint's speed, its
    direction ``nose`` turned toward the headings by at most ``max_turn``, and the speed's
    ``gate`` turned likewise when ``split`` (else the gate is the nose: Motion.setpoint_split).
    The speed is the command's scaled by the cosine of the gate's error before the turn, zero
    beyond half the view. Shared by arc._fly_copter and fly_copter_shaped; their one-command
    loops write the same operations inline, in the same order."""
    error = (headings - nose + math.pi) % TWO_PI - math.pi
    if split:
        gate_error = (headings - gate + math.pi) % TWO_PI - math.pi
        gate = gate + np.minimum(np.maximum(gate_error, -max_turn), max_turn)
    else:
        gate_error = error
    speed = np.where(np.abs(gate_error) > 0.5 * fov_rad, 0.0, commanded * np.cos(gate_error))
    return speed, nose + np.minimum(np.maximum(error, -max_turn), max_turn), gate


def fly_copter_shaped(start: np.ndarray, motion, headings: np.ndarray, commanded: np.ndarray,
                      steps: int, cruise_steps: int, fov_rad: float, step_s: float):
    """arc._fly_copter with ArduCopter's jerk-limited velocity (``motion.max_jerk_mps3``): the
    setpoint's direction and the speed's gate turn toward the command at the turn rate (as
    arc._fly_copter: from Motion.setpoint_start_rad and ``nose_rad``), the velocity follows the
    setpoint through ``shaped_step``; after the cruise the setpoint is zero. positions (J, N, 2),
    speeds (J, N)."""
    j = len(headings)
    max_turn = motion.max_turn_rate_rad_s * step_s
    nose = np.full(j, motion.setpoint_start_rad)
    gate, split = np.full(j, float(motion.nose_rad)), motion.setpoint_split
    vel_n = np.full(j, motion.speed_mps * math.cos(motion.course_rad))
    vel_e = np.full(j, motion.speed_mps * math.sin(motion.course_rad))
    acc_n, acc_e = np.zeros(j), np.zeros(j)
    north, east = np.full(j, float(start[0])), np.full(j, float(start[1]))
    positions = np.empty((j, steps, 2))
    speeds = np.empty((j, steps))
    zeros = np.zeros(j)
    for k in range(steps):
        if k < cruise_steps:
            speed, nose, gate = turn_setpoint(headings, commanded, nose, gate, split, max_turn,
                                              fov_rad)
            set_n, set_e = speed * np.cos(nose), speed * np.sin(nose)
        else:
            set_n, set_e = zeros, zeros
        north, east, vel_n, vel_e, acc_n, acc_e = shaped_step(
            north, east, vel_n, vel_e, acc_n, acc_e, set_n, set_e, motion.max_accel_mps2,
            motion.max_jerk_mps3, step_s)
        positions[:, k, 0] = north
        positions[:, k, 1] = east
        speeds[:, k] = np.sqrt(vel_n * vel_n + vel_e * vel_e)
    return positions, speeds


def fly_copter_shaped_one(start: np.ndarray, motion, heading: float, commanded: float,
                          steps: int, cruise_steps: int, fov_rad: float, step_s: float):
    """fly_copter_shaped for one command in Python floats (J = 1 is most roll-outs: the goal
    heading's path, a look; numpy's per-call cost was 80 times the arithmetic there). The same
    operations in the same order; positions (1, N, 2), speeds (1, N)."""
    sqrt, cos, sin, pi = math.sqrt, math.cos, math.sin, math.pi
    accel, jerk = motion.max_accel_mps2, motion.max_jerk_mps3
    dt = step_s / SUBSTEPS
    kpa = jerk / accel
    linear = accel * accel / jerk
    max_da = jerk * dt
    max_turn = motion.max_turn_rate_rad_s * step_s
    half_fov = 0.5 * fov_rad
    nose = motion.setpoint_start_rad
    gate, split = float(motion.nose_rad), motion.setpoint_split
    vel_n = motion.speed_mps * cos(motion.course_rad)
    vel_e = motion.speed_mps * sin(motion.course_rad)
    acc_n = acc_e = 0.0
    north, east = float(start[0]), float(start[1])
    path: list[float] = []
    speeds: list[float] = []
    for k in range(steps):
        if k < cruise_steps:
            error = (heading - nose + pi) % TWO_PI - pi
            if split:
                gate_error = (heading - gate + pi) % TWO_PI - pi
                gate = gate + min(max(gate_error, -max_turn), max_turn)
            else:
                gate_error = error
            speed = 0.0 if abs(gate_error) > half_fov else commanded * cos(gate_error)
            nose = nose + min(max(error, -max_turn), max_turn)
            set_n, set_e = speed * cos(nose), speed * sin(nose)
        else:
            set_n = set_e = 0.0
        for _ in range(SUBSTEPS):
            err_n, err_e = set_n - vel_n, set_e - vel_e
            err = sqrt(err_n * err_n + err_e * err_e)
            wanted = kpa * err if err <= linear else sqrt(2.0 * jerk * max(err - 0.5 * linear, 0.0))
            wanted = min(min(wanted, err / dt), accel)
            scale = wanted / max(err, 1e-9) if err > 1e-9 else 0.0
            da_n, da_e = err_n * scale - acc_n, err_e * scale - acc_e
            da = sqrt(da_n * da_n + da_e * da_e)
            limit = max_da / max(da, 1e-12) if da > max_da else 1.0
            acc_n, acc_e = acc_n + da_n * limit, acc_e + da_e * limit
            north = north + (vel_n + 0.5 * acc_n * dt) * dt
            east = east + (vel_e + 0.5 * acc_e * dt) * dt
            vel_n, vel_e = vel_n + acc_n * dt, vel_e + acc_e * dt
        path.append(north)
        path.append(east)
        speeds.append(sqrt(vel_n * vel_n + vel_e * vel_e))
    return np.array(path).reshape(1, steps, 2), np.array(speeds).reshape(1, steps)
