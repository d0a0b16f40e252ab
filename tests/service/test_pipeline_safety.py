"""Pipeline safety rules on synthetic streams (issue 14): one bad stamp costs nothing, the camera
is live on data only, the estimator starts and restarts on good samples, and every setpoint goes
through the gate."""
import dataclasses
import math

import pytest

from companion.mavlink import codec
from companion.core.estimation.slam_types import Observation
from companion.onboard.pipeline import Pipeline, StreamsWanted
from companion.onboard.safety.gate import SetpointGate, SetpointLimits
from tests.service.test_pipeline import GOAL, Feed, config, hb, setpoints, started


def holds(outputs):
    return [sp for sp in setpoints(outputs) if sp.reason.startswith("hold")]


def test_one_position_an_hour_ahead_is_dropped_and_the_flight_goes_on():
    feed = started()
    for _ in range(5):
        feed.step()
    nav, t_s = feed.p.navigator, feed.t_s
    cov_before = nav.slam.pose_cov.copy()
    out = feed.send(codec.LocalPosition(1, 1, t_s + 3600.0, feed.north_m, 0.0, 5.0, 0.0))
    assert not setpoints(out)
    for _ in range(5):
        out = feed.step()
        assert StreamsWanted("vehicle reboot") not in out
    assert feed.p.navigator is nav and feed.p.reset_counter == 0
    assert nav.t_s == pytest.approx(feed.t_s)
    assert nav.slam.pose_cov[0, 0] < cov_before[0, 0] + 1.0       # no hour of prediction
    assert setpoints(feed.outputs)[-1].reason == "goal"
    assert feed.p.counters["time_ahead"] == 1


def test_a_camera_frame_an_hour_ahead_then_silence_is_stale_camera():
    feed = started(require_camera=True, obstacle_timeout_s=3.5)
    for _ in range(5):
        feed.step()
    feed.p.handle(feed.link_s, codec.ObstacleFrame(1, 100, feed.t_s + 3600.0, ()))
    feed.camera_alive = False
    for _ in range(40):                                   # 4 s of camera silence
        feed.step()
    assert setpoints(feed.outputs)[-1].reason == "hold: obstacle data stale"
    assert feed.p.counters["obstacle_time_ahead"] == 1


def test_a_camera_that_only_heartbeats_is_stale():
    feed = Feed(Pipeline(config(require_camera=True, obstacle_timeout_s=1.0), GOAL))
    feed.camera_alive = False
    feed.send(hb())
    for _ in range(20):
        feed.send(codec.Heartbeat(1, 100, 30, False, False, 0))       # camera heartbeat
        feed.step()
    sps = setpoints(feed.outputs)
    assert sps and all(sp.reason == "hold: obstacle data stale" for sp in sps)


def test_an_epoch_stamped_camera_is_mapped_to_vehicle_time_with_one_notice():
    feed = started(require_camera=True, obstacle_timeout_s=1.0)
    feed.camera_alive = False
    for _ in range(3):
        feed.step()
    unix_at_start = 1_764_000_000.0
    notices = []
    for i in range(30):
        out = feed.step()
        frame_t = unix_at_start + (feed.t_s - 10.3)        # the camera's own Unix clock
        rel_north = 60.0 - feed.north_m                     # a static obstacle at (60, 3)
        seen = Observation(math.hypot(rel_north, 3.0), math.atan2(3.0, rel_north), 7)
        out += feed.p.handle(feed.link_s, codec.ObstacleFrame(1, 100, frame_t, (seen,)))
        notices += [o.text for o in out if isinstance(o, codec.Notice)]
    assert feed.p.navigator.slam.landmark_ids() == [7]
    assert sum("Unix time" in t for t in notices) == 1
    assert setpoints(feed.outputs)[-1].reason != "hold: obstacle data stale"
    for _ in range(15):                                   # then silence: stale as any camera
        feed.step()
    assert setpoints(feed.outputs)[-1].reason == "hold: obstacle data stale"


