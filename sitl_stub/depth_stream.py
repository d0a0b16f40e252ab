"""The depth stream: each frame of the stub's depth cameras to every client of a local TCP
server (``sitl-stub --depth-tcp HOST:PORT``), as documented in docs/depth.md.

One message per frame, little-endian: an 84-byte header

    magic      4s   b"DPTH"
    version    u16  1
    header     u16  84 (the header's size: a reader skips what it does not know)
    frame      u32  frame number (per camera, counting from 0 at t = 0)
    time       u32  capture time, the autopilot's time_boot_ms
    camera     u16  camera id (the index in sensor.cameras)
    width      u16  pixels
    height     u16  pixels
    encoding   u16  1 = Z16 (uint16, depth_scale units, 0 = no data)
    fx fy cx cy     f64 x 4, pixels
    min_depth  f64  metres
    max_depth  f64  metres
    scale      f64  metres per unit (0.001)
    payload    u32  bytes that follow: width x height x 2

then the pixels, row-major, uint16 little-endian. A client that falls behind by more than
MAX_BUFFERED_FRAMES frames loses frames (counted and logged), never the stub's pace. A client
that connects gets the latest capture at once (every camera's), so a lock-step peer that connects
while the stub waits for it does not miss the frames of the step it waits at.
"""
from __future__ import annotations

import asyncio
import logging
import struct
import sys

log = logging.getLogger(__name__)

MAGIC = b"DPTH"
VERSION = 1
ENCODING_Z16 = 1
HEADER = struct.Struct("<4sHHIIHHHHdddddddI")
MAX_BUFFERED_FRAMES = 8


def encode_frame(frame) -> bytes:
    """One StubDepthFrame as header + payload."""
    spec = frame.spec
    pixels = frame.pixels.astype("<u2", copy=False)
    payload = pixels.tobytes() if sys.byteorder == "little" else pixels.byteswap().tobytes()
    return HEADER.pack(MAGIC, VERSION, HEADER.size, frame.frame_number & 0xFFFFFFFF,
                       frame.time_boot_ms & 0xFFFFFFFF, frame.camera_id, spec.width_px,
                       spec.height_px, ENCODING_Z16, spec.fx_px, spec.fy_px, spec.cx_px,
                       spec.cy_px, spec.min_depth_m, spec.max_depth_m, spec.depth_scale_m,
                       len(payload)) + payload


class _Client(asyncio.Protocol):
    def __init__(self, server: "DepthServer") -> None:
        self.server = server
        self.transport: asyncio.Transport | None = None

    def connection_made(self, transport) -> None:
        self.transport = transport
        self.server.clients.add(self)
        for data in self.server.latest:
            transport.write(data)
        log.info("depth stream: client %s", transport.get_extra_info("peername"))

    def connection_lost(self, exc) -> None:
        self.server.clients.discard(self)

    def data_received(self, data: bytes) -> None:
        pass                                    # clients only listen


class DepthServer:
    """The TCP server; ``send(frames)`` writes every frame to every client."""

    def __init__(self) -> None:
        self.clients: set[_Client] = set()
        self.server: asyncio.base_events.Server | None = None
        self.sent = 0
        self.dropped = 0
        self.latest: list[bytes] = []      # the last capture's messages, for a new client

    async def start(self, host: str, port: int) -> tuple[str, int]:
        loop = asyncio.get_running_loop()
        self.server = await loop.create_server(lambda: _Client(self), host, port)
        return self.server.sockets[0].getsockname()[:2]

    def send(self, frames: list) -> None:
        messages = [encode_frame(frame) for frame in frames]
        if frames:
            last = frames[-1].frame_number
            self.latest = [data for frame, data in zip(frames, messages)
                           if frame.frame_number == last]
        for data in messages:
            for client in list(self.clients):
                transport = client.transport
                if transport is None or transport.is_closing():
                    continue
                if transport.get_write_buffer_size() > MAX_BUFFERED_FRAMES * len(data):
                    self.dropped += 1
                    if self.dropped == 1 or self.dropped % 100 == 0:
                        log.warning("depth stream: a client is behind, %d frames dropped",
                                    self.dropped)
                    continue
                transport.write(data)
                self.sent += 1

    async def close(self) -> None:
        for client in list(self.clients):
            if client.transport is not None:
                client.transport.close()
        if self.server is not None:
            self.server.close()
            await self.server.wait_closed()
