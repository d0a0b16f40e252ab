"""The asyncio MAVLink link: pymavlink parses and packs, asyncio owns the transports.

Design: every transport is native asyncio, so nothing blocks the loop and no thread is needed.
UDP is a DatagramProtocol, TCP uses streams, and a serial port is a raw termios file descriptor
watched with ``loop.add_reader``. pymavlink's MAVLink object is used only as the parser
(``parse_buffer``) and the encoder (``send``, which advances the sequence number).

URLs (pymavlink's spelling):
  udpin:HOST:PORT   listen; reply to the last sender whose datagram parsed (and, signing on,
                    verified) (also ``udp:``)
  udpout:HOST:PORT  send to HOST:PORT from an ephemeral port (we speak first: our heartbeat);
                    only datagrams from HOST:PORT are received (a connected socket)
  tcp:HOST:PORT     connect; reconnect every ``reconnect_interval_s`` when the peer goes away
  tcpin:HOST:PORT   listen; the latest client is the peer
  /dev/ttyX:BAUD    serial (also ``/dev/ttyX,BAUD`` as mavutil writes it)

Each received message comes out of ``inbox`` as :class:`Received` with ``t_us``: Unix time in
microseconds on a monotonic base (time.time() once, then the loop clock), so a wall-clock jump
cannot fake a heartbeat loss. The same number goes into the tlog, which is how replay sees the
same link clock.
"""
from __future__ import annotations

import asyncio
import logging
import os
import time
from contextlib import asynccontextmanager, contextmanager
from dataclasses import dataclass
from typing import AsyncIterator, Callable

from companion.mavlink.codec import Encoder, Parser
from companion.errors import LinkError

log = logging.getLogger(__name__)

MAX_TCP_WRITE_BUFFER = 64 * 1024
MAX_DATAGRAM_BYTES = 1400     # held messages share datagrams up to this (one Ethernet MTU)


@dataclass(frozen=True)
class Received:
    t_us: int
    msg: object


@dataclass(frozen=True)
class LinkStatistics:
    received: int
    sent: int
    bad_packets: int
    unknown_packets: int
    signature_rejected: int    # signing on: unsigned, wrongly signed or replayed packets refused
    dropped_inbound: int       # inbox full: the oldest message was dropped
    dropped_outbound: int      # no peer yet, or the peer is not reading
    connects: int
    unparsed_datagrams: int    # UDP datagrams that gave no message (a peer's junk never steers us)


@dataclass(frozen=True)
class Endpoint:
    kind: str                  # udpin, udpout, tcp, tcpin, serial
    host: str
    port: int                  # baud rate for serial


def parse_url(url: str) -> Endpoint:
    """Split a pymavlink connection string; raises LinkError naming what is wrong."""
    if url.startswith("/dev/") or url.startswith("COM"):
        device, sep, baud = url.replace(",", ":").rpartition(":")
        if not sep or not baud.isdigit():
            raise LinkError(f"{url}: expected DEVICE:BAUD, e.g. /dev/ttyACM0:115200")
        return Endpoint("serial", device, int(baud))
    kind, _, rest = url.partition(":")
    kind = {"udp": "udpin"}.get(kind, kind)
    if kind not in ("udpin", "udpout", "tcp", "tcpin"):
        raise LinkError(f"{url}: unknown link type {kind!r} "
                        "(udpin:, udpout:, tcp:, tcpin: or /dev/ttyX:BAUD)")
    host, sep, port = rest.rpartition(":")
    if not sep or not port.isdigit() or int(port) > 65535:
        raise LinkError(f"{url}: expected {kind}:HOST:PORT")
    return Endpoint(kind, host or "0.0.0.0", int(port))


