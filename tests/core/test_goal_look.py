"""The multicopter's look toward the goal (core/avoidance/look_at.py goal_look_yaw, avoidance.goal_look_deg):
while the velocity swerves, the nose turns back toward the goal's direction; only the yaw."""
import dataclasses
import math

import numpy as np
import pytest

from companion.sim import simulation
from companion.config.scenario import load_scenario
from companion.config.service import load_config
from companion.config.world import Goal, Obstacle, StartPose
from companion.core.geometry import wrap_angle
from companion.core.avoidance.look_at import GoalLookParams, goal_look_yaw
from companion.core.navigation.decider import Decider
from companion.errors import ConfigError
from companion.onboard.pipeline import Pipeline
from companion.sim.simulation import run_once

COPTER = "config/scenarios/copter.yaml"
COPTER_TEXT = open(COPTER).read()
COMPANION_TEXT = open("config/companion.yaml").read()
LOOK = GoalLookParams(math.radians(30.0))


# ------------------------------------------------------------------ the rule
@pytest.mark.parametrize("course_deg, goal_deg, nose_deg", [
    (20.0, 0.0, 0.0),        # swerved 20 right: the nose back on the goal
    (-12.0, 0.0, 0.0),
    (50.0, 0.0, 20.0),       # swerved 50: at most 30 from the flight direction
    (-50.0, 0.0, -20.0),
    (170.0, -170.0, -170.0),   # across +-180
    (0.0, 0.5, None),        # on the way (within a degree): no look
])
def test_the_nose_turns_toward_the_goal_within_the_offset(course_deg, goal_deg, nose_deg):
    yaw = goal_look_yaw(math.radians(course_deg), math.radians(goal_deg), LOOK)
    if nose_deg is None:
        assert yaw is None
    else:
        assert wrap_angle(yaw - math.radians(nose_deg)) == pytest.approx(0.0, abs=1e-9)


def test_the_gain_scales_the_turn_and_non_finite_input_gives_no_look():
    twice = GoalLookParams(math.radians(30.0), gain=2.0)
    assert math.degrees(goal_look_yaw(math.radians(10.0), 0.0, twice)) == pytest.approx(-10.0)
    assert goal_look_yaw(math.nan, 0.0, LOOK) is None
    assert goal_look_yaw(0.0, math.inf, LOOK) is None
    with pytest.raises(ValueError):
        GoalLookParams(math.radians(30.0), gain=0.0)


# ------------------------------------------------------------------ config
def _scenario_error(tmp_path, text):
    path = tmp_path / "s.yaml"
    path.write_text(text)
    with pytest.raises(ConfigError) as info:
        load_scenario(path)
    return str(info.value)


@pytest.mark.parametrize("line, why", [
    ("goal_look_deg: 45.0", "less than half the camera's field of view (45 degrees)"),
    ("goal_look_deg: 0.0", "an angle in (0, 180) degrees"),
    ("goal_look_deg: soon", "expected a number"),
    ("goal_look_gain: 0.0", "a gain in (0, 10]"),
])
def test_bad_goal_look_values_are_refused_naming_the_key(tmp_path, line, why):
    key = line.split(":")[0]
    shipped = next(ln for ln in COPTER_TEXT.splitlines() if ln.startswith(f"  {key}:"))
    text = COPTER_TEXT.replace(shipped, f"  {line}")
    message = _scenario_error(tmp_path, text)
    assert f"avoidance.{key}: " in message and why in message, message


def test_the_unicycle_refuses_the_goal_look(tmp_path):
    text = open("config/scenarios/paper.yaml").read().replace(
        "\navoidance:\n", "\navoidance:\n  goal_look_deg: 30.0\n")
    assert "avoidance.goal_look_deg: a multicopter's only" in _scenario_error(tmp_path, text)


def test_the_service_config_checks_it_against_its_camera(tmp_path):
    path = tmp_path / "c.yaml"
    assert "  look_at_threats: false" in COMPANION_TEXT
    path.write_text(COMPANION_TEXT.replace("  look_at_threats: false",
                                           "  goal_look_deg: 44.0\n  look_at_threats: false"))
    with pytest.raises(ConfigError) as info:       # the shipped camera: 87 degrees
        load_config(path)
    assert "avoidance.goal_look_deg: expected less than half" in str(info.value)
    assert load_config("config/companion.yaml").goal_look_params() is None     # off as shipped


# ------------------------------------------------------------------ flown (copter.yaml)
MOVER_ID = 2


def swerve_and_crosser(goal_look_deg, gain=1.5):
    """copter.yaml flying north from (0, 0) to (200, 0); a post 3.5 m in radius at (45, -1) turns
    it right by 12 to 18 degrees for about 8 s, and a 3.5 m/s mover crossing from the left (10
    degrees from square toward the vehicle) passes 4 to 5 m behind it 10 s in. Flown straight
    at the goal the camera would have it 28 to 36 degrees off the nose; from the swerved course
    it stays 47 degrees or more off the nose while within the camera's 40 m, so it is never in
    view without the look."""
    base = load_scenario(COPTER)
    post = Obstacle(id=1, north_m=45.0, east_m=-1.0, radius_m=3.5)
    mover = Obstacle(id=MOVER_ID, north_m=51.95, east_m=-27.99, radius_m=1.5,
                     vel_north_mps=-0.608, vel_east_mps=3.447)
    world = dataclasses.replace(base.world, start=StartPose(0.0, 0.0, 0.0),
                                goal=Goal(200.0, 0.0, 2.0), obstacles=(post, mover))
    avoidance = dataclasses.replace(base.avoidance, goal_look_deg=goal_look_deg,
                                    goal_look_gain=gain)
    return dataclasses.replace(base, world=world, avoidance=avoidance)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_a_crosser_behind_a_swerve_is_seen_and_avoided_only_with_the_look(seed):
    off = run_once(swerve_and_crosser(None), seed).summary
    on = run_once(swerve_and_crosser(30.0), seed).summary
    assert off["landmarks"]["obstacles_seen"] == 1            # the post only: passed at 4-5 m
    assert off["min_clearance_m"] < 6.0
    assert on["landmarks"]["obstacles_seen"] == 2
    assert on["reached_goal"] and not on["collided"]
    assert on["min_clearance_m"] >= 9.5                       # 11-12 m


