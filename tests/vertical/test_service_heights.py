"""The service in 3D (issue 27, onboard/heights.py): a frame's points grouped per obstacle, the
altitude and the points' z into the navigator, the floor dropped and counted, and vz from the
3D decision, bounded, only while airborne. In-process: the pipeline fed decoded events."""
import dataclasses
import math

import pytest

from companion.config.service import load_config
from companion.core.estimation.slam_types import Observation
from companion.core.perception.point_groups import group_points
from companion.mavlink import codec, obstacle_forms
from companion.onboard.heights import ServiceHeights
from companion.onboard.pipeline import Pipeline, snapshot

from tests.service.test_pipeline import GOAL, Feed, config, hb, setpoints

VFOV_RAD = math.radians(58.0)
WALL = [(i, 100.0, e, 1.0, 3.0) for i, e in enumerate(range(-30, 31, 4), start=1)]   # 3 m posts


def test_points_of_one_obstacle_become_one_observation_with_its_top_and_bottom():
    frame = [Observation(30.0, 0.1, 7, top_down_m=6.0, bottom_down_m=6.0),
             Observation(20.0, -0.2, None, top_down_m=10.0, bottom_down_m=10.0),    # floor
             Observation(30.0, 0.1, 7, top_down_m=10.0, bottom_down_m=10.0),
             Observation(25.0, 0.3, None, top_down_m=-2.0, bottom_down_m=-2.0),
             Observation(25.0, 0.3, None, top_down_m=4.0, bottom_down_m=4.0),       # same place
             Observation(12.0, 0.0, 3)]                                             # no z
    grouped, merged = group_points(frame)
    assert merged == 2
    assert [(o.obstacle_id, o.top_down_m, o.bottom_down_m) for o in grouped] == [
        (7, 6.0, 10.0), (None, 10.0, 10.0), (None, -2.0, 4.0), (3, None, None)]
    assert grouped[0].range_m == 30.0 and grouped[0].bearing_rad == 0.1
    flat = [Observation(30.0, 0.1, 7), Observation(20.0, 0.0, 8)]
    assert group_points(flat) == (flat, 0)


def vertical_config(**avoidance):
    """test_pipeline's config (Feed3D joins a vehicle already armed in the air: without
    restart.look_around, which would hold it and turn it round first) with vertical on."""
    base = config()
    return dataclasses.replace(base, avoidance=dataclasses.replace(
        base.avoidance, vertical=True, **avoidance))


def test_the_climb_sent_is_bounded_and_finite():
    heights = ServiceHeights(vertical_config(min_altitude_m=2.0, max_altitude_m=30.0))
    limit = heights.max_vertical_speed_mps                       # safety: 2.5 m/s
    assert heights.limit_climb_mps(9.0, 10.0) == limit
    assert heights.limit_climb_mps(-9.0, 10.0) == -limit
    assert heights.limit_climb_mps(math.nan, 10.0) == 0.0
    assert heights.limit_climb_mps(math.inf, 10.0) == 0.0
    assert heights.limit_climb_mps(-1.0, 2.0) == 0.0             # never sinks at the minimum
    assert heights.limit_climb_mps(1.0, 30.0) == 0.0             # never climbs at the ceiling
    assert heights.limit_climb_mps(1.0, 2.0) == 1.0 and heights.limit_climb_mps(-1.0, 30.0) == -1.0
    off = ServiceHeights(load_config("config/companion.yaml"))
    assert not off.on and off.extent is None and off.vertical_params(10.0) is None
    assert off.vel_down_mps(None, 10.0, 0.25, safe_hold=False) == 0.25


class Feed3D(Feed):
    """Feed's vehicle flying north at 5 m/s, its altitude following the setpoints' vz (a
    multicopter that flies what it is told vertically), with a camera of 45 deg half view and
    58 deg vertical view reporting each post as two points (top, bottom) and the floor."""

    def __init__(self, pipeline, posts, up_m=10.0, floor=True):
        super().__init__(pipeline)
        self.posts, self.up_m, self.floor = posts, up_m, floor
        self.vz_mps = 0.0
        self.track = []                           # (north, up) at each step

    def step(self, **kw):
        out = super().step(**kw)
        sent = setpoints(out)
        if sent:
            self.vz_mps = sent[-1].vel_down_mps
        self.up_m = max(0.0, self.up_m - self.vz_mps * 0.1)
        self.track.append((self.north_m, self.up_m))
        if self.steps % 2 == 0:
            out += self.frame()
        return out

    def send(self, event, link_step_s=0.0):
        if isinstance(event, codec.LocalPosition):    # the altitude flown, not Feed's 10 m
            event = dataclasses.replace(event, down_m=-self.up_m, vel_down_mps=self.vz_mps)
        return super().send(event, link_step_s)

    def frame(self):
        out = []
        tan = math.tan(0.5 * VFOV_RAD)
        for oid, north, east, _, top in self.posts:
            dn, de = north - self.north_m, east
            r, b = math.hypot(dn, de), math.atan2(de, dn)
            if r > 40.0 or abs(b) > math.radians(45) or dn <= 0:
                continue
            high, low = min(top, self.up_m + r * tan), max(0.0, self.up_m - r * tan)
            if high < low:
                continue
            for z in (self.up_m - high, self.up_m - low):
                out += self.camera([Observation(r, b, oid, top_down_m=z, bottom_down_m=z)])
        if self.floor:
            for b in (-0.3, 0.0, 0.3):
                out += self.camera([Observation(30.0, b, None, top_down_m=self.up_m,
                                                bottom_down_m=self.up_m)])
        return out


