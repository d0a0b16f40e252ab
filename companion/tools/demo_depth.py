"""``companion demo --depth-record FILE.db3``: the stub's depth stream recorded beside the flight
(``companion depth-record --stub``, the RealSense SDK's bag), for ``companion replay --depth
realsense-bag:FILE.db3``.

The recorder connects before the companion starts (the stub holds the vehicle's time at 0 until
the companion's first ODOMETRY, so it misses no frame), and ends by itself when the stub closes
the stream: it is stopped after the stub, never with it, so that it closes the bag.
"""
from __future__ import annotations

import asyncio
import sys
from pathlib import Path

READY_TIMEOUT_S = 30.0
FINISH_TIMEOUT_S = 60.0
MAX_FRAMES = 10_000_000        # the stream's end ends the recording


async def start_recorder(spawn, depth_address: str, path: Path, workdir: Path, stub):
    """Spawn the recorder; return it once the stub has seen it connect (its log says so)."""
    recorder = await spawn("depth-record", [
        sys.executable, "-m", "companion", "depth-record", "--stub", depth_address,
        "--frames", str(MAX_FRAMES), "--realsense", str(path)], workdir)
    clients = _clients(stub)
    try:
        async with asyncio.timeout(READY_TIMEOUT_S):
            while _clients(stub) <= clients:
                recorder.check_alive()
                await asyncio.sleep(0.05)
    except TimeoutError:
        await recorder.stop()
        raise
    return recorder


def _clients(stub) -> int:
    try:
        return stub.stderr_path.read_text(errors="replace").count("depth stream: client")
    except OSError:
        return 0


async def finish_recorder(recorder) -> int | None:
    """After the stub has stopped: the recorder's own exit (the bag closed), else SIGTERM."""
    try:
        async with asyncio.timeout(FINISH_TIMEOUT_S):
            return await recorder.proc.wait()
    except TimeoutError:
        return await recorder.stop()
