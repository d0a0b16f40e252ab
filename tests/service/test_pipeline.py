"""Pipeline rules on synthetic event streams: identities, gating, timing, failsafes."""
import dataclasses
import logging
import math

import numpy as np
import pytest

from companion.mavlink import codec
from companion.config.service import GoalConfig, load_config
from companion.core.estimation.slam_types import Observation
from companion.core.avoidance.guidance import GuidanceCommand
from companion.onboard.pipeline import Arrived, NavigatorStarted, Pipeline, StreamsWanted, snapshot

GUIDED, LOITER = 4, 5
GOAL = GoalConfig(180.0, 0.0, 2.0)


def config(**failsafe):
    """The Feed joins a vehicle already armed in the air: without restart.look_around, which
    would hold it first (tests/service/test_look_around.py)."""
    base = load_config("config/companion.yaml")
    return dataclasses.replace(base, failsafe=dataclasses.replace(base.failsafe, **failsafe),
                               restart=dataclasses.replace(base.restart, look_around=False))


def hb(armed=True, mode=GUIDED, sysid=1, compid=1, autopilot=True):
    return codec.Heartbeat(sysid, compid, 2, autopilot, armed, mode)


class Feed:
    """Drives a pipeline with a vehicle flying north at 5 m/s: ATTITUDE + LOCAL_POSITION_NED at
    10 Hz of vehicle time, the link clock ticking alongside."""

    def __init__(self, pipeline, sysid=1):
        self.p, self.sysid = pipeline, sysid
        self.t_s, self.link_s, self.north_m = 10.0, 1000.0, 20.0
        self.outputs = []
        self.armed, self.mode, self.steps = True, GUIDED, 0
        self.camera_alive = True
        self.landed_state = codec.LANDED_STATE_IN_AIR

    def send(self, event, link_step_s=0.0):
        self.link_s += link_step_s
        out = self.p.handle(self.link_s, event)
        self.outputs.extend(out)
        return out

    def step(self, heartbeat=None, speed_mps=5.0, yaw_rad=0.0):
        self.t_s = round(self.t_s + 0.1, 6)
        self.north_m += speed_mps * 0.1
        out = []
        self.steps += 1
        if heartbeat is None and self.steps % 10 == 0:
            heartbeat = hb(self.armed, self.mode, self.sysid)
        if heartbeat is not None:
            self.armed, self.mode = heartbeat.armed, heartbeat.custom_mode
            out += self.send(heartbeat)
        if self.camera_alive and self.steps % 10 == 0:
            out += self.send(codec.ObstacleFrame(self.sysid, 100, self.t_s, ()))  # empty frame
        out += self.send(codec.Attitude(self.sysid, 1, self.t_s, yaw_rad, 0.0), 0.05)
        if self.steps % 10 == 1:                  # EXTENDED_SYS_STATE: flying (companion asks)
            out += self.send(codec.LandedState(self.sysid, 1, self.landed_state, 0))
        out += self.send(codec.LocalPosition(self.sysid, 1, self.t_s, self.north_m, 0.0,
                                             speed_mps * math.cos(yaw_rad),
                                             speed_mps * math.sin(yaw_rad), -10.0, 0.0), 0.05)
        return out

    def camera(self, observations, compid=100, sysid=None):
        return self.send(codec.ObstacleFrame(sysid or self.sysid, compid, self.t_s,
                                             tuple(observations)))


def setpoints(outputs):
    return [o for o in outputs if isinstance(o, codec.VelocitySetpoint)]


def started(require_camera=False, **kw):
    feed = Feed(Pipeline(config(require_camera=require_camera, **kw), GOAL, record_track=True))
    feed.send(hb())
    feed.send(codec.ObstacleFrame(1, 100, feed.t_s, ()))       # the camera: an empty frame
    return feed


def test_vehicle_found_from_autopilot_heartbeat_and_streams_requested():
    p = Pipeline(config(), GOAL)
    assert p.handle(0.0, hb(autopilot=False, compid=191)) == []
    out = p.handle(0.0, hb(sysid=7))
    assert p.vehicle == (7, 1) and StreamsWanted("vehicle found") in out


def test_setpoints_at_the_configured_rate_of_message_time_when_armed_in_guided():
    feed = started()
    outs = [feed.step() for _ in range(30)]
    assert any(isinstance(o, NavigatorStarted) for o in feed.outputs)
    sps = setpoints(feed.outputs)
    assert len(sps) == 30                       # 10 Hz odometry, 10 Hz setpoints
    sp = sps[-1]
    assert (sp.target_system, sp.target_component) == (1, 1)
    assert math.hypot(sp.vel_north_mps, sp.vel_east_mps) == pytest.approx(5.0)
    assert sp.yaw_rad == pytest.approx(0.0, abs=1e-6)
    assert all(o for o in outs)