def fly(config, posts, floor=True, until_north_m=160.0):
    feed = Feed3D(Pipeline(config, GOAL, record_track=True), posts, floor=floor)
    feed.send(hb())
    while feed.north_m < until_north_m:
        feed.step()
    return feed


def test_the_service_climbs_over_a_low_wall_and_sinks_back_to_the_cruise_altitude():
    feed = fly(vertical_config(), WALL)
    sent = setpoints(feed.outputs)
    assert sent and all(math.isfinite(s.vel_down_mps) and abs(s.vel_down_mps) <= 2.5
                        for s in sent)
    at_wall = [up for north, up in feed.track if abs(north - 100.0) <= 10.0]
    # clearance in 3D: over the 3 m top by d (10 m) wherever it is within d horizontally
    assert min(at_wall) >= 3.0 + 10.0
    assert max(up for _, up in feed.track) <= 30.0                  # avoidance.max_altitude_m
    assert feed.track[-1][1] == pytest.approx(10.0, abs=0.5)        # back at the cruise altitude
    report = snapshot(feed.p)
    assert report["vertical"]["points"]["ground"] > 100             # the floor, counted ...
    assert len(report["landmarks"]) <= len(WALL)                    # ... and never mapped
    assert report["vertical"]["merged_points"] > 0
    tops = [e["top_m"] for e in report["vertical"]["extents"].values() if e["top_m"] is not None]
    assert tops and all(abs(t - 3.0) < 1.0 for t in tops)


def test_an_altitude_ceiling_below_the_wall_s_clearance_keeps_the_service_level():
    feed = fly(vertical_config(max_altitude_m=12.0), WALL, until_north_m=95.0)
    assert max(up for _, up in feed.track) <= 12.0 + 0.3
    assert all(s.vel_down_mps >= -2.5 for s in setpoints(feed.outputs))


def test_with_vertical_off_the_z_is_ignored_and_the_altitude_held():
    feed = fly(config(), WALL, floor=False, until_north_m=95.0)
    assert all(abs(up - 10.0) < 0.05 for _, up in feed.track)
    assert "vertical" not in snapshot(feed.p)


def test_no_setpoint_while_not_airborne_with_vertical_on():
    feed = Feed3D(Pipeline(vertical_config(), GOAL), WALL)
    feed.landed_state = codec.LANDED_STATE_TAKEOFF
    feed.send(hb())
    for _ in range(100):
        feed.step()
    assert setpoints(feed.outputs) == []


@pytest.mark.parametrize("z", [math.nan, math.inf, -math.inf])
def test_a_point_with_a_non_finite_z_is_refused_and_counted(z):
    from pymavlink.dialects.v20 import ardupilotmega as mavlink
    msg = mavlink.MAVLink_obstacle_distance_3d_message(
        10_000, 0, mavlink.MAV_FRAME_BODY_FRD, 4, 20.0, 1.0, z, 0.2, 40.0)
    frame = obstacle_forms._obstacle_3d(msg, 1, 100)
    assert frame.observations == () and frame.rejected
    feed = Feed3D(Pipeline(vertical_config(), GOAL), [], floor=False)
    feed.send(hb())
    for _ in range(5):
        feed.step()
    feed.send(dataclasses.replace(frame, t_s=feed.t_s))
    feed.step()
    assert feed.p.counters.get("obstacle_rejected") == 1
    assert snapshot(feed.p)["landmarks"] == []


def test_a_finite_z_rides_on_the_observation():
    from pymavlink.dialects.v20 import ardupilotmega as mavlink
    msg = mavlink.MAVLink_obstacle_distance_3d_message(
        10_000, 0, mavlink.MAV_FRAME_BODY_FRD, 4, 20.0, 1.0, -3.5, 0.2, 40.0)
    (obs,) = obstacle_forms._obstacle_3d(msg, 1, 100).observations
    assert obs.top_down_m == obs.bottom_down_m == pytest.approx(-3.5)


@pytest.mark.parametrize("section, text, key, problem", [
    ("perception", "camera_vfov_deg: 200", "perception.camera_vfov_deg", "(0, 180)"),
    ("perception", "ground_margin_m: -1", "perception.ground_margin_m", "a margin >= 0 m"),
    ("avoidance", "max_altitude_m: 1.0", "avoidance.max_altitude_m", "above min_altitude_m"),
    ("perception", "ground_margn_m: 1", "perception.ground_margn_m", "unknown key"),
])
def test_a_bad_3d_key_in_the_service_config_names_file_key_and_problem(tmp_path, section, text,
                                                                       key, problem):
    import yaml
    from companion.config.loader import ConfigError
    data = yaml.safe_load(open("config/companion.yaml"))
    key_name, value = text.split(": ")
    data.setdefault(section, {})[key_name] = yaml.safe_load(value)
    path = tmp_path / "bad.yaml"
    path.write_text(yaml.safe_dump(data))
    with pytest.raises(ConfigError) as err:
        load_config(path)
    message = str(err.value)
    assert str(path) in message and key in message and problem in message, message
