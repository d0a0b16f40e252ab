"""Reachable velocities: the path a vehicle actually flies toward a (speed, heading) command.

A heading that is free from where the vehicle is may not be reachable: at 15 m/s and 30 deg/s
the turn's radius is 29 m, and the arc toward the free heading can cross a neighbour's safety
circle. ``fly_out`` rolls every candidate command forward as the vehicle would fly it, and
``clearance`` measures each rolled-out path against every obstacle (moving ones at their
predicted positions, their radius growing with the track's uncertainty):

- the heading turns toward the command at ``min(turn rate, lateral accel / speed)`` (a unicycle
  has only the turn rate; a multicopter's velocity turns no faster than its acceleration allows);
- the speed moves toward the command at the acceleration limit; the command itself is scaled by
  the cosine of the remaining heading error and is zero beyond half the camera's field of view,
  as the guidance does at every decision (it turns in place toward headings it cannot see);
- after ``horizon_s`` the vehicle brakes to a stop along its heading: a command is only
  reachable if stopping after it is too (no state from which every future collides).

A multicopter (a lateral limit and its nose known: Motion.nose_rad) is rolled out as it flies
its velocity setpoint instead (_fly_copter): the nose turns at the turn rate, the setpoint
follows the nose (or, while the nose is apart from it after a look, goes on from the last
setpoint's direction, as guidance.shape_setpoint sends it), the velocity follows the setpoint
within max_accel as a vector, and a stop brakes straight. The arc above was 2.7 to 20 m off
that flight at 5 to 15 m/s (its course turned while braking, its speed kept up in a turn), and
at 10 m/s the choice took turns it could not fly and then braked straight into a safety circle
(tests/core/test_copter_rollout.py).

Why over 400 lines: each roll-out is written twice, on arrays and in Python floats for one
command (the most frequent call), and the two must stay the same operations in the same order
to the last bit (tests/core/test_fly_out.py); side by side, a change to one is seen in the other.

Pure numpy; times in seconds, positions north/east metres, headings LOCAL_NED yaw (rad).
"""
from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from companion.core.avoidance.jerk_shaping import (extra_brake_steps, fly_copter_shaped,
                                                   fly_copter_shaped_one, turn_setpoint)
from companion.core.geometry import TWO_PI

STEP_S = 0.25                    # the roll-out's time step
MAX_GROWTH_M = 5.0               # a mover's radius grows by at most this over a roll-out: a
                                 # track whose velocity is barely known must not wall off the sky


def stopping_distance_m(speed_mps: float, delay_s: float, max_accel_mps2: float) -> float:
    """How far a vehicle at ``speed_mps`` goes before it has stopped for an obstacle it has just
    seen: ``delay_s`` on at that speed (until the obstacle counts), then braking at the limit."""
    return speed_mps * delay_s + speed_mps * speed_mps / (2.0 * max_accel_mps2)


@dataclass(frozen=True)
class VehicleLimits:
    """The vehicle's velocity limits, from its config (SI units, radians)."""
    max_turn_rate_rad_s: float
    max_accel_mps2: float
    lateral_accel_limited: bool = False      # a multicopter's velocity turns within max_accel
    max_jerk_mps3: float | None = None       # a multicopter's velocity shaped as ArduCopter's
                                             # (jerk_shaping.py); None: within max_accel at once

    def motion(self, speed_mps: float, course_rad: float, nose_rad: float | None = None,
               setpoint_rad: float | None = None) -> "Motion":
        """``nose_rad``: the yaw now, ``setpoint_rad``: where the setpoint turns from (a
        multicopter's; see Motion)."""
        copter = self.lateral_accel_limited
        return Motion(self.max_turn_rate_rad_s, self.max_accel_mps2, speed_mps, course_rad,
                      self.max_accel_mps2 if copter else None, nose_rad if copter else None,
                      self.max_jerk_mps3 if copter else None,
                      setpoint_rad if copter else None)


