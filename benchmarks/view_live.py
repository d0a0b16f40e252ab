"""The live view during a real-time flight: how often the page redraws, and a screenshot.

    python -m benchmarks.view_live [--speedup 1] [--shot-north-m 108] [--shot docs/view.png]

Starts `companion view` and `companion demo --no-lockstep --speedup S --view-feed` (the stub on
the wall clock, so the flight takes real time), opens the page in headless Chromium and counts
the page's redraws and the feed datagrams it drew over the flight, then prints their rates
(per wall second). With --shot, takes the screenshot once the estimated pose passes
--shot-north-m (the paper's second obstacle is at 120 m north).
"""
from __future__ import annotations

import argparse
import asyncio
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from tests.view.browser import open_page
from tests.view.test_view_demo import start_view

PROBE = """(() => { const m = document.getElementById('map'); const v = window.companionView;
  return {updates: Number(m.dataset.updates), seq: Number(m.dataset.seq || 0),
          north: v.state && v.state.pose ? v.state.pose.north_m : null,
          arrived: !!(v.state && v.state.arrived)}; })()"""


async def watch(url: str, demo: subprocess.Popen, shot: Path | None, shot_north_m: float,
                width: int, height: int) -> list[tuple[float, dict]]:
    samples, taken = [], shot is None
    async with open_page(url, width, height) as page:
        while demo.poll() is None:
            probe = await page.evaluate(PROBE)
            if probe is None:                  # the page is still loading
                await asyncio.sleep(0.05)
                continue
            samples.append((time.monotonic(), probe))
            if not taken and probe["north"] is not None and probe["north"] >= shot_north_m:
                await page.screenshot(shot)
                taken = True
                print(f"screenshot at north {probe['north']:.1f} m: {shot}")
            await asyncio.sleep(0.05)
    return samples


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--speedup", type=float, default=1.0)
    parser.add_argument("--shot", type=Path)
    parser.add_argument("--shot-north-m", type=float, default=108.0)
    parser.add_argument("--size", default="1280x720", help="page size, WIDTHxHEIGHT")
    args = parser.parse_args()
    width, height = (int(v) for v in args.size.split("x"))
    with tempfile.TemporaryDirectory(prefix="view-live-") as tmp:
        work = Path(tmp)
        view, url, feed_port = start_view(work, "--source", "udp:127.0.0.1:0",
                                          "--truth", str(work / "truth.jsonl"))
        try:
            demo = subprocess.Popen(
                [sys.executable, "-m", "companion", "demo", "--no-lockstep", "--speedup",
                 str(args.speedup), "--keep", str(work), "--view-feed", f"127.0.0.1:{feed_port}"],
                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
            samples = asyncio.run(watch(url, demo, args.shot, args.shot_north_m, width, height))
        finally:
            view.stop()
    moving = [(t, p) for t, p in samples if p["north"] is not None and not p["arrived"]]
    if len(moving) < 2:
        print("the flight was not seen moving")
        return 1
    (t0, p0), (t1, p1) = moving[0], moving[-1]
    span_s = t1 - t0
    print(f"flight seen for {span_s:.1f} s of wall time: {(p1['updates'] - p0['updates']) / span_s:.1f}"
          f" redraws/s, {(p1['seq'] - p0['seq']) / span_s:.1f} feed datagrams drawn/s "
          f"(speedup {args.speedup:g})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