def test_no_setpoints_disarmed_or_outside_guided_and_pilot_wins_at_once():
    feed = started()
    for _ in range(5):
        feed.step()
    n = len(setpoints(feed.outputs))
    assert n > 0
    feed.step(heartbeat=hb(mode=LOITER))
    for _ in range(5):
        feed.step()
    feed.step(heartbeat=hb(armed=False))
    assert len(setpoints(feed.outputs)) == n
    feed.step(heartbeat=hb())
    assert len(setpoints(feed.outputs)) == n + 1


def test_obstacles_from_other_systems_never_reach_the_estimator():
    feed = started()
    for _ in range(3):
        feed.step()
    feed.camera([Observation(30.0, 0.1, 5)], sysid=9)
    feed.camera([Observation(30.0, 0.1, 6)], compid=42)
    assert feed.p.navigator.slam.landmark_count == 0
    feed.camera([Observation(30.0, 0.1, 7)])
    feed.send(hb())                            # the next message ends the camera's frame
    assert feed.p.navigator.slam.landmark_ids() == [7]


def test_an_obstacle_report_gets_its_own_setpoint_with_the_next_message():
    feed = started()
    for _ in range(3):
        feed.step()
    out = feed.camera([Observation(30.0, 0.1, 7)])
    out += feed.send(hb())       # a heartbeat: no setpoint of its own, it ends the frame
    assert len(setpoints(out)) == 1 and setpoints(out)[0].t_s == pytest.approx(feed.t_s)


def test_one_obstacle_message_per_obstacle_is_one_frame_for_the_lifecycle():
    """OBSTACLE_DISTANCE_3D carries one obstacle: the messages of a frame (one time) are one
    chance for every landmark in view, so three posts in view, each seen in every frame, are all
    confirmed and none expires (counted per message, each post missed two chances in three)."""
    base = config()
    cfg = dataclasses.replace(base, estimator=dataclasses.replace(
        base.estimator, sensor_fov_deg=90.0, sensor_max_range_m=40.0))
    feed = Feed(Pipeline(cfg, GOAL, record_track=True))
    feed.send(hb())
    posts_ne = [(50.0, -6.0), (52.0, 0.5), (54.0, 7.0)]
    for k in range(30):
        feed.step()
        if k % 2 == 0:                         # a 5 Hz camera
            for oid, (north, east) in enumerate(posts_ne, start=1):
                rel_n = north - feed.north_m
                feed.camera([Observation(math.hypot(rel_n, east), math.atan2(east, rel_n), oid)])
    feed.send(hb())
    lifecycle = feed.p.navigator.lifecycle
    assert sorted(feed.p.navigator.slam.landmark_ids()) == [1, 2, 3]
    assert lifecycle.counts["confirmed"] == 3 and lifecycle.counts["expired"] == 0


def test_urgent_obstacle_deflects_and_reports_urgency_then_clearing():
    feed = started()
    notices = []
    for i in range(120):
        out = feed.step()
        rel_north = 60.0 - feed.north_m
        if 0 < rel_north < 40:
            out += feed.camera([Observation(math.hypot(rel_north, 3.0),
                                            math.atan2(3.0, rel_north), 1)])
        notices += [o.text for o in out if isinstance(o, codec.Notice)]
    assert any("obstacle 1 urgent" in t for t in notices)
    turned = [sp for sp in setpoints(feed.outputs) if abs(sp.vel_east_mps) > 0.1]
    assert turned and all(sp.vel_east_mps < 0 for sp in turned[:3])   # away from the right side
    assert snapshot(feed.p)["urgency_events"][0]["state"] == "urgent"


def test_diverged_estimator_holds_and_logs_error(caplog):
    feed = started()
    for _ in range(3):
        feed.step()
    feed.p.navigator.slam._cov_buf[0, 0] = math.nan          # simulate a divergence
    with caplog.at_level(logging.ERROR, logger="companion.onboard.pipeline"):
        out = feed.step()
    (sp,) = setpoints(out)
    assert (sp.vel_north_mps, sp.vel_east_mps) == (0.0, 0.0) and sp.reason.startswith("hold")
    assert "estimator diverged" in caplog.text
    assert not any(isinstance(o, codec.PoseEstimate) for o in out)   # never publish NaN


def test_stale_camera_holds_then_resumes(caplog):
    feed = started(require_camera=True, obstacle_timeout_s=1.0)
    feed.camera_alive = False
    feed.step()
    assert setpoints(feed.outputs)[-1].vel_north_mps > 0     # the empty frame counted
    with caplog.at_level(logging.ERROR, logger="companion.onboard.pipeline"):
        for _ in range(15):
            feed.step()
    assert setpoints(feed.outputs)[-1].reason == "hold: obstacle data stale"
    assert "obstacle data stale" in caplog.text
    feed.send(codec.ObstacleFrame(1, 100, feed.t_s, ()))
    feed.step()
    assert setpoints(feed.outputs)[-1].reason == "goal"


