"""link.camera_frame_idle_s: a camera frame complete on idle time, not at the next message."""
import dataclasses

import pytest

from companion.config.service import load_config
from companion.core.estimation.slam_types import Observation
from companion.errors import ConfigError
from companion.mavlink import codec
from companion.onboard.pipeline import Pipeline
from tests.service.test_pipeline import GOAL, Feed, config, hb, setpoints

IDLE_S = 0.005


def idle_feed(idle_s=IDLE_S):
    base = config()
    cfg = dataclasses.replace(base, link=dataclasses.replace(base.link, camera_frame_idle_s=idle_s))
    feed = Feed(Pipeline(cfg, GOAL, record_track=True))
    feed.send(hb())
    feed.send(codec.ObstacleFrame(1, 100, feed.t_s, ()))
    for _ in range(3):
        feed.step()
    return feed


def test_frame_is_decided_on_once_idle_without_a_further_message():
    feed = idle_feed()
    assert feed.camera([Observation(30.0, 0.1, 7)]) == []          # in assembly
    first_report_s = feed.link_s
    deadline = feed.p.frames.idle_deadline_s()
    assert deadline == pytest.approx(first_report_s + IDLE_S)
    assert feed.p.frames.close_if_idle(deadline - 1e-4) == []          # not yet
    assert feed.p.frames.assembly is not None
    out = feed.p.frames.close_if_idle(deadline)
    assert feed.p.frames.assembly is None and feed.p.frames.idle_deadline_s() is None
    assert feed.p.navigator.slam.landmark_ids() == [7]
    sps = setpoints(out)
    assert len(sps) == 1 and sps[0].t_s == pytest.approx(feed.t_s)


def test_idle_counts_from_the_frames_last_report():
    feed = idle_feed()
    feed.camera([Observation(30.0, 0.1, 7)])
    feed.send(codec.ObstacleFrame(1, 100, feed.t_s, (Observation(25.0, -0.2, 8),)), 0.003)
    assert feed.p.frames.idle_deadline_s() == pytest.approx(feed.link_s + IDLE_S)
    assert feed.p.frames.close_if_idle(feed.link_s + 0.004) == []
    feed.p.frames.close_if_idle(feed.link_s + IDLE_S)
    assert sorted(feed.p.navigator.slam.landmark_ids()) == [7, 8]


def test_a_report_after_the_idle_close_is_counted_and_dropped():
    """The replay's view: nothing called frames.close_if_idle; the late report's stamp closes the
    frame first (as the live timer did), then the report is refused, its frame's chance taken."""
    feed = idle_feed()
    feed.camera([Observation(30.0, 0.1, 7)])
    late = codec.ObstacleFrame(1, 100, feed.t_s, (Observation(25.0, -0.2, 8),))
    out = feed.send(late, 0.02)
    assert len(setpoints(out)) == 1                 # the frame, decided on before the report
    assert feed.p.navigator.slam.landmark_ids() == [7]
    assert feed.p.counters["obstacle_after_frame_closed"] == 1
    assert feed.p.frames.assembly is None
    feed.step()                                     # the next frame is a frame again
    feed.camera([Observation(29.0, 0.1, 7)])
    assert feed.p.frames.assembly is not None


def test_replay_of_the_stamps_closes_where_the_live_timer_did():
    """Two pipelines, one closed by the timer (frames.close_if_idle), one fed the same stamps only:
    the same setpoints, in the same order."""
    live, replay = idle_feed(), idle_feed()
    for feed in (live, replay):
        feed.camera([Observation(30.0, 0.1, 7)])
    live.outputs += live.p.frames.close_if_idle(live.link_s + IDLE_S)
    for feed in (live, replay):
        feed.send(hb(), 0.01)
        for _ in range(3):
            feed.step()
    assert setpoints(live.outputs) == setpoints(replay.outputs)
    assert live.p.navigator.slam.landmark_ids() == replay.p.navigator.slam.landmark_ids() == [7]


def test_off_by_default_a_frame_waits_for_the_next_message():
    feed = Feed(Pipeline(config(), GOAL))
    assert load_config("config/companion.yaml").link.camera_frame_idle_s is None
    feed.send(hb())
    for _ in range(3):
        feed.step()
    feed.camera([Observation(30.0, 0.1, 7)])
    assert feed.p.frames.idle_deadline_s() is None
    assert feed.p.frames.close_if_idle(feed.link_s + 10.0) == []
    assert feed.p.frames.assembly is not None
    feed.send(codec.ObstacleFrame(1, 100, feed.t_s, (Observation(25.0, -0.2, 8),)), 1.0)
    feed.send(hb())
    assert sorted(feed.p.navigator.slam.landmark_ids()) == [7, 8]   # one frame, however late


@pytest.mark.parametrize("value", [0.0, -0.01, 0.6, float("nan")])
def test_a_bad_idle_time_is_refused_with_its_key(tmp_path, value):
    text = open("config/companion.yaml").read().replace(
        "camera_frame_idle_s: null", f"camera_frame_idle_s: {value}")
    path = tmp_path / "companion.yaml"
    path.write_text(text)
    with pytest.raises(ConfigError, match=r"companion.yaml.*link.camera_frame_idle_s"):
        load_config(path)