def test_a_nan_first_attitude_does_not_start_the_estimator_the_next_good_one_does():
    feed = started()
    feed.t_s += 0.1
    feed.send(codec.Attitude(1, 1, feed.t_s, math.nan, 0.0))
    feed.send(codec.LocalPosition(1, 1, feed.t_s, feed.north_m, 0.0, 5.0, 0.0))
    assert feed.p.navigator is None
    for _ in range(5):
        feed.step()
    nav = feed.p.navigator
    assert nav is not None and nav.slam.is_healthy()
    assert all(math.isfinite(sp.yaw_rad) for sp in setpoints(feed.outputs))
    assert setpoints(feed.outputs)[-1].reason == "goal"


def test_an_absurd_start_position_is_refused():
    feed = started()
    feed.t_s += 0.1
    feed.send(codec.Attitude(1, 1, feed.t_s, 0.0, 0.0))
    feed.send(codec.LocalPosition(1, 1, feed.t_s, 20.0, 3.4e38, 5.0, 0.0))
    feed.send(codec.Attitude(1, 1, feed.t_s + 0.05, 0.0, 0.0))
    assert feed.p.navigator is None
    assert feed.p.counters["start_implausible"] == 1
    feed.step()
    assert feed.p.navigator is not None
    assert abs(float(feed.p.navigator.slam.pose[1])) < 1.0


def test_a_diverged_estimator_restarts_from_the_next_sample():
    feed = started()
    for _ in range(3):
        feed.step()
    feed.p.navigator.slam._cov_buf[0, 0] = math.nan
    out = feed.step()
    assert holds(out) and feed.p.navigator is None
    for _ in range(3):
        feed.step()
    assert feed.p.navigator is not None and feed.p.navigator.slam.is_healthy()
    assert setpoints(feed.outputs)[-1].reason == "goal"
    assert feed.p.counters["estimator_restarts"] == 1 and feed.p.reset_counter == 1


def test_a_setpoint_the_gate_refuses_is_replaced_by_the_safe_action_and_counted():
    feed = started()
    feed.p.gate = SetpointGate(SetpointLimits(max_speed_mps=1.0))   # guidance asks 5 m/s
    for _ in range(3):
        feed.step()
    sps = setpoints(feed.outputs)
    assert sps and all(sp.reason.startswith("hold: setpoint refused") for sp in sps)
    assert feed.p.gate.refused["speed above max_speed_mps"] >= 3


def test_nothing_bypasses_the_gate_even_the_hold_or_the_stop():
    feed = started()
    for _ in range(3):
        feed.step()
    feed.p.ap_yaw_rad = math.nan                # whatever the state, NaN never leaves
    out = []
    feed.p.commander.safe(feed.link_s, feed.t_s, "test", out)
    out += feed.p.stop_setpoint(feed.link_s)
    assert setpoints(out) == []
    assert feed.p.gate.refused["yaw_rad not finite"] == 2


def test_stop_setpoint_is_zero_velocity_at_the_current_yaw_only_while_commanding():
    feed = started()
    for _ in range(3):
        feed.step(yaw_rad=0.3)
    (sp,) = feed.p.stop_setpoint(feed.link_s)
    assert (sp.vel_north_mps, sp.vel_east_mps, sp.reason) == (0.0, 0.0, "stop")
    assert sp.yaw_rad == pytest.approx(0.3)
    feed.step(heartbeat=hb(mode=5))
    assert feed.p.stop_setpoint(feed.link_s) == []


def test_obstacle_bounds_refused_by_the_codec_are_counted_and_do_not_feed_liveness():
    feed = started(require_camera=True, obstacle_timeout_s=1.0)
    feed.camera_alive = False
    for _ in range(3):
        feed.step()
    for _ in range(20):
        feed.p.handle(feed.link_s, codec.ObstacleFrame(1, 100, feed.t_s, (),
                                                        "non-finite distance bounds"))
        feed.step()
    assert feed.p.counters["obstacle_rejected"] == 20
    assert setpoints(feed.outputs)[-1].reason == "hold: obstacle data stale"


def test_after_the_stop_setpoint_nothing_is_sent():
    feed = started()
    for _ in range(3):
        feed.step()
    assert len(feed.p.stop_setpoint(feed.link_s)) == 1
    for _ in range(3):
        assert setpoints(feed.step()) == []
    assert feed.p.counters["setpoint_after_stop"] == 3
