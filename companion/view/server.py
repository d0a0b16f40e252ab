"""The view's HTTP side (aiohttp): the page, its assets, the state as JSON, and a live stream.

  GET /              the page (companion/view/static/index.html)
  GET /static/...    its script and style, shipped in the package: nothing from the network
  GET /api/state     everything now, paths whole (JSON)
  GET /api/stream    Server-Sent Events: the whole picture first, then what changed, at most
                     STREAM_RATE_HZ; a comment every KEEPALIVE_S keeps proxies and phones awake

SSE rather than WebSocket: one direction is all the page needs, and browsers reconnect an
EventSource by themselves when the laptop sleeps or the phone changes network.
"""
from __future__ import annotations

import asyncio
import json
import logging
from importlib import resources

from aiohttp import web

from companion.view.model import ViewModel

log = logging.getLogger(__name__)

STREAM_RATE_HZ = 10.0
KEEPALIVE_S = 5.0
STATIC = resources.files("companion.view") / "static"
NO_STORE = {"Cache-Control": "no-store"}
MODEL_KEY = web.AppKey("model", ViewModel)


def _json(data: dict) -> str:
    return json.dumps(data, separators=(",", ":"), allow_nan=False)


async def index(request: web.Request) -> web.Response:
    return web.Response(text=(STATIC / "index.html").read_text(), content_type="text/html",
                        headers=NO_STORE)


async def state(request: web.Request) -> web.Response:
    return web.Response(text=_json(request.app[MODEL_KEY].full()),
                        content_type="application/json", headers=NO_STORE)


async def stream(request: web.Request) -> web.StreamResponse:
    model = request.app[MODEL_KEY]
    response = web.StreamResponse(headers={"Content-Type": "text/event-stream",
                                           "Cache-Control": "no-store",
                                           "X-Accel-Buffering": "no"})
    await response.prepare(request)
    sent: dict = {}
    version, quiet_s = None, 0.0
    period_s = 1.0 / STREAM_RATE_HZ
    try:
        while True:
            if model.version != version:
                version = model.version
                await response.write(f"data: {_json(model.delta(sent))}\n\n".encode())
                quiet_s = 0.0
            elif quiet_s >= KEEPALIVE_S:
                await response.write(b": keepalive\n\n")
                quiet_s = 0.0
            await asyncio.sleep(period_s)
            quiet_s += period_s
    except ConnectionResetError:        # the browser went away: its stream ends here
        log.debug("stream closed by %s", request.remote)
    return response


def make_app(model: ViewModel) -> web.Application:
    app = web.Application()
    app[MODEL_KEY] = model
    app.router.add_get("/", index)
    app.router.add_get("/api/state", state)
    app.router.add_get("/api/stream", stream)
    app.router.add_static("/static/", str(STATIC), append_version=False)
    return app


async def start_server(model: ViewModel, host: str, port: int) -> tuple[web.AppRunner, int]:
    """Serve on host:port (0: any free port); returns the runner and the port bound."""
    runner = web.AppRunner(make_app(model), access_log=None, shutdown_timeout=1.0)
    await runner.setup()
    site = web.TCPSite(runner, host, port)
    await site.start()
    return runner, runner.addresses[0][1]
