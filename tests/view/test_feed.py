"""The view feed's content: blocked sectors worked out by hand, the path decimation, datagram
size, the decoder's refusals, and the service's sender with nobody listening."""
from __future__ import annotations

import asyncio
import json
import math
import socket
from types import SimpleNamespace

import numpy as np
import pytest

from companion.config.service import load_config
from companion.core.avoidance.guidance import GuidanceParams
from companion.core.avoidance.union import UnionParams
from companion.errors import ConfigError
from companion.config.paths import resolve_config
from companion.onboard.pipeline import Pipeline
from companion.view import feed


def fake_nav(obstacles, pose=(0.0, 0.0, 0.0), goal=(200.0, 0.0), eta=1.25):
    obstacles = np.array(obstacles, dtype=float).reshape(-1, 2)
    params = GuidanceParams(cruise_speed_mps=5.0, safety_distance_m=10.0, horizon_s=4.0,
                            eta=eta, goal_radius_m=2.0)
    return SimpleNamespace(obstacles=lambda: (obstacles, None, None, []), params=params,
                           goal=np.array(goal), slam=SimpleNamespace(pose=np.array(pose)),
                           union=UnionParams(lookahead_s=6.0))


def test_an_obstacle_ahead_blocks_eta_times_its_tangent_angle_either_side():
    # 20 m north, d = 10 m: tangent angle asin(10/20) = 30 deg, times eta 1.25 = 37.5 deg, so
    # sector centres within +-35 deg of north are blocked (k = 65..71, 0..7): 15 sectors.
    blocked = feed.blocked_sectors(fake_nav([[20.0, 0.0]]), cruise_mps=5.0)
    assert sorted(blocked) == list(range(0, 8)) + list(range(65, 72))


def test_an_obstacle_beyond_the_lookahead_blocks_nothing():
    # circle 40 m - 10 m = 30 m away; 5 m/s x 6 s = 30 m reach: not nearer than the reach
    assert feed.blocked_sectors(fake_nav([[40.0, 0.0]]), cruise_mps=5.0) == []
    assert feed.blocked_sectors(fake_nav([]), cruise_mps=5.0) == []


def test_an_obstacle_east_blocks_the_sectors_around_ninety_degrees():
    blocked = feed.blocked_sectors(fake_nav([[0.0, 20.0]]), cruise_mps=5.0)
    assert sorted(blocked) == list(range(18 - 7, 18 + 8))


def test_the_path_cursor_sends_each_pose_once_one_per_step():
    cursor = feed.PathCursor()
    track = [(0.1 * i, float(i), 0.0) for i in range(10)]          # 10 Hz rows
    first = cursor.take(track)
    assert first == [[0.0, 0.0], [2.0, 0.0], [4.0, 0.0], [6.0, 0.0], [8.0, 0.0]]
    assert cursor.take(track) == []
    track += [(0.1 * i, float(i), 0.0) for i in range(10, 14)]
    assert cursor.take(track) == [[10.0, 0.0], [12.0, 0.0]]


def big_state(landmarks: int) -> dict:
    return {"feed": feed.FEED_VERSION, "seq": 1, "pose": {"north_m": 0.0, "east_m": 0.0},
            "landmarks": [{"id": i, "north_m": float(i), "east_m": 0.5, "cov_m2": [0.1, 0.0, 0.1]}
                          for i in range(landmarks)],
            "movers": [], "path_ne_m": [], "blocked": []}


def test_a_map_too_big_for_one_datagram_keeps_the_nearest_landmarks():
    data = feed.encode(big_state(3000))
    assert len(data) <= feed.MAX_DATAGRAM_BYTES
    state = feed.decode(data)
    kept = [m["id"] for m in state["landmarks"]]
    assert kept == list(range(len(kept))) and 0 < len(kept) < 3000
    assert state["landmarks_left_out"] == 3000 - len(kept)
    assert len(feed.encode(big_state(10))) < 2000        # small maps go whole


@pytest.mark.parametrize("data, problem", [
    (b"\xff\xfe", "not JSON"), (b"[1, 2]", "not a companion-view/1"),
    (json.dumps({"feed": "other/9"}).encode(), "not a companion-view/1"),
    (json.dumps({**big_state(1), "landmarks": {}}).encode(), "landmarks: expected a list"),
    (json.dumps({**big_state(1), "t_s": math.inf}).encode(), "non-finite number Infinity"),
])
def test_the_decoder_refuses_what_is_not_a_feed_datagram(data, problem):
    with pytest.raises(ValueError, match=problem):
        feed.decode(data)


@pytest.mark.parametrize("text", ["nohost", "127.0.0.1:x", "127.0.0.1:70000", ":5"])
def test_a_bad_feed_address_names_the_option(text):
    with pytest.raises(ConfigError, match="--view-feed: expected HOST:PORT"):
        feed.parse_address(text, "--view-feed")
    assert feed.parse_address("udp:10.0.0.2:14660", "x") == ("10.0.0.2", 14660)


def idle_pipeline() -> Pipeline:
    config = load_config(resolve_config("config/companion.yaml"))
    return Pipeline(config, None)


def test_the_service_sender_reaches_a_listener_and_survives_none():
    pipeline = idle_pipeline()

    async def scenario():
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as listener:
            listener.bind(("127.0.0.1", 0))
            listener.setblocking(False)
            port = listener.getsockname()[1]
            sender = asyncio.create_task(feed.publish(pipeline, ("127.0.0.1", port), 50.0))
            loop = asyncio.get_running_loop()
            async with asyncio.timeout(5):
                states = [feed.decode(await loop.sock_recv(listener, 65536)) for _ in range(3)]
        # the listener is gone: loopback answers 'port unreachable'; the sender goes on
        await asyncio.sleep(0.2)
        assert not sender.done()
        sender.cancel()
        return states
    states = asyncio.run(scenario())
    assert [s["seq"] for s in states] == [1, 2, 3]
    assert states[0]["pose"] is None and states[0]["landmarks"] == [] and states[0]["t_s"] is None
    assert states[0]["sectors"] == feed.SECTORS and math.isfinite(states[0]["safety_distance_m"])


def test_the_path_cursor_starts_over_when_the_vehicle_clock_restarts():
    cursor = feed.PathCursor()
    cursor.take([(100.0 + 0.1 * i, float(i), 0.0) for i in range(5)])
    after_reboot = [(100.0 + 0.1 * i, float(i), 0.0) for i in range(5)] + [(0.5, 7.0, 7.0)]
    assert cursor.take(after_reboot) == [[7.0, 7.0]]


def test_a_fault_in_the_feed_stops_the_feed_not_the_service(monkeypatch, caplog):
    calls = []

    def broken(pipeline, seq, cursor):
        calls.append(seq)
        if seq == 1:
            return {**big_state(1), "t_s": math.nan}       # not JSON: skipped
        raise KeyError("a bug")

    monkeypatch.setattr(feed, "feed_state", broken)

    async def scenario():
        async with asyncio.timeout(5):
            await feed.publish(idle_pipeline(), ("127.0.0.1", 9), 100.0)   # returns, no raise
    asyncio.run(scenario())
    assert calls == [1, 2]
    assert "not sent" in caplog.text and "view feed stopped" in caplog.text
