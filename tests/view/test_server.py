"""The view's HTTP endpoints and its live stream, with aiohttp's client over loopback, fed by
datagrams over a real UDP socket. Every wait is bounded."""
from __future__ import annotations

import asyncio
import json

import aiohttp

from companion.view.model import MAX_PATH_POINTS
from tests.view.support import running_view, state

TIMEOUT_S = 10.0


async def wait_for(condition, poll_s: float = 0.01):
    async with asyncio.timeout(TIMEOUT_S):
        while not (value := condition()):
            await asyncio.sleep(poll_s)
        return value


def test_the_page_and_its_assets_are_served_from_the_package():
    async def scenario():
        async with running_view() as (_, url, _sender), aiohttp.ClientSession() as http:
            async with http.get(url + "/") as r:
                page = (r.status, r.content_type, await r.text())
            async with http.get(url + "/static/view.js") as r:
                script = (r.status, r.content_type, await r.text())
            async with http.get(url + "/static/view.css") as r:
                style = (r.status, r.content_type)
            async with http.get(url + "/static/../server.py") as r:
                escape = r.status
            async with http.get(url + "/nothing") as r:
                missing = r.status
        return page, script, style, escape, missing
    page, script, style, escape, missing = asyncio.run(scenario())
    assert page[:2] == (200, "text/html") and '<svg id="map"' in page[2]
    assert '/static/view.js' in page[2] and "http" not in page[2].replace("http-equiv", "")
    assert script[:2] == (200, "application/javascript") or script[1] == "text/javascript"
    assert 'new EventSource("/api/stream")' in script[2]
    assert style == (200, "text/css")
    assert escape in (403, 404) and missing == 404


def test_state_reflects_the_feed_and_bad_datagrams_are_counted_and_dropped():
    async def scenario():
        async with running_view() as (model, url, sender), aiohttp.ClientSession() as http:
            async with http.get(url + "/api/state") as r:
                empty = await r.json()
            sender.send(state(1, path=[(0, 0), (5, 0)], landmarks=[(60, 5), (120, 0)],
                              blocked=[0, 1, 71]))
            sender.send(b"not json at all")
            sender.send(json.dumps({"feed": "something-else"}).encode())
            await wait_for(lambda: model.datagrams == 1 and model.refused == 2)
            async with http.get(url + "/api/state") as r:
                return empty, r.headers["Cache-Control"], await r.json()
    empty, cache, full = asyncio.run(scenario())
    assert empty["state"] is None and empty["estimated_path"]["points"] == []
    assert cache == "no-store"
    assert [(m["north_m"], m["east_m"]) for m in full["state"]["landmarks"]] == [(60, 5), (120, 0)]
    assert full["state"]["blocked"] == [0, 1, 71]
    # the path, then the pose the datagram ended on
    assert full["estimated_path"]["points"] == [[0, 0], [5, 0], [10.0, 2.0]]
    assert full["info"]["refused"] == 2 and "not JSON" not in full["info"]["last_refusal"]


async def read_events(response, count: int) -> list[dict]:
    """The next ``count`` data events of an SSE response (comments skipped)."""
    events, data = [], []
    async with asyncio.timeout(TIMEOUT_S):
        async for raw in response.content:
            line = raw.decode().rstrip("\n")
            if line.startswith("data: "):
                data.append(line[6:])
            elif line == "" and data:
                events.append(json.loads("\n".join(data)))
                data = []
                if len(events) == count:
                    return events
    raise AssertionError(f"stream ended after {len(events)} events")


def test_the_stream_sends_the_whole_picture_then_only_what_is_new():
    async def scenario():
        async with running_view() as (model, url, sender), aiohttp.ClientSession() as http:
            sender.send(state(1, path=[(0, 0), (1, 0)], landmarks=[(60, 5)], pose=(2, 0, 0)))
            await wait_for(lambda: model.datagrams == 1)
            async with http.get(url + "/api/stream") as r:
                assert r.content_type == "text/event-stream"
                first = await read_events(r, 1)
                later = []
                for seq in (2, 3):
                    sender.send(state(seq, path=[(seq + 1, 0)], landmarks=[(60, 5), (120, 0)],
                                      pose=(seq + 1.5, 0, 0)))
                    await wait_for(lambda: model.datagrams == seq)
                    later += await read_events(r, 1)
        return first, later
    (first,), later = asyncio.run(scenario())
    assert first["estimated_path"]["from"] == 0
    assert first["estimated_path"]["points"] == [[0, 0], [1, 0], [2, 0]]
    assert len(first["state"]["landmarks"]) == 1
    path = list(first["estimated_path"]["points"])
    for event in later:
        delta = event["estimated_path"]
        assert delta["from"] == len(path) and delta["epoch"] == first["estimated_path"]["epoch"]
        path += delta["points"]
    assert path == [[0, 0], [1, 0], [2, 0], [3, 0], [3.5, 0], [4, 0], [4.5, 0]]
    assert [e["state"]["seq"] for e in later] == [2, 3]
    assert len(later[-1]["state"]["landmarks"]) == 2


def test_a_new_flight_starts_a_new_path_on_the_stream():
    async def scenario():
        async with running_view() as (model, url, sender), aiohttp.ClientSession() as http:
            sender.send(state(7, path=[(0, 0), (10, 0)], pose=(10, 0, 0)))
            await wait_for(lambda: model.datagrams == 1)
            async with http.get(url + "/api/stream") as r:
                (before,) = await read_events(r, 1)
                sender.send(state(1, path=[(50, 50)], pose=(51, 50, 0)))   # service restarted
                await wait_for(lambda: model.datagrams == 2)
                (after,) = await read_events(r, 1)
        return before, after, model.flights
    before, after, flights = asyncio.run(scenario())
    assert after["estimated_path"]["epoch"] != before["estimated_path"]["epoch"]
    assert after["estimated_path"]["from"] == 0
    assert after["estimated_path"]["points"] == [[50, 50], [51, 50]]
    assert flights == 2


def test_a_long_path_is_thinned_and_clients_get_it_whole_again():
    async def scenario():
        async with running_view() as (model, url, sender), aiohttp.ClientSession() as http:
            async with http.get(url + "/api/stream") as r:
                await read_events(r, 1)
                seq, north = 0, 0.0
                while len(model.estimated.points) + 401 <= MAX_PATH_POINTS:
                    seq += 1
                    path = [(north + i, 0.0) for i in range(400)]
                    north += 400
                    sender.send(state(seq, path=path, pose=(north, 0.0, 0.0)))
                    await wait_for(lambda: model.datagrams == seq)
                epoch = model.estimated.epoch
                seq += 1
                sender.send(state(seq, path=[(north + i, 0.0) for i in range(400)],
                                  pose=(north + 400, 0, 0)))
                await wait_for(lambda: model.estimated.epoch != epoch)
                while True:
                    (event,) = await read_events(r, 1)
                    if event["state"]["seq"] == seq:
                        return event, len(model.estimated.points)
    event, kept = asyncio.run(scenario())
    assert event["estimated_path"]["from"] == 0 and len(event["estimated_path"]["points"]) == kept
    assert kept <= MAX_PATH_POINTS