def test_heartbeat_loss_on_the_link_clock_stops_setpoints_and_return_resyncs():
    feed = started()
    feed.step()
    n = len(setpoints(feed.outputs))
    feed.link_s += 5.0                        # heartbeats silent for 5 s of link time
    for _ in range(3):
        feed.step()
    assert len(setpoints(feed.outputs)) == n
    out = feed.send(hb())
    assert StreamsWanted("heartbeat back") in out
    feed.step()
    assert len(setpoints(feed.outputs)) == n + 1


def test_one_stamp_back_is_dropped_not_a_reboot():
    feed = started()
    for _ in range(5):
        feed.step()
    nav, t_s = feed.p.navigator, feed.t_s
    feed.t_s = 0.5
    out = feed.step(heartbeat=hb())            # ATTITUDE and position behind, and a heartbeat
    assert StreamsWanted("vehicle reboot") not in out and feed.p.reset_counter == 0
    assert feed.p.counters["time_behind"] == 2
    feed.t_s = t_s
    feed.step()
    assert feed.p.navigator is nav and feed.p.latest_t_s == pytest.approx(t_s + 0.1)


def test_reboot_needs_consecutive_messages_and_a_heartbeat_then_resets_from_the_first():
    feed = started()
    for _ in range(5):
        feed.step()
    feed.t_s = 0.5
    feed.steps = 1                               # no heartbeat of the Feed's own for a while
    for _ in range(4):                           # 8 messages on the new clock, no heartbeat
        out = feed.step()
        assert StreamsWanted("vehicle reboot") not in out
    assert feed.p.reset_counter == 0
    out = feed.send(hb())                        # the vehicle's heartbeat, then one more message
    out += feed.step()
    assert StreamsWanted("vehicle reboot") in out and feed.p.reset_counter == 1
    # the evidence was handled again after the reset: the estimate starts at its first sample
    assert feed.p.started_t_s == pytest.approx(0.6)
    assert feed.p.navigator.t_s == pytest.approx(1.0)


def test_arrival_is_reported_and_the_vehicle_told_to_stop():
    feed = started()
    feed.north_m = 176.5
    for _ in range(10):
        feed.step(speed_mps=2.0)
    assert any(isinstance(o, Arrived) for o in feed.outputs)
    assert setpoints(feed.outputs)[-1].vel_north_mps == 0.0
    report = snapshot(feed.p)
    assert report["arrived"] and len(report["track"]["t_s"]) == 10


def test_speed_is_clamped_to_the_configured_limit():
    base = config(require_camera=False)
    fast = dataclasses.replace(base, commanding=dataclasses.replace(
        base.commanding, cruise_speed_mps=8.0, max_speed_mps=8.0))
    p = Pipeline(fast, GOAL)
    # the guidance asks for at most cruise; force a faster command through the commander
    feed = Feed(p)
    feed.send(hb())
    feed.step()
    sp = p.commander.setpoint(feed.t_s, GuidanceCommand(50.0, 0.0, "goal"))
    assert math.hypot(sp.vel_north_mps, sp.vel_east_mps) == pytest.approx(8.0)
    assert not p.gate.check(p.commander.setpoint(feed.t_s, GuidanceCommand(math.nan, 0.0, "goal"))).passed


def test_position_waits_for_the_attitude_of_its_own_time():
    """The stub sends LOCAL_POSITION_NED before the ATTITUDE of the same time_boot_ms.
    (The paper's model, whose yaw is the attitude's yaw exactly.)"""
    cfg = config(require_camera=False)
    cfg = dataclasses.replace(cfg, estimator=dataclasses.replace(cfg.estimator, motion_model="paper"))
    p = Pipeline(cfg, GOAL, record_track=True)
    p.handle(0.0, hb())
    p.handle(0.0, codec.Attitude(1, 1, 1.0, 0.0, 0.0))
    p.handle(0.0, codec.LocalPosition(1, 1, 1.0, 20.0, 0.0, 5.0, 0.0))
    assert p.handle(0.0, codec.LocalPosition(1, 1, 1.1, 20.5, 0.0, 5.0, 0.0)) == []   # held
    assert len(p.track) == 1
    p.handle(0.0, codec.Attitude(1, 1, 1.1, 0.2, 9.0))            # its own attitude: yaw 0.2
    assert len(p.track) == 2 and p.track[-1][3] == pytest.approx(0.2, abs=1e-3)
    # no attitude of its own before the next position: the older one, carried by its rate
    p.handle(0.0, codec.LocalPosition(1, 1, 1.2, 21.0, 0.0, 5.0, 0.0))
    p.handle(0.0, codec.LocalPosition(1, 1, 1.3, 21.5, 0.0, 5.0, 0.0))
    assert len(p.track) == 3 and p.track[-1][0] == pytest.approx(1.2)
    assert p.track[-1][3] == pytest.approx(0.2 + 0.9, abs=1e-2)