@dataclass(frozen=True)
class Motion:
    """What limits the vehicle's velocity, and the velocity it has now."""
    max_turn_rate_rad_s: float
    max_accel_mps2: float
    speed_mps: float                         # now
    course_rad: float                        # direction of the velocity now
    max_lateral_accel_mps2: float | None = None   # None: the unicycle (turn rate only)
    nose_rad: float | None = None            # a multicopter's yaw now: with a lateral limit, the
                                             # roll-out flies its velocity setpoint (_fly_copter)
    max_jerk_mps3: float | None = None       # with nose_rad: the velocity follows the setpoint
                                             # jerk-limited, as ArduCopter's (jerk_shaping.py)
    setpoint_rad: float | None = None        # with nose_rad: the direction the next setpoint's
                                             # velocity turns from, if not the nose (the last
                                             # setpoint's while the nose is apart from it)

    @property
    def setpoint_start_rad(self) -> float:
        """Where a multicopter's roll-out starts turning its setpoint: where the next setpoint
        turns from (guidance.shape_setpoint: the last one's direction while the nose is apart
        from it, else the nose), so the command flown is the command rolled out."""
        return float(self.nose_rad if self.setpoint_rad is None else self.setpoint_rad)

    @property
    def setpoint_split(self) -> bool:
        """Whether the setpoint turns from elsewhere than the yaw the decision reads: the
        roll-out then turns the two apart, the setpoint's direction from ``setpoint_rad`` and
        the speed's gate (the command's speed falls with the heading's error from the yaw the
        decision reads: union.turn_speed_factor) from ``nose_rad``."""
        return self.setpoint_rad is not None and float(self.setpoint_rad) != float(self.nose_rad)

    def turn_rate_at(self, speed_mps: np.ndarray) -> np.ndarray:
        """The fastest turn of the velocity's direction at each speed (rad/s)."""
        rate = np.full(np.shape(speed_mps), self.max_turn_rate_rad_s)
        if self.max_lateral_accel_mps2 is None:
            return rate
        return np.minimum(rate, self.max_lateral_accel_mps2 / np.maximum(speed_mps, 1e-3))


@dataclass(frozen=True)
class Rollout:
    """Rolled-out paths of J commands: times (N,), positions (J, N, 2), speeds (J, N)."""
    times_s: np.ndarray
    positions: np.ndarray
    speeds: np.ndarray


@functools.lru_cache(maxsize=None)
def step_times(steps: int) -> np.ndarray:
    """(steps,) a roll-out's times, STEP_S * (1 .. steps): made once per length and shared by
    every Rollout of that length, so read-only (a few lengths only: the horizon and the top
    speed's braking steps)."""
    times = STEP_S * np.arange(1, steps + 1)
    times.flags.writeable = False
    return times


def _top_command(commanded: np.ndarray) -> float:
    """``commanded.max(initial=0.0)`` as a float (fly_out's step count); one command is read
    in plain floats: 0.0 unless it is greater, or NaN, as numpy's maximum takes it."""
    if len(commanded) == 1:
        command = float(commanded[0])
        return 0.0 if 0.0 >= command else command
    return float(commanded.max(initial=0.0))