class MavlinkLink:
    """One MAVLink peer over one transport. Use :func:`open_link`."""

    def __init__(self, endpoint: Endpoint, encoder: Encoder, inbox_size: int,
                 reconnect_interval_s: float, signing_key: bytes | None = None) -> None:
        self.endpoint = endpoint
        self.encoder = encoder
        self.inbox: asyncio.Queue[Received] = asyncio.Queue(maxsize=inbox_size)
        self.reconnect_interval_s = reconnect_interval_s
        self.on_sent: Callable[[int, bytes], None] | None = None
        self.on_connect: Callable[[], None] | None = None
        self.local_address: tuple[str, int] | None = None
        self._loop = asyncio.get_running_loop()
        self._base_us = int(time.time() * 1e6)
        self._base_loop_s = self._loop.time()
        self._signing_key = signing_key
        self._parser = Parser(signing_key)
        self._send_bytes: Callable[[bytes], bool] = lambda data: False
        self._counts = dict(received=0, sent=0, dropped_inbound=0, dropped_outbound=0, connects=0,
                            unparsed_datagrams=0)
        self._closers: list[Callable[[], None]] = []
        self._held: list[tuple[int, bytes]] | None = None      # inside coalesced(): (t_us, data)

    # ---------------------------------------------------------------- API
    def now_us(self) -> int:
        return self._base_us + int(round((self._loop.time() - self._base_loop_s) * 1e6))

    def send(self, msg) -> bytes | None:
        """Pack and send one message now (never blocks). Returns the bytes, or None if dropped.
        Inside :meth:`coalesced`, the message is held and goes out when the block ends."""
        data = self.encoder.encode(msg)
        # Stamped as it is handed to the transport: on loopback, sendto() returns only after the
        # kernel has delivered the datagram and woken the receiver (tens of us later).
        t_us = self.now_us()
        if self._held is not None:
            self._held.append((t_us, data))
            return data
        return data if self._send_now([(t_us, data)]) else None

    @contextmanager
    def coalesced(self):
        """Messages sent inside the block go out at its end, in order, in as few writes (UDP:
        datagrams of whole packets, up to MAX_DATAGRAM_BYTES) as fit: a lock-step answer (a
        setpoint, then the ODOMETRY) wakes the peer once instead of once per message."""
        if self._held is not None:
            yield
            return
        self._held = []
        try:
            yield
        finally:
            held, self._held = self._held, None
            chunk: list[tuple[int, bytes]] = []
            size = 0
            for item in held:
                if chunk and size + len(item[1]) > MAX_DATAGRAM_BYTES:
                    self._send_now(chunk)
                    chunk, size = [], 0
                chunk.append(item)
                size += len(item[1])
            if chunk:
                self._send_now(chunk)

    def _send_now(self, items: list[tuple[int, bytes]]) -> bool:
        """One write of the packets ``items`` [(t_us, data)]; counted and recorded per packet."""
        if not self._send_bytes(items[0][1] if len(items) == 1 else
                                b"".join(data for _, data in items)):
            self._counts["dropped_outbound"] += len(items)
            return False
        self._counts["sent"] += len(items)
        if self.on_sent is not None:
            for t_us, data in items:
                self.on_sent(t_us, data)
        return True

    def statistics(self) -> LinkStatistics:
        return LinkStatistics(bad_packets=self._parser.bad_packets,
                              unknown_packets=self._parser.unknown_packets,
                              signature_rejected=self._parser.signature_rejected, **self._counts)

    async def run(self) -> None:
        """The receive task: keeps the transport alive (TCP reconnects) until cancelled."""
        if self.endpoint.kind == "tcp":
            await self._run_tcp_client()
        else:
            await asyncio.Future()          # datagrams, server and serial arrive by callback

    # ---------------------------------------------------------------- receiving
    def _feed(self, data: bytes) -> int:
        """Parse received bytes into the inbox; returns how many messages they gave."""
        t_us = self.now_us()
        msgs = self._parser.feed(data)
        for msg in msgs:
            self._counts["received"] += 1
            if self.inbox.full():
                self.inbox.get_nowait()
                self._counts["dropped_inbound"] += 1
            self.inbox.put_nowait(Received(t_us, msg))
        return len(msgs)

    def _connected(self, what: str) -> None:
        # A new connection starts with no half packet; the parser, its counters and its signing
        # state (each stream's last timestamp: what refuses replays) carry on.
        self._counts["connects"] += 1
        self._parser.discard_partial()
        log.info("link up: %s", what)
        if self.on_connect is not None:
            self.on_connect()

    # ---------------------------------------------------------------- transports
    async def open(self) -> None:
        kind = self.endpoint.kind
        try:
            if kind in ("udpin", "udpout"):
                await self._open_udp()
            elif kind == "tcpin":
                await self._open_tcp_server()
            elif kind == "serial":
                self._open_serial()
        except OSError as exc:
            raise LinkError(f"cannot open {kind}:{self.endpoint.host}:{self.endpoint.port}: "
                            f"{exc.strerror or exc}") from None

    def close(self) -> None:
        for closer in reversed(self._closers):
            closer()
        self._closers.clear()

    async def _open_udp(self) -> None:
        ep = self.endpoint
        link = self
        peer: list[tuple | None] = [None if ep.kind == "udpin" else (ep.host, ep.port)]

        class Protocol(asyncio.DatagramProtocol):
            def datagram_received(self, data: bytes, addr) -> None:
                # MAVLink over UDP puts whole packets in each datagram: parse each on its own, so
                # a truncated packet cannot swallow the next datagram or another sender's bytes.
                link._parser.discard_partial()
                if link._feed(data) == 0:
                    link._counts["unparsed_datagrams"] += 1
                elif ep.kind == "udpin" and addr != peer[0]:
                    # only a sender whose packet parsed (and verified) takes the reply path
                    peer[0] = addr
                    link._connected(f"udp peer {addr[0]}:{addr[1]}")

            def error_received(self, exc: Exception) -> None:
                log.debug("udp error: %s", exc)       # e.g. ICMP port unreachable: peer down

        if ep.kind == "udpin":
            transport, _ = await self._loop.create_datagram_endpoint(
                Protocol, local_addr=(ep.host, ep.port))
        else:
            # A connected socket: the kernel delivers datagrams from HOST:PORT only. Unconnected,
            # a stream meant for whoever held our ephemeral port before (another stub's or
            # autopilot's last peer on this machine) was taken for the vehicle's.
            transport, _ = await self._loop.create_datagram_endpoint(
                Protocol, remote_addr=(ep.host, ep.port))
        self._closers.append(transport.close)
        self.local_address = transport.get_extra_info("sockname")[:2]

        def send(data: bytes) -> bool:
            if peer[0] is None or transport.is_closing():
                return False
            transport.sendto(data, peer[0] if ep.kind == "udpin" else None)
            return True
        self._send_bytes = send
        if ep.kind == "udpout":
            self._connected(f"udp to {ep.host}:{ep.port}")

    def _use_stream(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        def send(data: bytes) -> bool:
            if writer.is_closing() or writer.transport.get_write_buffer_size() > MAX_TCP_WRITE_BUFFER:
                return False
            writer.write(data)
            return True
        self._send_bytes = send

    async def _read_stream(self, reader: asyncio.StreamReader) -> None:
        while data := await reader.read(4096):
            self._feed(data)

    async def _run_tcp_client(self) -> None:
        ep = self.endpoint
        while True:
            writer = None
            try:
                reader, writer = await asyncio.open_connection(ep.host, ep.port)
                self._use_stream(reader, writer)
                self._connected(f"tcp {ep.host}:{ep.port}")
                await self._read_stream(reader)
                log.warning("link down: tcp %s:%d closed by the peer", ep.host, ep.port)
            except OSError as exc:
                log.warning("link down: tcp %s:%d: %s", ep.host, ep.port, exc.strerror or exc)
            finally:
                self._send_bytes = lambda data: False
                if writer is not None:
                    writer.close()
            await asyncio.sleep(self.reconnect_interval_s)

    async def _open_tcp_server(self) -> None:
        async def client(reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
            self._use_stream(reader, writer)
            self._connected(f"tcp client {writer.get_extra_info('peername')}")
            try:
                await self._read_stream(reader)
            except OSError as exc:
                log.warning("link down: %s", exc)
            finally:
                writer.close()
        server = await asyncio.start_server(client, self.endpoint.host, self.endpoint.port)
        self._closers.append(server.close)
        self.local_address = server.sockets[0].getsockname()[:2]

    def _open_serial(self) -> None:
        import termios
        import tty
        fd = os.open(self.endpoint.host, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
        self._closers.append(lambda: os.close(fd))
        tty.setraw(fd)
        attrs = termios.tcgetattr(fd)
        speed = getattr(termios, f"B{self.endpoint.port}", None)
        if speed is None:
            raise LinkError(f"{self.endpoint.host}: unsupported baud rate {self.endpoint.port}")
        attrs[4] = attrs[5] = speed
        termios.tcsetattr(fd, termios.TCSANOW, attrs)

        def readable() -> None:
            try:
                data = os.read(fd, 4096)
            except BlockingIOError:
                return
            if data:
                self._feed(data)

        def send(data: bytes) -> bool:
            try:
                return os.write(fd, data) == len(data)
            except (BlockingIOError, OSError):
                return False
        self._loop.add_reader(fd, readable)
        self._closers.append(lambda: self._loop.remove_reader(fd))
        self._send_bytes = send
        self._connected(f"serial {self.endpoint.host} at {self.endpoint.port} baud")


@asynccontextmanager
async def open_link(url: str, encoder: Encoder, inbox_size: int = 1000,
                    reconnect_interval_s: float = 1.0,
                    signing_key: bytes | None = None) -> AsyncIterator[MavlinkLink]:
    """Open the link for ``url``; the transport is closed on exit, whatever happens.

    ``signing_key`` (32 bytes): accept only packets signed with it. Outbound signing is the
    encoder's (give it the same key).
    """
    link = MavlinkLink(parse_url(url), encoder, inbox_size, reconnect_interval_s, signing_key)
    try:
        await link.open()
        yield link
    finally:
        link.close()
