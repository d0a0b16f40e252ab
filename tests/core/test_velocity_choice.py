"""Issue 16: guidance chooses a velocity the vehicle can fly (arc.py, velocity_choice.py)."""
import math

import numpy as np
import pytest

from companion.core.avoidance.arc import Motion, clearance, fly_out
from companion.core.geometry import wrap_angles
from companion.core.avoidance.guidance import GuidanceInputs, GuidanceParams
from companion.core.avoidance.union import UnionParams, guide_union, sensed_speed_limit
from companion.core.avoidance.velocity_choice import gate_headings, guide_flyable

D = 10.0
RATE = math.radians(30.0)
UNION = UnionParams(lookahead_s=6.0, hysteresis=0.5, fov_rad=math.radians(90))
GOAL = np.array([300.0, 0.0])
POSE = np.array([0.0, 0.0, 0.0])


def params(cruise: float) -> GuidanceParams:
    return GuidanceParams(cruise_speed_mps=cruise, safety_distance_m=D, horizon_s=4.0, eta=1.25,
                          goal_radius_m=2.0)


def flying(speed: float, course: float = 0.0) -> Motion:
    return Motion(RATE, 2.5, speed, course)


def flown_margin(command, motion, obstacles, velocities=None):
    rolled = fly_out(POSE[:2], motion, np.array([command.heading_rad]),
                     np.array([command.speed_mps]), UNION.lookahead_s, UNION.fov_rad)
    return float(clearance(rolled, obstacles, np.full(len(obstacles), D), velocities)[0])


def test_fly_out_never_turns_or_accelerates_beyond_the_limits():
    motion = Motion(RATE, 2.5, 12.0, 0.3, max_lateral_accel_mps2=2.5)
    headings = np.linspace(-math.pi, math.pi, 13)
    rolled = fly_out(np.zeros(2), motion, headings, np.full(13, 15.0), 6.0, math.radians(90))
    steps = np.diff(np.concatenate([np.zeros((13, 1, 2)), rolled.positions], axis=1), axis=1)
    course = np.arctan2(steps[..., 1], steps[..., 0])
    length = np.hypot(steps[..., 0], steps[..., 1])
    moving = (length[:, 1:] > 0.1) & (length[:, :-1] > 0.1)   # a turn on the spot has no chord
    turn = np.abs(wrap_angles(np.diff(course, axis=1)))[moving]
    speed = np.concatenate([np.full((13, 1), 12.0), rolled.speeds], axis=1)
    dt = rolled.times_s[0]
    assert np.all(np.abs(np.diff(speed, axis=1)) <= 2.5 * dt + 1e-9)
    # the multicopter's velocity turns within min(turn rate, a / v); never beyond the turn rate
    assert turn.max() <= RATE * dt + 1e-9
    assert rolled.speeds[:, -1] == pytest.approx(0.0)             # every roll-out ends stopped


def test_no_turn_demanded_that_the_turn_rate_cannot_fly():
    # At 15 m/s (radius 29 m) two posts 30 to 35 m ahead either side of the path: the
    # heading-only law takes a free heading at nearly full speed, and the arc that reaches it at
    # 30 deg/s cuts a safety circle by 2.6 m; the velocity choice only commands what it can fly.
    obstacles = np.array([[30.0, 6.0], [34.0, -12.0]])
    heading_only = guide_union(GuidanceInputs(POSE, GOAL, obstacles, None, None), params(15.0),
                                              UNION)
    assert flown_margin(heading_only, flying(15.0), obstacles) < -2.0
    chosen = guide_flyable(GuidanceInputs(POSE, GOAL, obstacles, None, None, motion=flying(15.0)),
                                          params(15.0), UNION)
    assert flown_margin(chosen, flying(15.0), obstacles) >= 0.0
    assert chosen.mode != "goal" and chosen.speed_mps < heading_only.speed_mps


def test_slows_when_the_free_heading_needs_a_tighter_turn():
    # Three posts 21 to 43 m ahead: no arc at 15 m/s clears them by d, one at 3 m/s does.
    obstacles = np.array([[43.0, -7.0], [21.0, -20.0], [23.0, 5.0]])
    chosen = guide_flyable(GuidanceInputs(POSE, GOAL, obstacles, None, None, motion=flying(15.0)),
                                          params(15.0), UNION)
    assert chosen.speed_mps < 15.0
    assert flown_margin(chosen, flying(15.0), obstacles) >= 0.0


