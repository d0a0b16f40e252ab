"""The look round after a start in the air (companion/onboard/look_around.py, issue 31)."""
from __future__ import annotations

import math

import pytest

from companion.core.geometry import wrap_angle
from companion.onboard.look_around import DONE, LOOKING, LookAround, LookAroundParams


def fly(look: LookAround, yaw_rad: float, speed_mps: float = 0.0, turn_rad_s: float = 1.0,
        dt_s: float = 0.1, until_s: float = 60.0):
    """Decisions every dt_s; the vehicle turns toward each target at turn_rad_s (as a
    multicopter turns to a yaw target); returns the targets' history and the yaws seen."""
    t_s, yaws, targets = 0.0, [yaw_rad], []
    while t_s < until_s:
        step = look.next_yaw(t_s, yaw_rad, speed_mps)
        if step is None:
            break
        targets.append(step)
        err = wrap_angle(step.yaw_rad - yaw_rad)
        yaw_rad = wrap_angle(yaw_rad + max(-turn_rad_s * dt_s, min(turn_rad_s * dt_s, err)))
        yaws.append(yaw_rad)
        t_s += dt_s
    return t_s, targets, yaws


def test_a_flight_seen_from_the_ground_never_looks_round():
    look = LookAround(LookAroundParams())
    look.on_heartbeat(False)
    look.on_heartbeat(True)
    assert look.next_yaw(0.0, 0.3, 0.0) is None and look.state == DONE
    assert look.started_t_s is None and look.end_reason == "not needed"


def test_disabled_never_looks_round():
    look = LookAround(LookAroundParams(enabled=False))
    look.on_heartbeat(True)
    assert look.next_yaw(0.0, 0.3, 0.0) is None


def test_joined_armed_it_holds_and_turns_a_full_circle_then_flies_on():
    params = LookAroundParams(step_rad=math.radians(60.0), dwell_s=0.5)
    look = LookAround(params)
    look.on_heartbeat(True)
    start = math.radians(-10.0)
    t_end, targets, yaws = fly(look, start)
    assert look.state == DONE and look.end_reason == "full circle"
    # six steps, each less than 180 deg from the last (the autopilot turns the short way)
    assert [s.step for s in targets][0] == 1 and max(s.step for s in targets) == 6
    distinct = []
    for s in targets:
        if not distinct or distinct[-1] != s.yaw_rad:
            distinct.append(s.yaw_rad)
    assert len(distinct) == 6
    for a, b in zip([start] + distinct, distinct):
        assert abs(wrap_angle(b - a)) < math.pi - 0.1
    # the nose went all the way round: the turned angle adds up to a circle, ending where it began
    turned = sum(wrap_angle(b - a) for a, b in zip(yaws, yaws[1:]))
    assert turned > 2.0 * math.pi - params.yaw_tolerance_rad
    assert abs(wrap_angle(yaws[-1] - start)) <= params.yaw_tolerance_rad
    # and it dwelt at each step: at least 6 x dwell on top of the turning (2 pi at 1 rad/s)
    assert t_end >= 2.0 * math.pi / 1.0 + 6 * params.dwell_s - 1.0


def test_a_moving_vehicle_is_braked_before_the_turn_begins():
    look = LookAround(LookAroundParams())
    look.on_heartbeat(True)
    step = look.next_yaw(0.0, 0.5, 3.0)
    assert step is not None and step.step == 0 and step.yaw_rad == 0.5 and look.state == LOOKING
    step = look.next_yaw(0.1, 0.5, 0.2)
    assert step.step == 1 and abs(wrap_angle(step.yaw_rad - 0.5 - math.pi / 3.0)) < 1e-9


def test_a_yaw_that_never_settles_ends_on_the_timeout():
    look = LookAround(LookAroundParams(timeout_s=5.0))
    look.on_heartbeat(True)
    t_end, targets, _ = fly(look, 0.0, turn_rad_s=0.0)        # the nose does not move
    assert look.end_reason == "timeout" and 5.0 <= t_end <= 5.3


def test_after_the_circle_it_steps_back_nose_first_until_clear_of_the_nearest_obstacle():
    params = LookAroundParams(clear_m=15.0, back_off_speed_mps=1.0, dwell_s=0.0)
    look = LookAround(params)
    look.on_heartbeat(True)
    post = (8.0, 8.9)                          # ArduCopter's stop, 12 m from the second post
    t_s, yaw, north, east, steps = 0.0, 0.0, 0.0, 0.0, []
    while t_s < 60.0:
        rel = (post[0] - north, post[1] - east)
        step = look.next_yaw(t_s, yaw, 0.0, rel)
        if step is None:
            break
        steps.append(step)
        if step.step > step.steps:             # the step back: at the commanded velocity
            north += step.vel_north_mps * 0.1
            east += step.vel_east_mps * 0.1
        yaw = step.yaw_rad                     # (an instant turn: this test is about the order)
        t_s += 0.1
    backs = [s for s in steps if s.step > s.steps]
    assert backs and all(s.step <= s.steps for s in steps[:len(steps) - len(backs)])
    away = math.atan2(-post[1], -post[0])
    assert all(abs(wrap_angle(s.yaw_rad - away)) < 1e-9 for s in backs)           # nose first
    assert all(math.hypot(s.vel_north_mps, s.vel_east_mps) == pytest.approx(1.0) for s in backs)
    assert math.hypot(post[0] - north, post[1] - east) >= 15.0 - 0.11
    assert look.end_reason == "full circle, backed off"
    assert look.backed_off_m == pytest.approx(math.hypot(*post))


def test_nothing_near_no_step_back():
    look = LookAround(LookAroundParams(dwell_s=0.0))
    look.on_heartbeat(True)
    t_s, yaw = 0.0, 0.0
    while (step := look.next_yaw(t_s, yaw, 0.0, (30.0, 0.0))) is not None:
        assert step.step <= step.steps and (step.vel_north_mps, step.vel_east_mps) == (0.0, 0.0)
        yaw, t_s = step.yaw_rad, t_s + 0.1
    assert look.end_reason == "full circle" and look.backed_off_m is None


def test_the_pipeline_joining_an_armed_vehicle_holds_and_turns_before_guidance():
    from companion.mavlink import codec
    from companion.onboard.pipeline import Pipeline
    from tests.service.test_pipeline import GOAL, Feed, hb, setpoints
    from companion.config.service import load_config
    feed = Feed(Pipeline(load_config("config/companion.yaml"), GOAL, record_track=True))
    feed.send(hb())                                  # the first heartbeat: armed, GUIDED
    feed.send(codec.ObstacleFrame(1, 100, feed.t_s, ()))
    for _ in range(20):
        feed.step(speed_mps=0.0)
    sps = setpoints(feed.outputs)
    assert sps and all(sp.reason == "hold: look around" for sp in sps)
    assert all((sp.vel_north_mps, sp.vel_east_mps) == (0.0, 0.0) for sp in sps)
    assert abs(wrap_angle(sps[-1].yaw_rad - math.radians(60.0))) < 1e-6   # the first step
    assert feed.p.look_around.active
