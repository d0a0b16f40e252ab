"""ArduCopter's answer to GUIDED velocity+yaw setpoints, as the service now assumes it:

- the velocity follows a setpoint jerk-limited (core/avoidance/jerk_shaping.py, AC_PosControl's
  shape_vel_accel_xy), pinned against a real ArduCopter 4.6 SITL flight (data/ CSV: the setpoints
  the service sent and the LOCAL_POSITION_NED velocity the autopilot answered);
- the copter roll-out with a jerk limit stops and turns later than without;
- a setpoint's yaw leads a lagging nose (guidance.shape_setpoint's yaw_lead_s), so that a turn
  asked at 30 deg/s is not flown at a fraction of it.
"""
from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np
import pytest

from companion.config.loader import FieldError
from companion.config.service import CommandingConfig
from companion.core.avoidance.arc import VehicleLimits, fly_out
from companion.core.avoidance.guidance import GuidanceCommand, shape_setpoint
from companion.core.avoidance.jerk_shaping import (fly_copter_shaped, fly_copter_shaped_one,
                                                   shaped_step)

FLIGHT = Path(__file__).parent / "data" / "arducopter_guided_velocity.csv"
ACCEL_MPS2, JERK_MPS3 = 2.5, 5.0          # WPNAV_ACCEL, PSC_JERK_XY defaults (copter-4.6.parm)
STEP_S = 0.02


def recorded():
    with FLIGHT.open() as f:
        rows = [r for r in csv.DictReader(line for line in f if not line.startswith("#"))]
    setpoints = [(float(r["t_s"]), float(r["vn_mps"]), float(r["ve_mps"]))
                 for r in rows if r["kind"] == "setpoint"]
    achieved = [(float(r["t_s"]), float(r["vn_mps"]), float(r["ve_mps"]))
                for r in rows if r["kind"] == "achieved"]
    return setpoints, achieved


def replay_rms_mps(shaped: bool, delay_s: float = 0.0) -> float:
    """Fly the recorded setpoints (each held until the next, ``delay_s`` late) from the first
    achieved velocity; RMS error against what ArduCopter flew."""
    setpoints, achieved = recorded()
    t = achieved[0][0]
    vel = np.array(achieved[0][1:]).reshape(2, 1)
    acc = np.zeros((2, 1))
    pos = np.zeros((2, 1))
    i, errors = 0, []
    for t_a, vn, ve in achieved[1:]:
        while t < t_a - 1e-9:
            while i + 1 < len(setpoints) and setpoints[i + 1][0] <= t - delay_s:
                i += 1
            target = setpoints[i][1:] if setpoints[i][0] <= t - delay_s else (0.0, 0.0)
            if shaped:
                pos[0], pos[1], vel[0], vel[1], acc[0], acc[1] = shaped_step(
                    pos[0], pos[1], vel[0], vel[1], acc[0], acc[1], np.array([target[0]]),
                    np.array([target[1]]), ACCEL_MPS2, JERK_MPS3, STEP_S)
            else:                           # the stub's truth: within max_accel at once
                dv = np.array(target).reshape(2, 1) - vel
                norm = float(np.hypot(dv[0, 0], dv[1, 0]))
                vel = vel + dv * min(1.0, ACCEL_MPS2 * STEP_S / max(norm, 1e-12))
            t += STEP_S
        errors.append(math.hypot(vel[0, 0] - vn, vel[1, 0] - ve))
    return float(np.sqrt(np.mean(np.square(errors))))


def test_the_jerk_limited_model_flies_arducopters_velocity_the_unshaped_one_does_not():
    shaped, unshaped = replay_rms_mps(True), replay_rms_mps(False)
    assert shaped < 0.2, shaped              # 0.14 m/s RMS over 62 s of flight
    assert unshaped > 2.5 * shaped, (shaped, unshaped)          # 0.47 m/s
    # nor is the unshaped step a pure delay of ArduCopter's answer
    assert min(replay_rms_mps(False, d) for d in (0.2, 0.3, 0.5)) > 1.5 * shaped


def test_shaped_acceleration_stays_within_its_limit_and_changes_within_the_jerk():
    north = east = np.zeros(1)
    vel_n, vel_e = np.array([5.0]), np.zeros(1)
    acc_n = acc_e = np.zeros(1)
    previous = np.zeros(2)
    travelled, dt = 0.0, 0.05
    for _ in range(200):                     # 10 s: a stop from 5 m/s
        north, east, vel_n, vel_e, acc_n, acc_e = shaped_step(
            north, east, vel_n, vel_e, acc_n, acc_e, np.zeros(1), np.zeros(1), ACCEL_MPS2,
            JERK_MPS3, dt)
        acc = np.array([acc_n[0], acc_e[0]])
        assert np.hypot(*acc) <= ACCEL_MPS2 + 1e-9
        assert np.hypot(*(acc - previous)) <= JERK_MPS3 * dt + 1e-9
        previous = acc
    travelled = float(north[0])
    assert abs(vel_n[0]) < 0.05
    # at the acceleration limit at once it would stop in v^2 / 2a = 5 m; the ramp costs more
    assert 5.5 < travelled < 7.5, travelled