def fly_out(start_ne_m: np.ndarray, motion: Motion, headings_rad: np.ndarray,
            speeds_mps: np.ndarray, horizon_s: float, fov_rad: float) -> Rollout:
    """Roll J commands (headings (J,), speeds (J,)) forward ``horizon_s``, then brake to rest."""
    headings = np.asarray(headings_rad, dtype=float)
    commanded = np.asarray(speeds_mps, dtype=float)
    j = len(headings)
    dv = motion.max_accel_mps2 * STEP_S
    top = max(_top_command(commanded), motion.speed_mps)
    steps = int(math.ceil(horizon_s / STEP_S)) + int(math.ceil(top / max(dv, 1e-9)))
    cruise_steps = int(math.ceil(horizon_s / STEP_S))
    start = np.asarray(start_ne_m, dtype=float)
    if motion.max_lateral_accel_mps2 is not None and motion.nose_rad is not None \
            and motion.max_jerk_mps3 is not None:
        steps += extra_brake_steps(motion.max_accel_mps2, motion.max_jerk_mps3, STEP_S)
        times = step_times(steps)
        if j == 1:
            positions, speeds = fly_copter_shaped_one(start, motion, float(headings[0]),
                                                      float(commanded[0]), steps, cruise_steps,
                                                      fov_rad, STEP_S)
        else:
            positions, speeds = fly_copter_shaped(start, motion, headings, commanded, steps,
                                                  cruise_steps, fov_rad, STEP_S)
        return Rollout(times, positions, speeds)
    times = step_times(steps)
    if motion.max_lateral_accel_mps2 is not None and motion.nose_rad is not None:
        positions, speeds = _fly_copter(start, motion, headings, commanded, steps, cruise_steps,
                                        fov_rad)
        return Rollout(times, positions, speeds)
    if j == 1:
        positions, speeds = _fly_one(start, motion, float(headings[0]), float(commanded[0]),
                                     steps, cruise_steps, fov_rad)
        return Rollout(times, positions, speeds)
    course = np.full(j, motion.course_rad)
    speed = np.full(j, motion.speed_mps)
    north = np.full(j, start[0])
    east = np.full(j, start[1])
    positions = np.empty((j, steps, 2))
    speeds = np.empty((j, steps))
    # The loop runs once per time step on (J,) arrays: plain ufunc calls (np.clip and
    # np.stack cost more in dispatch than in arithmetic here), each the same operation as
    # turn_rate_at, wrap_angles and a clip, so the paths are the same to the last bit. Every
    # constant is a (J,) array: a ufunc on two arrays dispatches in half the time of one with
    # a Python float (the same double each element: the same bits).
    pi_j, two_pi_j = np.full(j, math.pi), np.full(j, TWO_PI)
    half_fov_j, zeros_j, half_j = np.full(j, 0.5 * fov_rad), np.zeros(j), np.full(j, 0.5)
    dv_j, neg_dv_j, step_j = np.full(j, dv), np.full(j, -dv), np.full(j, STEP_S)
    rate = motion.max_turn_rate_rad_s
    lateral = motion.max_lateral_accel_mps2
    if lateral is None:
        limit, neg_limit = np.full(j, rate * STEP_S), np.full(j, -(rate * STEP_S))
    else:
        rate_j, lateral_j, floor_j = np.full(j, rate), np.full(j, lateral), np.full(j, 1e-3)
    add, subtract, multiply, minimum, maximum = np.add, np.subtract, np.multiply, \
        np.minimum, np.maximum
    cos, sin = np.cos, np.sin
    for k in range(steps):
        error = subtract(add(subtract(headings, course), pi_j) % two_pi_j, pi_j)   # wrap_angles
        if k < cruise_steps:
            target = np.where(np.abs(error) > half_fov_j, zeros_j, multiply(commanded, cos(error)))
        else:
            if not speed.any():          # all at rest: nothing moves any more
                positions[:, k:] = positions[:, k - 1:k]
                speeds[:, k:] = 0.0
                break
            target = zeros_j
        new_speed = add(speed, minimum(maximum(subtract(target, speed), neg_dv_j), dv_j))
        mean_speed = multiply(half_j, add(speed, new_speed))
        if lateral is not None:
            limit = multiply(minimum(rate_j, lateral_j / maximum(mean_speed, floor_j)), step_j)
            neg_limit = -limit
        turn = minimum(maximum(error, neg_limit), limit)
        mid = add(course, multiply(half_j, turn))
        step_m = multiply(mean_speed, step_j)
        north = add(north, multiply(step_m, cos(mid)))
        east = add(east, multiply(step_m, sin(mid)))
        course = add(course, turn)
        speed = new_speed
        positions[:, k, 0] = north
        positions[:, k, 1] = east
        speeds[:, k] = speed
    return Rollout(times, positions, speeds)


