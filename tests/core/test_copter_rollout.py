"""Issue 16 at 10-15 m/s on the multicopter: the velocity choice's roll-out (arc.fly_out) is the
path the multicopter flies (truth.step_copter from guidance.shape_setpoint's setpoints), not the
unicycle's arc: its nose turns at the turn rate ahead of a velocity that turns within the
acceleration limit, the speed setpoint follows the nose, and told to stop it brakes straight."""
import math

import numpy as np
import pytest

from companion.config.scenario import load_scenario
from companion.core.avoidance.arc import VehicleLimits, clearance, fly_out
from companion.core.avoidance.guidance import (GuidanceCommand, ShapedSetpoint, limit_turn,
                                               shape_setpoint)
from companion.core.avoidance.union import turn_speed_factor
from companion.sim.simulation import make_navigator
from companion.sim.truth import TruthWorld

FOV = math.radians(90.0)
HORIZON_S = 4.0


@pytest.fixture(scope="module")
def copter():
    return load_scenario("config/scenarios/copter.yaml")


def flown(scenario, speed, course, nose, heading, cruise, horizon_s=HORIZON_S, total_s=12.0):
    """The truth multicopter's path from the origin: (speed, course) now, the nose at ``nose``,
    the command (cruise, heading) held for ``horizon_s`` (its speed scaled by the nose's error at
    every decision, as the velocity choice does), then a stop; positions every 0.1 s."""
    truth = TruthWorld(scenario, np.random.default_rng(0))
    truth.pose = np.array([0.0, 0.0, nose])
    truth.vel_ne_mps = speed * np.array([math.cos(course), math.sin(course)])
    vehicle = scenario.vehicle
    shaped, path = None, []
    for step in range(round(total_s / vehicle.dt_s)):
        t = step * vehicle.dt_s
        factor = turn_speed_factor(truth.pose[2], heading, FOV) if t < horizon_s - 1e-9 else 0.0
        command = GuidanceCommand(cruise * factor, heading, "avoid")
        shaped = shape_setpoint(truth.pose[2], shaped, command, vehicle.max_turn_rate_rad_s,
                                vehicle.dt_s, math.inf)
        truth.step_copter(shaped.speed_mps * np.array([math.cos(shaped.course_rad),
                                                       math.sin(shaped.course_rad)]),
                          shaped.yaw_rad)
        path.append(truth.pose[:2].copy())
    return np.array(path)


def rolled(scenario, speed, course, nose, heading, cruise):
    vehicle = scenario.vehicle
    limits = VehicleLimits(vehicle.max_turn_rate_rad_s, vehicle.max_accel_mps2,
                           lateral_accel_limited=True)
    return fly_out(np.zeros(2), limits.motion(speed, course, nose), np.array([heading]),
                   np.array([cruise]), HORIZON_S, FOV)


@pytest.mark.parametrize("speed, course_deg, nose_deg, heading_deg, cruise", [
    (7.3, 48.0, 77.0, 105.0, 10.0),      # dense seed 7 at 10 m/s: the nose 30 deg ahead
    (10.0, 0.0, 0.0, 60.0, 10.0),        # a sharp turn at cruise
    (15.0, 0.0, 0.0, 40.0, 15.0),
    (15.0, 0.0, 0.0, -100.0, 15.0),      # beyond the view: the nose turns, the speed falls
])
def test_the_roll_out_is_the_path_the_multicopter_flies(copter, speed, course_deg, nose_deg,
                                                        heading_deg, cruise):
    course, nose, heading = (math.radians(a) for a in (course_deg, nose_deg, heading_deg))
    roll = rolled(copter, speed, course, nose, heading, cruise)
    truth = flown(copter, speed, course, nose, heading, cruise)
    t_truth = copter.vehicle.dt_s * np.arange(1, len(truth) + 1)
    at = np.stack([np.interp(roll.times_s, t_truth, truth[:, i]) for i in (0, 1)], axis=1)
    error = np.hypot(*(roll.positions[0] - at).T)
    assert error.max() < 2.0          # 0.2-1.5 m; the unicycle's arc was 2.7 to 20 m off these


def test_a_stop_is_a_straight_brake_not_a_turn_away(copter):
    # 10 m/s north, a post 16 m ahead and 7 m to the right: braking straight (what a zero
    # setpoint flies) passes 7 m from it, inside d = 10 m; the unicycle's arc turned left while
    # braking and called a stop toward the west safe.
    post, d = np.array([[16.0, 7.0]]), np.array([10.0])
    stop = rolled(copter, 10.0, 0.0, 0.0, -math.pi / 2, 0.0)
    truth = flown(copter, 10.0, 0.0, 0.0, -math.pi / 2, 0.0, horizon_s=0.0)
    truth_margin = float(np.min(np.hypot(*(truth - post[0]).T)) - d[0])
    assert truth_margin < -2.0
    assert float(clearance(stop, post, d)[0]) == pytest.approx(truth_margin, abs=0.5)


