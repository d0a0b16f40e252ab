"""Where the view's data comes from: the service's UDP feed, a tlog replayed at a pace, the truth
log of a simulated flight. Each puts what it reads into the ViewModel; bad input is counted and
dropped."""
from __future__ import annotations

import asyncio
import json
import logging
import threading
import time
from pathlib import Path

from companion.view import feed
from companion.view.model import ViewModel

log = logging.getLogger(__name__)

TRUTH_POLL_S = 0.1
REPLAY_FEED_PERIOD_S = 1.0 / feed.FEED_RATE_HZ


class FeedProtocol(asyncio.DatagramProtocol):
    def __init__(self, model: ViewModel) -> None:
        self.model = model

    def datagram_received(self, data: bytes, addr) -> None:
        try:
            state = feed.decode(data)
        except ValueError as exc:
            self.model.on_refused(f"{addr[0]}:{addr[1]}: {exc}")
            log.debug("feed datagram refused: %s", exc)
            return
        self.model.on_feed(state)


async def listen_feed(model: ViewModel, host: str, port: int):
    """Bind the feed's UDP port; returns (transport, the port actually bound)."""
    loop = asyncio.get_running_loop()
    transport, _ = await loop.create_datagram_endpoint(lambda: FeedProtocol(model),
                                                       local_addr=(host, port))
    return transport, transport.get_extra_info("sockname")[1]


async def follow_truth(model: ViewModel, path: Path) -> None:
    """Tail a truth log (JSON lines): new lines as they come; a new or shorter file starts the
    true path again (the next `companion demo` in the same directory)."""
    identity, offset, pending = None, 0, b""
    while True:
        try:
            stat = path.stat()
        except FileNotFoundError:
            await asyncio.sleep(TRUTH_POLL_S)
            continue
        restarted = False
        if identity != (stat.st_dev, stat.st_ino) or stat.st_size < offset:
            restarted = identity is not None
            identity, offset, pending = (stat.st_dev, stat.st_ino), 0, b""
        if stat.st_size > offset or restarted:
            with open(path, "rb") as f:
                f.seek(offset)
                chunk = f.read()
            offset += len(chunk)
            *lines, pending = (pending + chunk).split(b"\n")
            records = []
            for line in lines:
                try:
                    record = json.loads(line)
                except ValueError:
                    continue
                if isinstance(record, dict):
                    records.append(record)
            model.on_truth(records, restarted)
        await asyncio.sleep(TRUTH_POLL_S)


class ReplayFeed:
    """``companion replay`` of a tlog in a worker thread, at ``pace`` times the log's time,
    building the same feed datagrams as the live service (feed.feed_state) every 0.1 s of wall
    time and handing them to the model on the event loop."""

    def __init__(self, model: ViewModel, tlog: Path, config, pace: float) -> None:
        if pace <= 0:
            raise ValueError(f"pace must be > 0, got {pace}")
        self.model, self.tlog, self.config, self.pace = model, tlog, config, pace
        self._stop = threading.Event()

    async def run(self) -> None:
        loop = asyncio.get_running_loop()
        try:
            await asyncio.to_thread(self._replay, loop)
        finally:
            self._stop.set()

    def _replay(self, loop: asyncio.AbstractEventLoop) -> None:
        from companion.daemon.replay import replay_tlog
        cursor = feed.PathCursor()
        started = time.monotonic()
        marks = {"first_us": None, "next_s": 0.0, "seq": 0, "pipeline": None}

        def hand_over(pipeline) -> None:
            marks["seq"] += 1
            state = json.loads(feed.encode(feed.feed_state(pipeline, marks["seq"], cursor)))
            loop.call_soon_threadsafe(self.model.on_feed, state)

        def on_inbound(t_us: int, pipeline) -> None:
            if self._stop.is_set():
                raise _Stopped()
            marks["pipeline"] = pipeline
            if marks["first_us"] is None:
                marks["first_us"] = t_us
            due_s = (t_us - marks["first_us"]) / 1e6 / self.pace
            wait_s = due_s - (time.monotonic() - started)
            if wait_s > 0:
                self._stop.wait(wait_s)
            if time.monotonic() - started >= marks["next_s"]:
                marks["next_s"] = time.monotonic() - started + REPLAY_FEED_PERIOD_S
                hand_over(pipeline)
        try:
            replay_tlog(self.tlog, self.config, on_inbound=on_inbound)
        except _Stopped:
            return
        if marks["pipeline"] is not None:
            hand_over(marks["pipeline"])
        loop.call_soon_threadsafe(self._finished)

    def _finished(self) -> None:
        self.model.finished = True
        self.model.version += 1

    def stop(self) -> None:
        self._stop.set()


class _Stopped(Exception):
    pass
