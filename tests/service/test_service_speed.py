"""The service flies the velocity choice (issue 16): its limits from the config, setpoints within
them (slowing and stopping included), and a multicopter's nose toward a mover it cannot see."""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from companion.mavlink import codec
from companion.config.service import load_config
from companion.core.avoidance.arc import VehicleLimits
from companion.core.estimation.slam_types import Observation
from companion.core.geometry import wrap_angle
from companion.core.avoidance.guidance import GuidanceCommand, ShapedSetpoint, shape_setpoint
from companion.core.avoidance.look_at import LookAtParams, threat_to_watch
from companion.errors import ConfigError
from companion.onboard.pipeline import Pipeline
from tests.service.test_pipeline import GOAL, Feed, config, hb, setpoints

SHIPPED = "config/companion.yaml"
TEXT = open(SHIPPED).read()


# ------------------------------------------------------------------ config
@pytest.mark.parametrize("old, new, key", [
    ("max_accel_mps2: 2.5", "max_accel_mps2: 0.0", "commanding.max_accel_mps2"),
    ("max_accel_mps2: 2.5", "max_accel_mps2: -1.0", "commanding.max_accel_mps2"),
    ("max_accel_mps2: 2.5", "max_accel_mps2: 250.0", "commanding.max_accel_mps2"),   # cm/s/s
    ("max_accel_mps2: 2.5", "max_accel_mps2: fast", "commanding.max_accel_mps2"),
    ("max_accel_mps2: 2.5", "max_accel_mps2: .nan", "commanding.max_accel_mps2"),
    ("perception_delay_s: 1.0", "perception_delay_s: -0.1", "commanding.perception_delay_s"),
    ("perception_delay_s: 1.0", "perception_delay_s: 60.0", "commanding.perception_delay_s"),
    ("sensor_fov_deg: 87.0", "sensor_fov_deg: 0.0", "estimator.sensor_fov_deg"),
    ("sensor_max_range_m: 40.0", "sensor_max_range_m: -40.0", "estimator.sensor_max_range_m"),
    ("look_at_threats: false", "look_at_threats: sometimes", "avoidance.look_at_threats"),
])
def test_bad_vehicle_limits_are_refused_naming_file_and_key(tmp_path, old, new, key):
    path = tmp_path / "bad.yaml"
    assert old in TEXT
    path.write_text(TEXT.replace(old, new))
    with pytest.raises(ConfigError) as info:
        load_config(path)
    assert str(info.value).startswith(f"{path}: {key}: "), str(info.value)


def test_the_service_navigator_gets_the_configured_limits_and_camera():
    base = config(require_camera=False)
    tuned = dataclasses.replace(
        base, commanding=dataclasses.replace(base.commanding, max_turn_rate_deg_s=45.0,
                                             max_accel_mps2=1.5, perception_delay_s=0.4,
                                             max_jerk_mps3=7.0),
        estimator=dataclasses.replace(base.estimator, sensor_fov_deg=70.0,
                                      sensor_max_range_m=25.0))
    feed = Feed(Pipeline(tuned, GOAL))
    feed.send(hb())
    feed.step()
    nav = feed.p.navigator
    assert nav.limits == VehicleLimits(math.radians(45.0), 1.5, lateral_accel_limited=True,
                                       max_jerk_mps3=7.0)
    assert nav.union.sensor_range_m == 25.0 and nav.union.perception_delay_s == 0.4
    assert nav.union.fov_rad == pytest.approx(math.radians(70.0))
    assert nav.look_at is None                       # off unless asked for
    looking = dataclasses.replace(tuned, avoidance=dataclasses.replace(
        tuned.avoidance, look_at_threats=True))
    assert looking.look_at_params() == LookAtParams(math.radians(70.0), 6.0, 20.0)


def test_tentatives_in_the_decision_mean_no_perception_delay():
    base = config()
    est = dataclasses.replace(base.estimator, tentative_in_guidance=True)
    assert dataclasses.replace(base, estimator=est).union_params().perception_delay_s == 0.0