def test_stops_when_nothing_is_free_and_accelerates_back():
    ring = np.array([[14.0 * math.cos(a), 14.0 * math.sin(a)]
                     for a in np.linspace(-math.pi, math.pi, 12, endpoint=False)])
    boxed = guide_flyable(GuidanceInputs(POSE, GOAL, ring, None, None, motion=flying(2.0)),
                                         params(10.0), UNION)
    assert boxed.speed_mps == 0.0 and boxed.mode in ("slow", "stop", "hold")
    free = guide_flyable(GuidanceInputs(POSE, GOAL, ring + np.array([400.0, 0.0]), None, None,
                                        motion=flying(0.0)), params(10.0), UNION)
    assert free.mode == "goal" and free.speed_mps == pytest.approx(10.0)


def test_never_outruns_the_camera():
    # stops d short of the camera's 40 m range: sqrt(2 * 2.5 * 30) = 12.2 m/s
    assert sensed_speed_limit(40.0, D, 2.5) == pytest.approx(math.sqrt(150.0))
    union = UnionParams(lookahead_s=6.0, fov_rad=math.radians(90), sensor_range_m=40.0)
    command = guide_flyable(GuidanceInputs(POSE, GOAL, np.empty((0, 2)), None, None,
                                           motion=flying(15.0)), params(15.0), union)
    assert command.speed_mps == pytest.approx(math.sqrt(150.0))


def test_the_camera_limit_counts_the_time_a_new_obstacle_stays_tentative():
    """A landmark stays out of the guidance until confirmed (up to 5 frames at 5 Hz: 1 s): the
    vehicle flies that second before it brakes, so v t + v^2 / 2a = range - d: 10 m/s here."""
    v = sensed_speed_limit(40.0, D, 2.5, perception_delay_s=1.0)
    assert v * 1.0 + v * v / (2 * 2.5) == pytest.approx(40.0 - D)
    assert v == pytest.approx(10.0) and v < sensed_speed_limit(40.0, D, 2.5)


def test_a_tracked_crossing_mover_behind_the_camera_is_avoided():
    # A mover 120 degrees off the nose (out of a 90 degree camera's view), 20 m away, crossing
    # at 4.5 m/s so as to meet the vehicle flying straight: kept in the decision by its track,
    # the chosen velocity keeps d from where it will be; taken as static it would not.
    mover = np.array([[-10.0, 17.3]])
    # where the vehicle flying north at 5 m/s meets it: both at (20, 0) after 4 s
    velocity = (np.array([20.0, 0.0]) - mover[0]) / 4.0
    velocities = velocity[None, :]
    motion = flying(5.0)
    straight = guide_flyable(GuidanceInputs(POSE, GOAL, mover, None, None, motion=motion),
                                            params(5.0), UNION)
    assert flown_margin(straight, motion, mover, velocities) < 0.0        # static: no threat
    chosen = guide_flyable(GuidanceInputs(POSE, GOAL, mover, None, None, velocities=velocities,
                                          motion=motion, growth_mps=np.array([0.3])), params(5.0), UNION)
    assert chosen.mode != "goal" and chosen.urgent_index == 0
    assert flown_margin(chosen, motion, mover, velocities) >= 0.0


def test_time_to_closest_approach_ranks_the_threats():
    # A static post 60 m ahead and a head-on mover 90 m ahead at 5 m/s: both on the path, the
    # mover's closest approach comes first (9 s against 12 s at 5 m/s).
    obstacles = np.array([[60.0, 0.0], [90.0, 0.0]])
    velocities = np.array([[0.0, 0.0], [-5.0, 0.0]])
    union = UnionParams(lookahead_s=12.0, fov_rad=math.radians(90))
    command = guide_flyable(GuidanceInputs(POSE, GOAL, obstacles, None, None,
                                           velocities=velocities, motion=flying(5.0)), params(5.0), union)
    assert command.urgent_index == 1


def test_gate_headings_find_the_gap_in_a_wall_of_posts():
    wall = [np.array([50.0, e]) for e in np.arange(-40.0, -10.0, 4.0)] \
        + [np.array([50.0, e]) for e in np.arange(12.0, 41.0, 4.0)]
    obstacles = np.array(wall)                  # the gap: posts at -12 and 12, 24 m apart
    headings = gate_headings(POSE[:2], obstacles, np.full(len(obstacles), D), 2.0)
    assert headings == pytest.approx([0.0], abs=1e-9)
    assert gate_headings(POSE[:2], obstacles, np.full(len(obstacles), D), 5.0).size == 0
