"""fly_out's fast paths (plain ufuncs, the one-command loop in floats, the stop once every path
is at rest) against the roll-out written out plainly, step by step: equal to the last bit."""
import math

import numpy as np
import pytest

from companion.core.avoidance.arc import STEP_S, Motion, clearance, fly_out
from companion.core.geometry import wrap_angles


def plain_fly_out(start, motion, headings, commanded, horizon_s, fov_rad):
    dv = motion.max_accel_mps2 * STEP_S
    top = max(float(commanded.max(initial=0.0)), motion.speed_mps)
    cruise_steps = int(math.ceil(horizon_s / STEP_S))
    steps = cruise_steps + int(math.ceil(top / max(dv, 1e-9)))
    course = np.full(len(headings), motion.course_rad)
    speed = np.full(len(headings), motion.speed_mps)
    position = np.tile(start, (len(headings), 1))
    positions, speeds = [], []
    for k in range(steps):
        error = wrap_angles(headings - course)
        target = np.where(np.abs(error) > 0.5 * fov_rad, 0.0, commanded * np.cos(error)) \
            if k < cruise_steps else np.zeros(len(headings))
        new_speed = speed + np.clip(target - speed, -dv, dv)
        mean_speed = 0.5 * (speed + new_speed)
        limit = motion.turn_rate_at(mean_speed) * STEP_S
        turn = np.clip(error, -limit, limit)
        mid = course + 0.5 * turn
        position = position + (mean_speed * STEP_S)[:, None] * np.stack([np.cos(mid), np.sin(mid)], 1)
        course, speed = course + turn, new_speed
        positions.append(position)
        speeds.append(speed)
    return np.stack(positions, 1), np.stack(speeds, 1)


@pytest.mark.parametrize("lateral", [None, 3.0])
@pytest.mark.parametrize("now_mps", [0.0, 4.0, 12.0])
def test_fast_paths_match_the_plain_roll_out(lateral, now_mps):
    rng = np.random.default_rng(7)
    motion = Motion(math.radians(45.0), 2.5, now_mps, 0.4, lateral)
    start = np.array([3.0, -8.0])
    headings = rng.uniform(-math.pi, math.pi, 40)
    for speeds in (np.full(40, 10.0), rng.uniform(0.0, 15.0, 40)):
        plain_positions, plain_speeds = plain_fly_out(start, motion, headings, speeds, 6.0, 1.5)
        batch = fly_out(start, motion, headings, speeds, 6.0, 1.5)
        assert np.array_equal(batch.positions, plain_positions)
        assert np.array_equal(batch.speeds, plain_speeds)
        for k in (0, 17, 39):                    # one command: the loop in Python floats
            p, s = plain_fly_out(start, motion, headings[k:k + 1], speeds[k:k + 1], 6.0, 1.5)
            one = fly_out(start, motion, headings[k:k + 1], speeds[k:k + 1], 6.0, 1.5)
            assert np.array_equal(one.positions, p) and np.array_equal(one.speeds, s)
        assert np.all(batch.speeds[:, -1] == 0.0)


def test_clearance_matches_the_gaps_written_out():
    rng = np.random.default_rng(3)
    motion = Motion(math.radians(45.0), 2.5, 6.0, 0.0, 2.5)
    start = np.zeros(2)
    rolled = fly_out(start, motion, rng.uniform(-3, 3, 30), np.full(30, 8.0), 6.0, 1.5)
    obstacles = np.vstack([rng.uniform(-40, 40, (12, 2)), [[1.0, 1.0]]])   # the last: inside
    radii, velocities = np.full(13, 5.0), rng.uniform(-2, 2, (13, 2))
    growth = rng.uniform(0.0, 1.0, 13)
    t = rolled.times_s
    centres = obstacles[None] + t[:, None, None] * velocities[None]
    grown = radii[None] + np.minimum(t[:, None] * growth[None], 5.0)
    gaps = rolled.positions[:, :, None, :] - centres[None]
    margin = np.hypot(gaps[..., 0], gaps[..., 1]) - grown[None]
    now = np.hypot(*(obstacles - start).T) - radii
    expected = (margin - np.minimum(now, 0.0)[None, None, :]).min(axis=(1, 2))
    assert np.array_equal(clearance(rolled, obstacles, radii, velocities, growth, start), expected)
    assert np.array_equal(clearance(rolled, obstacles, radii, velocities, growth),
                          margin.min(axis=(1, 2)))


def test_first_passing_gives_the_all_at_once_answer():
    from companion.core.avoidance.velocity_choice import _first_passing
    rng = np.random.default_rng(11)
    for _ in range(300):
        k = int(rng.integers(1, 120))
        margins = rng.normal(-1.0 if rng.random() < 0.5 else 0.5, 1.0, k)
        offset = rng.uniform(-math.pi, math.pi, k)
        order = rng.permutation(k)
        skip = int(rng.integers(0, 2))
        ok = order[skip:][margins[order[skip:]] >= 0.0]
        forward = ok[np.abs(offset[ok]) < 0.5 * math.pi]
        first, ahead = _first_passing(order, skip, lambda idx: margins[idx], offset, True)
        assert first == (int(ok[0]) if ok.size else None)
        assert ahead == (int(forward[0]) if forward.size else None)
        first, _ = _first_passing(order, skip, lambda idx: margins[idx], offset, False)
        assert first == (int(ok[0]) if ok.size else None)


def test_one_command_in_floats_is_the_plain_roll_out_on_straight_legs_too():
    """_fly_one's shortcuts (cos and sin kept along a straight leg, a steady cruise repeated):
    random commands, some already flown (heading and speed as commanded, from the first step),
    some at rest or reversing; every position and speed equal to the last bit."""
    rng = np.random.default_rng(29)
    for case in range(300):
        lateral = None if case % 2 else float(rng.uniform(1.0, 4.0))
        course, now_mps = float(rng.uniform(-math.pi, math.pi)), float(rng.uniform(0.0, 12.0))
        motion = Motion(math.radians(rng.uniform(10.0, 90.0)), rng.uniform(1.0, 4.0), now_mps,
                        course, lateral)
        heading, speed = course, now_mps                         # steady from the first step
        if case % 3 == 1:
            heading, speed = float(rng.uniform(-3.2, 3.2)), float(rng.uniform(0.0, 15.0))
        elif case % 3 == 2:
            heading, speed = course + float(rng.choice([0.0, 1e-3, math.pi])), 0.0
        start = rng.uniform(-50.0, 50.0, 2)
        horizon_s, fov = float(rng.uniform(1.0, 8.0)), math.radians(rng.uniform(60.0, 180.0))
        p, s = plain_fly_out(start, motion, np.array([heading]), np.array([speed]), horizon_s, fov)
        one = fly_out(start, motion, np.array([heading]), np.array([speed]), horizon_s, fov)
        assert np.array_equal(one.positions, p) and np.array_equal(one.speeds, s)