# ------------------------------------------------------------------ setpoint shaping
def test_shaped_setpoints_never_exceed_the_turn_rate_or_the_speed_limit():
    rng = np.random.default_rng(7)
    rate, dt, top = math.radians(30.0), 0.1, 8.0
    yaw, last = 0.0, None
    for _ in range(2000):
        look = rng.uniform(-math.pi, math.pi) if rng.random() < 0.3 else None
        command = GuidanceCommand(float(rng.uniform(-5.0, 20.0)),
                                  float(rng.uniform(-math.pi, math.pi)), "avoid", yaw_rad=look)
        shaped = shape_setpoint(yaw, last, command, rate, dt, top)
        assert 0.0 <= shaped.speed_mps <= top
        assert abs(wrap_angle(shaped.yaw_rad - yaw)) <= rate * dt + 1e-9
        reference = last.course_rad if shaped.apart else yaw
        assert abs(wrap_angle(shaped.course_rad - reference)) <= rate * dt + 1e-9
        if last is not None:       # the velocity's direction never jumps between setpoints
            assert abs(wrap_angle(shaped.course_rad - last.course_rad)) <= 2 * rate * dt + 1e-9 \
                or not (shaped.apart or last.apart)
        # the vehicle follows its nose setpoint, with some lag
        yaw = wrap_angle(yaw + 0.8 * wrap_angle(shaped.yaw_rad - yaw))
        last = shaped


def test_nose_and_velocity_fly_together_unless_the_command_looks_elsewhere():
    rate, dt = math.radians(30.0), 0.1
    straight = ShapedSetpoint(0.0, 5.0, 0.0)
    together = shape_setpoint(0.0, straight, GuidanceCommand(5.0, 1.0, "avoid"), rate, dt, 8.0)
    assert together.yaw_rad == together.course_rad == pytest.approx(rate * dt)
    assert not together.apart
    # a nose lagging its setpoint (no look): the velocity still turns from the nose
    lagging = shape_setpoint(0.5, straight, GuidanceCommand(5.0, 1.0, "avoid"), rate, dt, 8.0)
    assert lagging.course_rad == pytest.approx(0.5 + rate * dt) and not lagging.apart
    # looking right at a mover while the velocity goes left: each turns its own way
    apart = shape_setpoint(0.0, straight, GuidanceCommand(5.0, -1.0, "avoid", yaw_rad=2.0),
                           rate, dt, 8.0)
    assert apart.course_rad == pytest.approx(-rate * dt)
    assert apart.yaw_rad == pytest.approx(rate * dt) and apart.apart
    # the nose far off, coming back from a look: the velocity turns from where it was going,
    # not from the nose, until the nose is back
    looked = ShapedSetpoint(0.1, 5.0, 2.5, apart=True)
    back = shape_setpoint(2.5, looked, GuidanceCommand(5.0, 0.1, "goal"), rate, dt, 8.0)
    assert back.course_rad == pytest.approx(0.1) and back.apart
    assert back.yaw_rad == pytest.approx(2.5 - rate * dt)
    home = shape_setpoint(0.12, back, GuidanceCommand(5.0, 0.1, "goal"), rate, dt, 8.0)
    assert not home.apart and home.yaw_rad == pytest.approx(0.1)


# ------------------------------------------------------------------ pipeline
def blocked_feed(look_at: bool = False, **commanding):
    base = config(require_camera=False)
    base = dataclasses.replace(base, estimator=dataclasses.replace(base.estimator,
                                                                   sensor_fov_deg=90.0))
    cfg = dataclasses.replace(base, commanding=dataclasses.replace(base.commanding, **commanding),
                              avoidance=dataclasses.replace(base.avoidance,
                                                            look_at_threats=look_at))
    feed = Feed(Pipeline(cfg, GOAL))
    feed.send(hb())
    return feed


def wall(feed, north_m: float, easts_m) -> list[Observation]:
    """Observations of obstacles across the way at ``north_m`` (ids 1..), from the feed's pose."""
    out = []
    for i, east in enumerate(easts_m):
        dn, de = north_m - feed.north_m, east
        out.append(Observation(math.hypot(dn, de), math.atan2(de, dn), i + 1))
    return out


def test_a_way_blocked_close_ahead_stops_the_vehicle_within_the_limits():
    """A wall of overlapping circles 16 m ahead from side to side: no velocity toward it keeps
    d, so the setpoints slow to a stop (none turns across the circles at speed); each within
    the speed limit and the turn rate."""
    feed = blocked_feed()
    sent = []
    for step in range(40):
        out = feed.step(speed_mps=5.0 if step < 20 else 0.0)
        if step >= 19 and step % 2 == 1:
            out += feed.camera(wall(feed, 46.0, np.arange(-60.0, 61.0, 8.0)))
        sent += setpoints(out)
    limits = feed.p.config.commanding
    speeds = [math.hypot(s.vel_north_mps, s.vel_east_mps) for s in sent]
    assert max(speeds) <= limits.max_speed_mps + 1e-9
    assert speeds[0] == pytest.approx(limits.cruise_speed_mps, abs=1e-6)  # nothing in the way yet
    assert speeds[-1] == pytest.approx(0.0, abs=1e-6)
    seen = next(i for i, s in enumerate(sent) if s.reason != "goal")
    assert all(b <= a + 1e-9 for a, b in zip(speeds[seen:], speeds[seen + 1:])), speeds[seen:]
    for a, b in zip(sent, sent[1:]):
        assert abs(wrap_angle(b.yaw_rad - a.yaw_rad)) <= limits.max_turn_rate_rad_s \
            * limits.setpoint_period_s + math.radians(0.5)     # + the fed yaw's own change