def _fly_copter(start: np.ndarray, motion: Motion, headings: np.ndarray, commanded: np.ndarray,
                steps: int, cruise_steps: int, fov_rad: float) -> tuple[np.ndarray, np.ndarray]:
    """fly_out for a multicopter, as the truth flies it (truth.step_copter) from the setpoint the
    guidance sends (guidance.shape_setpoint): the setpoint's direction turns toward the command
    at the turn rate from where the next setpoint turns (Motion.setpoint_start_rad: the nose,
    or the last setpoint's direction while the nose is apart from it); its speed is the
    command's scaled by the cosine of the remaining error of the yaw the decision reads
    (``nose_rad``, turning likewise; zero beyond half the view, as union.turn_speed_factor);
    the velocity moves toward that setpoint at the acceleration limit, as a vector. After the
    cruise the setpoint is zero: the vehicle brakes in a straight line, as it does when told to
    stop. Unlike the unicycle's arc, the course does not turn while braking, and the speed is
    not kept up while the velocity turns. positions (J, N, 2), speeds (J, N). One command runs
    in Python floats (_fly_copter_one: the same operations in the same order, the same bits)."""
    if len(headings) == 1:
        return _fly_copter_one(start, motion, float(headings[0]), float(commanded[0]), steps,
                               cruise_steps, fov_rad)
    j = len(headings)
    max_dv = motion.max_accel_mps2 * STEP_S
    max_turn = motion.max_turn_rate_rad_s * STEP_S
    nose = np.full(j, motion.setpoint_start_rad)
    gate, split = np.full(j, float(motion.nose_rad)), motion.setpoint_split
    vel_n = np.full(j, motion.speed_mps * math.cos(motion.course_rad))
    vel_e = np.full(j, motion.speed_mps * math.sin(motion.course_rad))
    north, east = np.full(j, float(start[0])), np.full(j, float(start[1]))
    positions = np.empty((j, steps, 2))
    speeds = np.empty((j, steps))
    for k in range(steps):
        if k < cruise_steps:
            speed, nose, gate = turn_setpoint(headings, commanded, nose, gate, split, max_turn,
                                              fov_rad)
            dv_n, dv_e = speed * np.cos(nose) - vel_n, speed * np.sin(nose) - vel_e
        else:
            if not (vel_n.any() or vel_e.any()):     # all at rest: nothing moves any more
                positions[:, k:] = positions[:, k - 1:k]
                speeds[:, k:] = 0.0
                break
            dv_n, dv_e = -vel_n, -vel_e
        north, east, vel_n, vel_e = accel_limited_step(north, east, vel_n, vel_e, dv_n, dv_e,
                                                       max_dv, positions, speeds, k)
    return positions, speeds


def accel_limited_step(north, east, vel_n, vel_e, dv_n, dv_e, max_dv: float,
                       positions: np.ndarray, speeds: np.ndarray, k: int):
    """One STEP_S of a multicopter's roll-out (arrays of J): the velocity change (dv_n, dv_e)
    limited to max_dv as a vector (as truth.step_copter: limited beyond), the position moved by
    the mean velocity, written into positions[:, k] and speeds[:, k]; returns the new north,
    east, vel_n, vel_e. Shared by _fly_copter and the evasion's roll-out (evade.py)."""
    norm = np.sqrt(dv_n * dv_n + dv_e * dv_e)
    scale = np.where(norm > max_dv, max_dv / np.maximum(norm, 1e-12), 1.0)
    dv_n, dv_e = dv_n * scale, dv_e * scale
    north = north + (vel_n + 0.5 * dv_n) * STEP_S
    east = east + (vel_e + 0.5 * dv_e) * STEP_S
    vel_n, vel_e = vel_n + dv_n, vel_e + dv_e
    positions[:, k, 0] = north
    positions[:, k, 1] = east
    speeds[:, k] = np.sqrt(vel_n * vel_n + vel_e * vel_e)
    return north, east, vel_n, vel_e


