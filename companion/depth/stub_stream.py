"""The stub's depth stream (``sitl-stub --depth-tcp HOST:PORT``, docs/depth.md) as DepthFrames.

The companion's own reader of the documented wire format (the stub's writer is
sitl_stub/depth_stream.py; neither imports the other). One message per frame, little-endian:
an 84-byte header (magic b"DPTH", version 1, header size, frame number, time_boot_ms, camera id,
width, height, encoding 1 = Z16, fx, fy, cx, cy, min and max depth, depth scale, payload size)
then width x height uint16 pixels, row-major.

    async with open_stub_stream("127.0.0.1", port) as stream:
        async for frame in stream:          # DepthFrame, until the stub closes
            ...

or, blocking: ``read_frame(sock.makefile("rb"))`` (None at the end of the stream).
"""
from __future__ import annotations

import asyncio
import struct
from contextlib import asynccontextmanager
from dataclasses import dataclass

import numpy as np

from companion.core.perception.depth_frame import DepthFrame, DepthIntrinsics
from companion.errors import CompanionError

MAGIC = b"DPTH"
VERSION = 1
ENCODING_Z16 = 1
HEADER = struct.Struct("<4sHHIIHHHHdddddddI")
MAX_PIXELS = 4096 * 4096


class DepthStreamError(CompanionError):
    """The stream carried something that is not a depth frame of this format."""


@dataclass(frozen=True)
class FrameHeader:
    header_bytes: int
    frame_number: int
    time_boot_ms: int
    camera_id: int
    intrinsics: DepthIntrinsics
    payload_bytes: int


def decode_header(data: bytes) -> FrameHeader:
    """The first HEADER.size bytes of a message; raises DepthStreamError if they are not one."""
    (magic, version, header_bytes, number, t_ms, camera, width, height, encoding, fx, fy, cx, cy,
     min_m, max_m, scale, payload) = HEADER.unpack(data[:HEADER.size])
    if magic != MAGIC:
        raise DepthStreamError(f"depth stream: bad magic {magic!r} (expected {MAGIC!r})")
    if version != VERSION or header_bytes < HEADER.size:
        raise DepthStreamError(f"depth stream: version {version} with a {header_bytes}-byte "
                               f"header; this reader knows version {VERSION}")
    if encoding != ENCODING_Z16:
        raise DepthStreamError(f"depth stream: encoding {encoding}, expected {ENCODING_Z16} (Z16)")
    if not (0 < width * height <= MAX_PIXELS) or payload != width * height * 2:
        raise DepthStreamError(f"depth stream: {width}x{height} pixels with a {payload}-byte "
                               "payload (expected 2 bytes a pixel)")
    return FrameHeader(header_bytes, number, t_ms, camera,
                       DepthIntrinsics(width, height, fx, fy, cx, cy, min_m, max_m, scale), payload)


def to_frame(header: FrameHeader, payload: bytes) -> DepthFrame:
    intr = header.intrinsics
    pixels = np.frombuffer(payload, dtype="<u2").astype(np.uint16).reshape(intr.height_px,
                                                                           intr.width_px)
    return DepthFrame(header.frame_number, header.time_boot_ms, header.camera_id, intr, pixels)


def read_frame(stream) -> DepthFrame | None:
    """One frame from a blocking binary file (``socket.makefile('rb')``); None at a clean end."""
    head = stream.read(HEADER.size)
    if not head:
        return None
    if len(head) < HEADER.size:
        raise DepthStreamError("depth stream: ended inside a header")
    header = decode_header(head)
    stream.read(header.header_bytes - HEADER.size)
    payload = stream.read(header.payload_bytes)
    if len(payload) < header.payload_bytes:
        raise DepthStreamError("depth stream: ended inside a frame")
    return to_frame(header, payload)


class StubStream:
    """An open stream: ``async for frame in stream``; ``frames`` counts what was read."""

    def __init__(self, reader: asyncio.StreamReader) -> None:
        self._reader = reader
        self.frames = 0

    def __aiter__(self):
        return self

    async def __anext__(self) -> DepthFrame:
        try:
            head = await self._reader.readexactly(HEADER.size)
        except asyncio.IncompleteReadError as exc:
            if exc.partial:
                raise DepthStreamError("depth stream: ended inside a header") from None
            raise StopAsyncIteration from None
        header = decode_header(head)
        try:
            await self._reader.readexactly(header.header_bytes - HEADER.size)
            payload = await self._reader.readexactly(header.payload_bytes)
        except asyncio.IncompleteReadError:
            raise DepthStreamError("depth stream: ended inside a frame") from None
        self.frames += 1
        return to_frame(header, payload)


@asynccontextmanager
async def open_stub_stream(host: str, port: int, timeout_s: float = 10.0):
    """Connect to the stub's depth stream; the connection closes on leaving the block."""
    try:
        async with asyncio.timeout(timeout_s):
            reader, writer = await asyncio.open_connection(host, port)
    except (OSError, TimeoutError) as exc:
        raise DepthStreamError(f"depth stream {host}:{port}: cannot connect: {exc}") from None
    try:
        yield StubStream(reader)
    finally:
        writer.close()
        try:
            await writer.wait_closed()
        except OSError:
            pass
