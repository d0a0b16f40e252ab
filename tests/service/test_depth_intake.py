"""The service's own depth frames in the pipeline (companion/onboard/depth_intake.py): a frame is
placed at the pose and the tilt of its capture, not of its arrival; its time on the vehicle's
clock; refusals counted."""
import dataclasses
import math

import numpy as np
import pytest

from companion.config.service import GoalConfig
from companion.core.perception.depth_frame import CameraMount, DepthFrame, DepthIntrinsics
from companion.mavlink import codec
from companion.onboard.pipeline import Pipeline
from companion.sim.depth_camera import TruePose, render_true_m
from companion.sim.depth_render import DepthRenderer, DepthScene
from tests.service.test_pipeline import Feed, config, hb

INTR = DepthIntrinsics.from_fov(848, 480, 87.0, 58.0, 0.3, 20.0, 0.001)   # a D455
POST_RADIUS_M = 1.0


def depth_pipeline() -> Pipeline:
    base = config(require_camera=False)
    depth = dataclasses.replace(base.perception.depth, source="stub:127.0.0.1:9")
    cfg = dataclasses.replace(base, perception=dataclasses.replace(base.perception, depth=depth))
    return Pipeline(cfg, GoalConfig(500.0, 0.0, 2.0))


def frame_of_post(post_ne_m, north_m: float, t_s: float, number: int = 0) -> DepthFrame:
    """A frame without errors of one post, seen from (north_m, 0) at 10 m, level, facing north."""
    scene = DepthScene(np.array([post_ne_m], float), np.array([POST_RADIUS_M]), np.zeros(1),
                       np.array([math.inf]))
    depth_m = render_true_m(DepthRenderer(INTR), scene, TruePose(north_m, 0.0, 10.0),
                            CameraMount((0.0, 0.0, 0.0), 0.0, 0.0, 0.0))
    z16 = np.where(np.isfinite(depth_m) & (depth_m <= 20.0), np.round(depth_m * 1000.0), 0)
    return DepthFrame(number, int(round(t_s * 1000.0)), 0, INTR, z16.astype(np.uint16))


def flying(pipeline: Pipeline, steps: int = 10) -> Feed:
    feed = Feed(pipeline)
    feed.send(hb())
    for _ in range(steps):
        feed.step()
    return feed


def absorb(pipeline: Pipeline, frame: DepthFrame, t_capture_s: float):
    job = pipeline.depth.job(frame, t_capture_s, final=True)
    assert not isinstance(job, str), job
    out: list = []
    pipeline.depth.absorb(0.0, job, job.perceive(), out)
    return job


def test_a_late_frame_is_placed_at_the_pose_of_its_capture_not_of_its_arrival():
    p = depth_pipeline()
    feed = flying(p)
    t_capture_s, north_then_m = feed.t_s, feed.north_m
    post_ne = (north_then_m + 12.0, 0.0)            # 12 m ahead at the capture
    frame = frame_of_post(post_ne, north_then_m, t_capture_s)
    for _ in range(6):                              # it arrives 0.6 s (3 m of flight) later
        feed.step()
    job = absorb(p, frame, t_capture_s)
    assert job.t_estimate_s == pytest.approx(feed.t_s)
    assert job.motion.forward_m == pytest.approx(3.0, abs=0.05)
    (landmark,) = p.navigator.slam.landmarks()
    # the post's centre (the surface's median, a radius behind): where it stands, within the
    # perception's own bias; taken from the pose at arrival it would sit 3 m farther north
    assert landmark[0] == pytest.approx(post_ne[0], abs=0.6)
    assert abs(landmark[0] - (post_ne[0] + 3.0)) > 2.0
    assert p.depth.counts["frames"] == 1 and p.depth.counts["observations"] >= 1


def test_the_tilt_is_the_attitude_at_the_capture():
    p = depth_pipeline()
    feed = flying(p, 5)
    t0 = feed.t_s
    for k, roll in enumerate((0.05, -0.1, 0.2)):     # ATTITUDEs at t0+0.1, t0+0.2, t0+0.3
        t = round(t0 + 0.1 * (k + 1), 6)
        feed.send(codec.Attitude(1, 1, t, 0.0, 0.0, roll, 0.02 * (k + 1)))
        feed.send(codec.LocalPosition(1, 1, t, feed.north_m + 0.5 * (k + 1), 0.0, 5.0, 0.0,
                                      -10.0, 0.0))
    frame = frame_of_post((200.0, 0.0), feed.north_m, t0 + 0.15)
    job = p.depth.job(frame, t0 + 0.15)
    # the first ATTITUDE at or after the capture (the stub renders a step's frames with the
    # later step's tilt), not the latest (0.2) nor the one before (0.05)
    assert (job.roll_rad, job.pitch_rad) == (-0.1, pytest.approx(0.04))


def test_a_frame_before_any_attitude_of_its_time_waits_for_it():
    p = depth_pipeline()
    feed = flying(p, 5)
    frame = frame_of_post((200.0, 0.0), feed.north_m, feed.t_s + 0.05)
    assert p.depth.job(frame, feed.t_s + 0.05) == "wait"
    feed.step()
    assert not isinstance(p.depth.job(frame, feed.t_s - 0.05), str)


def test_frames_outside_the_pose_history_or_before_the_estimator_are_refused_and_counted():
    p = depth_pipeline()
    frame = frame_of_post((200.0, 0.0), 20.0, 0.0)
    assert p.depth.job(frame, 0.0, final=True) == "before_estimator"
    feed = flying(p, 40)
    assert p.depth.job(frame, feed.t_s - 3.0, final=True) == "outside_pose_history"
    assert p.depth.job(frame, feed.t_s + 1.0, final=True) == "no_attitude"
    assert dict(p.depth.counts) == {"before_estimator": 1, "outside_pose_history": 1,
                                    "no_attitude": 1}
    other = dataclasses.replace(frame, camera_id=3)
    assert p.depth.job(other, feed.t_s, final=True) == "unknown_camera"


def test_capture_time_on_the_vehicle_clock():
    p = depth_pipeline()
    feed = flying(p, 5)
    frame = frame_of_post((200.0, 0.0), 20.0, 1.234)
    assert p.depth.capture_time_s(frame, None) == pytest.approx(1.234)     # the stub's stamp
    assert p.depth.capture_time_s(frame, 7.5) == 7.5        # a recording's own (vehicle) time
    # a camera in Unix time: the first frame's offset until TIMESYNC answers
    unix_s = 1.7e9
    assert p.depth.capture_time_s(frame, unix_s) == pytest.approx(feed.t_s)
    assert p.depth.capture_time_s(frame, unix_s + 0.5) == pytest.approx(feed.t_s + 0.5)
    assert p.wants_timesync
    # once TIMESYNC has answered: its offset (vehicle clock - ours), not the first frame's
    ts1 = p.timesync.request(int(unix_s * 1e9))
    p.timesync.on_reply(int(42.0 * 1e9), ts1, ts1 + 2_000_000)       # 2 ms round trip
    assert p.depth.capture_time_s(frame, unix_s + 1.0) == pytest.approx(42.0 - 0.001 + 1.0)


def test_without_a_depth_source_the_pipeline_keeps_no_poses():
    p = Pipeline(config(require_camera=False), GoalConfig(500.0, 0.0, 2.0))
    flying(p)
    assert p.depth.history.latest_t_s is None and not p.depth.attitudes
