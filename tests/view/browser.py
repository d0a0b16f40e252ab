"""Headless Chromium driven over its DevTools protocol (a WebSocket, with aiohttp's client): load
a page, evaluate JavaScript in it, take a screenshot. Debian's chromium, flags as the machine's
notes give them (no background networking: this machine's network is closed)."""
from __future__ import annotations

import asyncio
import base64
import itertools
import json
import shutil
import subprocess
import tempfile
from contextlib import asynccontextmanager
from pathlib import Path

import aiohttp

CHROMIUM = Path("/usr/bin/chromium")
START_TIMEOUT_S = 20.0
FLAGS = ("--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync",
         "--hide-scrollbars", "--force-device-scale-factor=1", "--remote-debugging-port=0")


class Page:
    def __init__(self, ws) -> None:
        self.ws = ws
        self._ids = itertools.count(1)

    async def call(self, method: str, **params) -> dict:
        call_id = next(self._ids)
        await self.ws.send_json({"id": call_id, "method": method, "params": params})
        while True:
            msg = json.loads((await self.ws.receive()).data)
            if msg.get("id") == call_id:
                if "error" in msg:
                    raise RuntimeError(f"{method}: {msg['error']}")
                return msg["result"]

    async def evaluate(self, expression: str):
        result = await self.call("Runtime.evaluate", expression=expression, returnByValue=True)
        return result["result"].get("value")

    async def wait_for(self, expression: str, timeout_s: float, poll_s: float = 0.1):
        """Evaluate until truthy; returns the value (TimeoutError after ``timeout_s``)."""
        async with asyncio.timeout(timeout_s):
            while not (value := await self.evaluate(expression)):
                await asyncio.sleep(poll_s)
            return value

    async def screenshot(self, path: Path) -> None:
        data = (await self.call("Page.captureScreenshot", format="png"))["data"]
        path.write_bytes(base64.b64decode(data))


async def _page_socket(http: aiohttp.ClientSession, profile: Path) -> str:
    """The DevTools WebSocket of Chromium's first page, once it has one."""
    port_file = profile / "DevToolsActivePort"
    while not port_file.exists() or len(port_file.read_text().split()) < 2:
        await asyncio.sleep(0.05)
    port = int(port_file.read_text().split()[0])
    while True:
        async with http.get(f"http://127.0.0.1:{port}/json/list") as r:
            pages = [t for t in await r.json() if t["type"] == "page"]
        if pages:
            return pages[0]["webSocketDebuggerUrl"]
        await asyncio.sleep(0.05)


@asynccontextmanager
async def open_page(url: str, width: int = 1280, height: int = 720):
    """Chromium on ``url`` at width x height CSS pixels; yields a Page; kills it afterwards."""
    profile = Path(tempfile.mkdtemp(prefix="view-chromium-"))
    proc = subprocess.Popen([str(CHROMIUM), *FLAGS, f"--user-data-dir={profile}",
                             f"--window-size={width},{height}", url],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        async with aiohttp.ClientSession() as http:
            async with asyncio.timeout(START_TIMEOUT_S):       # the start only
                ws_url = await _page_socket(http, profile)
            async with http.ws_connect(ws_url, max_msg_size=0) as ws:
                page = Page(ws)
                await page.call("Emulation.setDeviceMetricsOverride", width=width,
                                height=height, deviceScaleFactor=1, mobile=width < 600)
                yield page
    finally:
        proc.kill()
        proc.wait()
        shutil.rmtree(profile, ignore_errors=True)