def test_the_chosen_speed_comes_back_once_the_way_is_clear():
    """A wall seen ahead brings a stop; once the camera shows it gone (the landmarks deleted
    after their misses), the speed returns to cruise."""
    feed = blocked_feed()
    for step in range(20):
        feed.step()
    for step in range(10):
        feed.step(speed_mps=0.0)
        feed.camera(wall(feed, feed.north_m + 14.0, np.arange(-60.0, 61.0, 8.0)))
    stopped = setpoints(feed.outputs)[-1]
    assert math.hypot(stopped.vel_north_mps, stopped.vel_east_mps) < 1e-6
    # the camera no longer sees any of them (only something far off to the side): each is
    # deleted after delete_misses frames in view. (An empty frame never reaches the estimator:
    # the pipeline takes it as the camera's liveness only.)
    far = Observation(39.0, math.radians(40.0), 99)
    for step in range(60):
        feed.step(speed_mps=0.0)
        if step % 2 == 0:
            feed.camera([far])
    resumed = setpoints(feed.outputs)[-1]
    assert math.hypot(resumed.vel_north_mps, resumed.vel_east_mps) == pytest.approx(
        feed.p.config.commanding.cruise_speed_mps)


# ------------------------------------------------------------------ look at threats
LOOK = LookAtParams(math.radians(90.0), 6.0, 20.0)


def test_a_mover_out_of_view_closing_in_is_watched():
    # flying north at 5 m/s; a mover 20 m east, 10 m ahead, walking west at 3 m/s: 63 deg off
    watch = threat_to_watch(np.zeros(2), 0.0, 5.0, np.array([[10.0, 20.0]]),
                            np.array([[0.0, -3.0]]), LOOK)
    assert watch is not None and watch.index == 0
    assert watch.bearing_rad == pytest.approx(math.atan2(20.0, 10.0))
    assert watch.time_to_closest_s < LOOK.horizon_s and watch.closest_m < LOOK.distance_m


@pytest.mark.parametrize("position, velocity, why", [
    ((30.0, 5.0), (0.0, -3.0), "in view ahead: the camera sees it anyway"),
    ((-10.0, 15.0), (0.0, 3.0), "behind and walking away"),
    ((10.0, 60.0), (0.0, -0.5), "out of view but far: passes beyond the distance"),
    ((10.0, 90.0), (0.0, -3.0), "closes in only after the horizon"),
])
def test_no_watch_when_the_mover_is_seen_or_no_threat(position, velocity, why):
    assert threat_to_watch(np.zeros(2), 0.0, 5.0, np.array([position]), np.array([velocity]),
                           LOOK) is None, why


def test_of_two_threats_the_earlier_closest_approach_is_watched():
    movers = np.array([[0.0, 30.0], [0.0, -15.0]])
    velocities = np.array([[5.0, -3.0], [5.0, 3.0]])        # both abeam, closing at 3 m/s
    watch = threat_to_watch(np.zeros(2), 0.0, 5.0, movers, velocities, LOOK)
    assert watch is not None and watch.index == 1


def test_the_navigator_points_the_nose_at_a_tracked_mover_out_of_view():
    feed = blocked_feed(look_at=True)
    for _ in range(5):
        feed.step()
    nav = feed.p.navigator
    track = nav.movers.create(nav.clock_s, np.array([feed.north_m + 8.0, 20.0]), np.eye(2) * 0.1,
                              7, (np.array([0.0, -3.0]), 0.05))
    out = feed.step()
    (sp,) = setpoints(out)
    assert nav.watching == track
    course = math.atan2(sp.vel_east_mps, sp.vel_north_mps)
    # the nose turns toward it (east) at the turn rate; the velocity does not follow it
    assert wrap_angle(sp.yaw_rad - 0.0) == pytest.approx(
        feed.p.config.commanding.max_turn_rate_rad_s * feed.p.config.commanding.setpoint_period_s)
    assert course <= 1e-6
    without = blocked_feed(look_at=False)
    for _ in range(5):
        without.step()
    without.p.navigator.movers.create(without.p.navigator.clock_s,
                                      np.array([without.north_m + 8.0, 20.0]), np.eye(2) * 0.1,
                                      7, (np.array([0.0, -3.0]), 0.05))
    (plain,) = setpoints(without.step())
    assert without.p.navigator.watching is None
    assert plain.yaw_rad == pytest.approx(math.atan2(plain.vel_east_mps, plain.vel_north_mps))