def _fly_copter_one(start: np.ndarray, motion: Motion, heading: float, commanded: float,
                    steps: int, cruise_steps: int, fov_rad: float) -> tuple[np.ndarray, np.ndarray]:
    """_fly_copter's loop for one command in Python floats: positions (1, N, 2), speeds (1, N)."""
    max_dv = motion.max_accel_mps2 * STEP_S
    max_turn = motion.max_turn_rate_rad_s * STEP_S
    half_fov, pi, cos, sin, sqrt = 0.5 * fov_rad, math.pi, math.cos, math.sin, math.sqrt
    nose = motion.setpoint_start_rad
    gate, split = float(motion.nose_rad), motion.setpoint_split
    vel_n = motion.speed_mps * cos(motion.course_rad)
    vel_e = motion.speed_mps * sin(motion.course_rad)
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
            dv_n, dv_e = speed * cos(nose) - vel_n, speed * sin(nose) - vel_e
        else:
            if vel_n == 0.0 and vel_e == 0.0:
                path += path[-2:] * (steps - k)
                speeds += [0.0] * (steps - k)
                break
            dv_n, dv_e = -vel_n, -vel_e
        norm = sqrt(dv_n * dv_n + dv_e * dv_e)
        scale = max_dv / norm if norm > max_dv else 1.0
        dv_n, dv_e = dv_n * scale, dv_e * scale
        north = north + (vel_n + 0.5 * dv_n) * STEP_S
        east = east + (vel_e + 0.5 * dv_e) * STEP_S
        vel_n, vel_e = vel_n + dv_n, vel_e + dv_e
        path.append(north)
        path.append(east)
        speeds.append(sqrt(vel_n * vel_n + vel_e * vel_e))
    return np.array(path).reshape(1, steps, 2), np.array(speeds).reshape(1, steps)


def _fly_one(start: np.ndarray, motion: Motion, heading: float, commanded: float, steps: int,
             cruise_steps: int, fov_rad: float) -> tuple[np.ndarray, np.ndarray]:
    """fly_out's loop for one command in Python floats (J = 1 is most calls: the goal heading's
    path; numpy's per-call cost was nearly all of it). The same operations in the same order;
    positions (1, N, 2), speeds (1, N).

    Two shortcuts, both exact: a step's cos and sin are those of the last step when its mid
    course is the same nonzero float (a straight leg: nearly nine steps in ten on dense worlds);
    and once a cruise step leaves course and speed as they were (the same nonzero floats, so the
    same bits), every cruise step after it repeats it, and only the position moves."""
    # Each clip is written as min(max(x, lo), hi) evaluates (max keeps x unless lo > x, min
    # keeps it unless hi < it), without the two builtin calls, and the path is one flat list:
    # the same values, less time.
    dv = motion.max_accel_mps2 * STEP_S
    neg_dv = -dv
    half_fov = 0.5 * fov_rad
    rate = motion.max_turn_rate_rad_s
    lateral = motion.max_lateral_accel_mps2
    pi, cos, sin = math.pi, math.cos, math.sin
    course, speed = float(motion.course_rad), float(motion.speed_mps)
    north, east = float(start[0]), float(start[1])
    path: list[float] = []
    speeds: list[float] = []
    limit = rate * STEP_S
    last_mid = cos_mid = sin_mid = 0.0          # 0.0: never reused (see below)
    k = 0
    while k < steps:
        error = (heading - course + pi) % TWO_PI - pi
        cruising = k < cruise_steps
        if cruising:
            target = 0.0 if abs(error) > half_fov else commanded * cos(error)
        else:
            if speed == 0.0:
                path += path[-2:] * (steps - k)
                speeds += [0.0] * (steps - k)
                break
            target = 0.0
        change = target - speed
        change = neg_dv if neg_dv > change else change
        new_speed = speed + (dv if dv < change else change)
        mean_speed = 0.5 * (speed + new_speed)
        if lateral is not None:
            floor = 1e-3 if 1e-3 > mean_speed else mean_speed
            turn_rate = lateral / floor
            limit = (turn_rate if turn_rate < rate else rate) * STEP_S
        neg_limit = -limit
        turn = neg_limit if neg_limit > error else error
        turn = limit if limit < turn else turn
        mid = course + 0.5 * turn
        if mid != last_mid or mid == 0.0:        # equal nonzero floats: the same bits
            last_mid, cos_mid, sin_mid = mid, cos(mid), sin(mid)
        step_m = mean_speed * STEP_S
        north = north + step_m * cos_mid
        east = east + step_m * sin_mid
        new_course = course + turn
        steady = new_course == course and new_speed == speed and course != 0.0 and speed != 0.0
        course = new_course
        speed = new_speed
        path.append(north)
        path.append(east)
        speeds.append(speed)
        k += 1
        if cruising and steady and k < cruise_steps:
            north, east = _cruise_straight(path, north, east, step_m * cos_mid,
                                           step_m * sin_mid, cruise_steps - k)
            speeds += [speed] * (cruise_steps - k)
            k = cruise_steps
    return np.array(path).reshape(1, steps, 2), np.array(speeds).reshape(1, steps)