def test_the_look_changes_only_the_yaw_within_the_offset_and_the_turn_rate(monkeypatch):
    scenario = swerve_and_crosser(30.0)
    looks, shaped = [], []
    plain = Decider._look_toward_goal

    def recorded(self, command):
        out = plain(self, command)
        looks.append((command, out))
        return out

    def shape(yaw_now, last, command, rate, dt, top):
        out = real_shape(yaw_now, last, command, rate, dt, top)
        shaped.append((yaw_now, last, out, rate * dt))
        return out

    real_shape = simulation.shape_setpoint
    monkeypatch.setattr(Decider, "_look_toward_goal", recorded)
    monkeypatch.setattr(simulation, "shape_setpoint", shape)
    outcome = run_once(scenario, 0)
    assert outcome.summary["reached_goal"]
    offset = math.radians(30.0)
    looked = [out for _, out in looks if out.yaw_rad is not None]
    assert len(looked) >= 30                                  # 3 s or more of looking
    for before, after in looks:
        # the velocity choice's command, untouched: direction, speed, mode
        assert dataclasses.replace(after, yaw_rad=before.yaw_rad) == before
        if after.yaw_rad is not None:
            assert abs(wrap_angle(after.yaw_rad - after.heading_rad)) <= offset + 1e-9
    apart = 0
    for yaw_now, last, out, max_step in shaped:
        assert math.isfinite(out.yaw_rad) and math.isfinite(out.course_rad)
        assert abs(wrap_angle(out.yaw_rad - yaw_now)) <= max_step + 1e-9      # the nose's rate
        if last is not None:                                                  # the velocity's
            reference = last.course_rad if out.apart else yaw_now
            assert abs(wrap_angle(out.course_rad - reference)) <= max_step + 1e-9
        apart += abs(wrap_angle(out.yaw_rad - out.course_rad)) > math.radians(5.0)
    assert apart >= 20                                        # the nose did leave the velocity
    # the true nose never turned faster than the vehicle's yaw rate
    yaw = np.array(outcome.trace.true_pose)[:, 2]
    rate = scenario.vehicle.max_turn_rate_rad_s * scenario.vehicle.dt_s
    assert np.abs(wrap_angle_array(np.diff(yaw))).max() <= rate + 1e-6


def wrap_angle_array(a):
    return (a + np.pi) % (2 * np.pi) - np.pi


# ------------------------------------------------------------------ the service (ArduCopter's path)
def _service_flight(goal_look_deg):
    """The pipeline flying north at 5 m/s (tests/service's feed, which does not follow the
    setpoints) toward a post seen 2 m left of the way: the setpoints it sends."""
    from tests.service.test_pipeline import GOAL, Feed, config, hb, setpoints
    from companion.core.estimation.slam_types import Observation
    base = config(require_camera=False)
    cfg = dataclasses.replace(base, avoidance=dataclasses.replace(
        base.avoidance, goal_look_deg=goal_look_deg))
    feed = Feed(Pipeline(cfg, GOAL))
    feed.send(hb())
    sent = []
    for step in range(60):
        out = feed.step()
        if step % 2 == 1:
            dn = 45.0 - feed.north_m
            out += feed.camera([Observation(math.hypot(dn, -2.0), math.atan2(-2.0, dn), 1)])
        sent += setpoints(out)
    return feed, sent


def test_the_service_has_the_goal_look_only_when_configured_and_sends_finite_yaws():
    feed, sent = _service_flight(None)                         # companion.yaml as shipped: off
    assert feed.p.navigator.goal_look is None and len(sent) > 40
    for s in sent:     # the nose along the velocity (the feed's yaw is 0, the SLAM's near it)
        if math.hypot(s.vel_north_mps, s.vel_east_mps) > 1.0:
            assert abs(wrap_angle(s.yaw_rad - math.atan2(s.vel_east_mps, s.vel_north_mps))) \
                < math.radians(1.0)
    feed, sent = _service_flight(30.0)
    assert feed.p.navigator.goal_look == GoalLookParams(math.radians(30.0))
    limits = feed.p.config.commanding
    for a, b in zip(sent, sent[1:]):
        assert all(math.isfinite(v) for v in (b.yaw_rad, b.vel_north_mps, b.vel_east_mps))
        assert abs(wrap_angle(b.yaw_rad - a.yaw_rad)) <= limits.max_turn_rate_rad_s \
            * limits.setpoint_period_s + math.radians(0.5)     # + the fed yaw's own change
        course = math.atan2(b.vel_east_mps, b.vel_north_mps)
        assert abs(wrap_angle(b.yaw_rad - course)) <= math.radians(30.0) + math.radians(1.0)