@pytest.mark.parametrize("setpoint_rad", [None, -0.3])     # the setpoint turning from the nose,
def test_one_command_alone_rolls_out_to_the_same_bits_as_among_many(copter, setpoint_rad):
    headings = np.radians([-170.0, -100.0, -44.0, 0.0, 30.0, 46.0, 105.0])  # or from elsewhere
    speeds = np.array([15.0, 10.0, 10.0, 0.0, 7.5, 10.0, 12.0])
    vehicle = copter.vehicle
    motion = VehicleLimits(vehicle.max_turn_rate_rad_s, vehicle.max_accel_mps2,
                           lateral_accel_limited=True).motion(8.0, 0.4, 0.9, setpoint_rad)
    many = fly_out(np.array([3.0, -2.0]), motion, headings, speeds, HORIZON_S, FOV)
    for i, (heading, speed) in enumerate(zip(headings, speeds)):
        one = fly_out(np.array([3.0, -2.0]), motion, np.array([heading]), np.array([speed]),
                      HORIZON_S, FOV)
        n = len(one.times_s)       # fewer steps at a lower top speed: stopped by then
        assert np.array_equal(one.positions[0], many.positions[i, :n])
        assert np.array_equal(one.speeds[0], many.speeds[i, :n])
        assert np.all(many.positions[i, n:] == one.positions[0, -1])
        assert one.speeds[0, -1] == pytest.approx(0.0, abs=1e-9)


def flown_from(scenario, last, speed, course, nose, heading, cruise, look_rad, read_rad):
    """As ``flown``, but after the setpoint ``last``, with the nose held at ``look_rad``; the
    command's speed scaled by the heading's error from the yaw the decision reads, ``read_rad``
    now, turning toward the heading at the turn rate (the roll-out's speed gate)."""
    truth = TruthWorld(scenario, np.random.default_rng(0))
    truth.pose = np.array([0.0, 0.0, nose])
    truth.vel_ne_mps = speed * np.array([math.cos(course), math.sin(course)])
    vehicle, path = scenario.vehicle, []
    for step in range(round(12.0 / vehicle.dt_s)):
        factor = turn_speed_factor(read_rad, heading, FOV) \
            if step * vehicle.dt_s < HORIZON_S - 1e-9 else 0.0
        read_rad += limit_turn(read_rad, heading, vehicle.max_turn_rate_rad_s, vehicle.dt_s)
        command = GuidanceCommand(cruise * factor, heading, "avoid", yaw_rad=look_rad)
        last = shape_setpoint(truth.pose[2], last, command, vehicle.max_turn_rate_rad_s,
                              vehicle.dt_s, math.inf)
        truth.step_copter(last.speed_mps * np.array([math.cos(last.course_rad),
                                                     math.sin(last.course_rad)]), last.yaw_rad)
        path.append(truth.pose[:2].copy())
    return np.array(path)


def test_after_a_stop_turned_apart_the_roll_out_starts_where_the_setpoint_turns_from(copter):
    # forest-dense 7 m/s seed 12 at 117.4 s: braking at 3 m/s along -102 deg, the nose held
    # at -160 by the goal look, the stop's setpoint direction turned on to -135; asked for
    # 4.4 m/s at -72. The next setpoint turns from -135 (guidance.shape_setpoint, apart): rolled
    # out from there the path is the one flown; from the velocity the decision read, it was
    # metres off (the command flown toward a trunk was not the one rolled out).
    speed, course, nose, turned, heading = (3.0, *np.radians([-102.0, -160.0, -135.0, -72.0]))
    last = ShapedSetpoint(turned, 0.3, nose, apart=True)
    truth = flown_from(copter, last, speed, course, nose, heading, 4.4, nose, course)
    t_truth = copter.vehicle.dt_s * np.arange(1, len(truth) + 1)
    vehicle = copter.vehicle
    limits = VehicleLimits(vehicle.max_turn_rate_rad_s, vehicle.max_accel_mps2,
                           lateral_accel_limited=True)
    errors = {}
    for name, motion in (("setpoint", limits.motion(speed, course, course, turned)),
                         ("velocity", limits.motion(speed, course, course))):
        roll = fly_out(np.zeros(2), motion, np.array([heading]), np.array([4.4]), HORIZON_S,
                       FOV)
        at = np.stack([np.interp(roll.times_s, t_truth, truth[:, i]) for i in (0, 1)], axis=1)
        errors[name] = float(np.hypot(*(roll.positions[0] - at).T).max())
    assert errors["setpoint"] < 0.5            # 0.07 m
    assert errors["velocity"] > 2.0            # 3.0 m: the roll-out before the fix


def test_the_decision_rolls_out_from_the_last_setpoint_while_the_nose_is_apart(copter):
    nav = make_navigator(copter)
    nav.on_velocity(0.0, 5.0, 0.0, 0.0, 0.0)
    pose = nav.slam.pose
    assert nav.decider._motion(pose).setpoint_start_rad == pytest.approx(float(pose[2]))
    nav.on_setpoint(ShapedSetpoint(0.7, 2.0, 0.0, apart=True))
    assert nav.decider._motion(pose).setpoint_start_rad == 0.7
    assert nav.decider._motion(pose).nose_rad == pytest.approx(float(pose[2]))   # the camera's
    nav.on_setpoint(ShapedSetpoint(0.05, 2.0, 0.0, apart=False))
    assert nav.decider._motion(pose).setpoint_start_rad == pytest.approx(float(pose[2]))