def _cruise_straight(path: list[float], north: float, east: float, step_north_m: float,
                     step_east_m: float, count: int) -> tuple[float, float]:
    """_fly_one's steady cruise: ``count`` more steps of the same length along the same course,
    appended to the flat ``path``; returns the last north, east."""
    append = path.append
    for _ in range(count):
        north = north + step_north_m
        east = east + step_east_m
        append(north)
        append(east)
    return north, east


def clearance(rollout: Rollout, obstacles: np.ndarray, radii: np.ndarray,
              velocities: np.ndarray | None = None,
              growth_mps: np.ndarray | None = None,
              start_ne_m: np.ndarray | None = None) -> np.ndarray:
    """(J,) the smallest margin of each path over every obstacle: distance minus radius (m).

    obstacles (n,2) now; radii (n,) the safety distances; velocities (n,2) or None; growth_mps
    (n,) how fast each radius grows with time (a mover's velocity uncertainty), or None.
    Negative: the path enters that safety circle. +inf without obstacles. With ``start_ne_m``
    (where the vehicle is), a circle it is already inside counts only what the path loses beyond
    the present margin: a way out must not be refused for starting inside.
    """
    j = rollout.positions.shape[0]
    if len(obstacles) == 0:
        return np.full(j, np.inf)
    centres, grown = _obstacles_at(rollout.times_s, obstacles, radii, velocities, growth_mps)
    # north and east apart: no (J, N, n, 2) array of gaps
    north = rollout.positions[:, :, 0][:, :, None] - centres[None, :, :, 0]            # (J,N,n)
    east = rollout.positions[:, :, 1][:, :, None] - centres[None, :, :, 1]
    margin = (np.hypot(north, east) - grown[None, :, :]).min(axis=1)                   # (J, n)
    if start_ne_m is not None:
        # after the minimum over time: subtracting a constant keeps the order of the values
        now = np.hypot(*(obstacles - np.asarray(start_ne_m)).T) - radii               # (n,)
        margin = margin - np.minimum(now, 0.0)[None, :]
    return margin.min(axis=1)


def _obstacles_at(times_s: np.ndarray, obstacles: np.ndarray, radii: np.ndarray,
                  velocities: np.ndarray | None, growth_mps: np.ndarray | None
                  ) -> tuple[np.ndarray, np.ndarray]:
    """The obstacles' centres (N, n, 2) and safety radii (N, n) at the roll-out's times (N,); a
    length 1 where they do not change: static centres and ungrown radii as they are. (Adding
    zeros to them, as this once did, can change only a zero's sign: hypot ignores signs, and a
    distance less +0.0 or -0.0 is the same float; the same margins, fewer arrays.)"""
    centres = obstacles[None, :, :] if velocities is None \
        else obstacles[None, :, :] + times_s[:, None, None] * velocities[None, :, :]
    grown = radii[None, :] if growth_mps is None \
        else radii[None, :] + np.minimum(times_s[:, None] * growth_mps[None, :], MAX_GROWTH_M)
    return centres, grown


def margins_by_obstacle(rollout: Rollout, obstacles: np.ndarray, radii: np.ndarray,
                        velocities: np.ndarray | None = None,
                        growth_mps: np.ndarray | None = None
                        ) -> tuple[np.ndarray, np.ndarray]:
    """For one rolled-out path (J = 1): each obstacle's smallest margin (n,) and its time (n,)."""
    t = rollout.times_s
    centres, grown = _obstacles_at(t, obstacles, radii, velocities, growth_mps)
    gaps = rollout.positions[0][:, None, :] - centres
    margin = np.hypot(gaps[..., 0], gaps[..., 1]) - grown                            # (N, n)
    worst = margin.argmin(axis=0)
    return margin.min(axis=0), t[worst]