def test_a_jerk_limited_roll_out_brakes_and_turns_later():
    fov = math.radians(87.0)
    plain = VehicleLimits(math.radians(30.0), ACCEL_MPS2, lateral_accel_limited=True)
    jerky = VehicleLimits(math.radians(30.0), ACCEL_MPS2, lateral_accel_limited=True,
                          max_jerk_mps3=JERK_MPS3)
    start = np.zeros(2)
    stops = [fly_out(start, lim.motion(5.0, 0.0, 0.0), np.array([0.0]), np.array([0.0]), 0.0, fov)
             for lim in (plain, jerky)]
    assert stops[1].positions[0, -1, 0] > stops[0].positions[0, -1, 0] + 0.5
    assert stops[1].speeds[0, -1] < 0.1
    turns = [fly_out(start, lim.motion(5.0, 0.0, 0.0), np.array([math.radians(40.0)]),
                     np.array([5.0]), 4.0, fov) for lim in (plain, jerky)]
    one_s = 3                                # 1 s at the roll-out's 0.25 s step
    assert turns[1].positions[0, one_s, 1] < turns[0].positions[0, one_s, 1]


def test_one_commands_shaped_roll_out_in_floats_is_the_arrays_bit_for_bit():
    """fly_copter_shaped_one (J = 1, Python floats) against fly_copter_shaped (numpy, the same
    command as the first of two): random motions, commands and limits, every position and speed
    equal to the last bit, so a candidate's margin never depends on how many were rolled."""
    rng = np.random.default_rng(7)
    for _ in range(200):
        lim = VehicleLimits(math.radians(rng.uniform(10.0, 90.0)), rng.uniform(1.0, 4.0),
                            lateral_accel_limited=True, max_jerk_mps3=rng.uniform(2.0, 8.0))
        setpoint = rng.uniform(-3.0, 3.0) if rng.random() < 0.5 else None    # split, or not
        motion = lim.motion(rng.uniform(0.0, 10.0), rng.uniform(-3.0, 3.0), rng.uniform(-3.0, 3.0),
                            setpoint)
        heading, speed = rng.uniform(-3.2, 3.2), rng.uniform(0.0, 10.0)
        start, fov = rng.uniform(-50.0, 50.0, 2), math.radians(rng.uniform(60.0, 120.0))
        many = fly_copter_shaped(start, motion, np.array([heading, heading + 1.0]),
                                 np.array([speed, 1.0]), 40, 24, fov, 0.25)
        one = fly_copter_shaped_one(start, motion, heading, speed, 40, 24, fov, 0.25)
        assert np.array_equal(one[0], many[0][:1]) and np.array_equal(one[1], many[1][:1])
    lim = VehicleLimits(math.radians(30.0), ACCEL_MPS2, lateral_accel_limited=True,
                        max_jerk_mps3=JERK_MPS3)
    rolled = fly_out(np.zeros(2), lim.motion(5.0, 0.0, 0.0), np.array([0.7]), np.array([5.0]),
                     4.0, math.radians(87.0))                      # fly_out takes the float path
    both = fly_out(np.zeros(2), lim.motion(5.0, 0.0, 0.0), np.array([0.7, 0.0]),
                   np.array([5.0, 5.0]), 4.0, math.radians(87.0))
    assert np.array_equal(rolled.positions[0], both.positions[0])


def turn(yaw_lead_s, nose_follows: bool):
    """Ten setpoints at 10 Hz toward a heading 90 degrees right; the nose stays put (an autopilot
    lagging far behind) or reaches each setpoint's yaw (the stub)."""
    command = GuidanceCommand(5.0, math.radians(90.0), "avoid")
    nose, last, yaws = 0.0, None, []
    for _ in range(10):
        last = shape_setpoint(nose, last, command, math.radians(30.0), 0.1, 8.0, yaw_lead_s)
        yaws.append(math.degrees(last.yaw_rad))
        if nose_follows:
            nose = last.yaw_rad
    return yaws


def test_a_setpoints_yaw_leads_a_lagging_nose_by_at_most_the_lead():
    assert turn(None, nose_follows=False) == pytest.approx([3.0] * 10)   # asks 3 deg ahead, ever
    led = turn(0.5, nose_follows=False)
    assert led[:5] == pytest.approx([3.0, 6.0, 9.0, 12.0, 15.0])        # 30 deg/s on
    assert max(led) == pytest.approx(15.0 + 3.0)                         # 0.5 s x 30 deg/s, + a step
    # a nose that reaches each yaw (the stub's): the lead changes nothing
    assert turn(0.5, nose_follows=True) == pytest.approx(turn(None, nose_follows=True))


@pytest.mark.parametrize("key,value", [("max_jerk_mps3", 0.0), ("max_jerk_mps3", -5.0),
                                       ("max_jerk_mps3", math.inf), ("yaw_lead_s", -0.1),
                                       ("yaw_lead_s", 3.0), ("yaw_lead_s", math.nan)])
def test_an_implausible_jerk_or_yaw_lead_is_refused_by_name(key, value):
    with pytest.raises(FieldError, match=key):
        CommandingConfig(**{key: value})
