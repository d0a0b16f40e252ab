"""The stub's MAVLink 2 links: a TCP server (several clients) and a UDP endpoint (udpin-like).

Every message the stub emits goes to every client. Each client has its own parser and one
pymavlink encoder per component (1 and 100), so each component has its own sequence numbers
on each link, as ArduPilot keeps them per channel. Garbage from a client is counted and
dropped. With drop_rate P, each incoming/outgoing UDP datagram and each incoming/outgoing TCP
message is dropped with probability P, from its own seeded random stream.

Lock-step hooks (``sitl_stub/lockstep.py``): ``on_delivered(client, msg)`` for every message
that went out, ``on_odometry(client, msg)`` for every ODOMETRY that came in, ``on_client(name)``
when a client appears. With ``on_odometry`` set, UDP drops are drawn per message like TCP's, and
ODOMETRY is never dropped: it is the simulation's clock (as ArduPilot SITL's physics socket is
apart from MAVLink), not flight traffic, and a lost one would stall the stub for a timeout.
"""
from __future__ import annotations

import asyncio
import logging
import time
from contextlib import asynccontextmanager
from dataclasses import dataclass
from typing import AsyncIterator, Callable

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from .sim import STREAM_LINK_DROP, make_rng

log = logging.getLogger(__name__)

COMPONENTS = (mavlink.MAV_COMP_ID_AUTOPILOT1, mavlink.MAV_COMP_ID_CAMERA)
MAX_TCP_BACKLOG_BYTES = 1 << 20
MAX_DATAGRAM_BYTES = 1400        # a burst's packets share datagrams up to this (one Ethernet MTU)
CLOSE_TIMEOUT_S = 2.0             # handlers of connected TCP clients get this long to end   # a client that does not read loses messages beyond this
# Unsigned messages accepted when signing is on (ArduPilot also lets RADIO_STATUS through).
UNSIGNED_ALLOWED = (mavlink.MAVLINK_MSG_ID_HEARTBEAT, mavlink.MAVLINK_MSG_ID_RADIO_STATUS)
_MSG_ID_ODOMETRY = mavlink.MAVLINK_MSG_ID_ODOMETRY
_SIGNING_EPOCH_UNIX_S = 1420070400   # MAVLink signing timestamps count 10 us from 2015-01-01
_CRC_EXTRA = {msg_id: bytes([cls.crc_extra]) for msg_id, cls in mavlink.mavlink_map.items()}


class LinkError(Exception):
    """A link could not be opened (port in use, bad address)."""


@dataclass(frozen=True)
class LinkStatistics:
    tcp_clients: int
    udp_clients: int
    received: int
    sent: int
    dropped_in: int
    dropped_out: int
    bad_data: int
    bad_bytes: int
    unsigned_rejected: int
    backlog_dropped: int
    forwarded: int = 0


@dataclass(frozen=True)
class Endpoint:
    host: str
    port: int


def parse_endpoint(text: str, what: str) -> Endpoint | None:
    """'HOST:PORT' -> Endpoint; 'none' -> None. Raises ValueError with a clear message."""
    if text.strip().lower() in ("none", "-", ""):
        return None
    host, sep, port = text.rpartition(":")
    if not sep or not host:
        raise ValueError(f"--{what}: expected HOST:PORT or none, got {text!r}")
    try:
        port_i = int(port)
    except ValueError:
        raise ValueError(f"--{what}: port must be an integer, got {port!r}") from None
    if not 0 <= port_i <= 65535:
        raise ValueError(f"--{what}: port must be in 0..65535, got {port_i}")
    return Endpoint(host=host, port=port_i)


class _Sink:
    """File-like object that keeps the bytes pymavlink's MAVLink.send() writes."""

    def __init__(self) -> None:
        self.data = b""

    def write(self, data: bytes) -> None:
        self.data = bytes(data)


class _Client:
    def __init__(self, name: str, sysid: int, signing_key: bytes | None, link_id: int) -> None:
        self.name = name
        self.parser = mavlink.MAVLink(None)
        self.parser.robust_parsing = True
        self._sink = _Sink()
        self.encoders = {comp: mavlink.MAVLink(self._sink, sysid, comp) for comp in COMPONENTS}
        self.link_id = link_id
        if signing_key is not None:
            self.set_signing(signing_key, int(max(0.0, time.time() - _SIGNING_EPOCH_UNIX_S)
                                              * 100_000))

    def set_signing(self, key: bytes | None, timestamp: int) -> None:
        """Sign everything sent and refuse unsigned input (but UNSIGNED_ALLOWED) with ``key``;
        None turns signing off."""
        for enc in self.encoders.values():
            enc.signing.secret_key = key
            enc.signing.sign_outgoing = key is not None
            enc.signing.link_id = self.link_id
            enc.signing.timestamp = max(timestamp, enc.signing.timestamp)
        self.parser.signing.secret_key = key
        self.parser.signing.timestamp = max(timestamp, self.parser.signing.timestamp)
        self.parser.signing.allow_unsigned_callback = (
            (lambda _mav, msg_id: msg_id in UNSIGNED_ALLOWED) if key is not None else None)

    def encode(self, comp: int, msg, packed: bytes | None = None) -> bytes:
        """``msg`` packed for this link (advances this component's sequence number).

        ``packed``: the same message already packed, unsigned, for another link: only the
        sequence number and the CRC differ, so they are patched in rather than the payload packed
        again (the bytes are those pymavlink would give). Signed links always pack."""
        enc = self.encoders[comp]
        if packed is None or enc.signing.sign_outgoing:
            enc.send(msg)
            return self._sink.data
        frame = bytearray(packed)
        frame[4 if frame[0] == mavlink.PROTOCOL_MARKER_V2 else 2] = enc.seq
        crc = mavlink.x25crc(frame[1:-2])
        crc.accumulate(_CRC_EXTRA[msg.id])
        frame[-2:] = crc.crc.to_bytes(2, "little")
        enc.seq = (enc.seq + 1) % 256
        return bytes(frame)

    @property
    def signs(self) -> bool:
        return any(enc.signing.sign_outgoing for enc in self.encoders.values())


class LinkHub:
    """Owns both endpoints and their clients; decoded messages go to `on_message(name, msg)`."""

    def __init__(self, tcp: Endpoint | None, udp: Endpoint | None, sysid: int,
                 on_message: Callable[[str, object], None], drop_rate: float = 0.0, seed: int = 0,
                 signing_key: bytes | None = None) -> None:
        self._tcp_ep, self._udp_ep = tcp, udp
        self._sysid = sysid
        self._on_message = on_message
        self._drop_rate = drop_rate
        self._rng = make_rng(seed, STREAM_LINK_DROP)
        self._signing_key = signing_key
        self._server: asyncio.base_events.Server | None = None
        self._udp_transport: asyncio.DatagramTransport | None = None
        self._tcp_clients: dict[str, tuple[_Client, asyncio.StreamWriter]] = {}
        self._udp_clients: dict[tuple, _Client] = {}
        self._handlers: set[asyncio.Task] = set()
        self._next_link_id = 0
        self.tcp_address: tuple[str, int] | None = None
        self.udp_address: tuple[str, int] | None = None
        self._n = dict(received=0, sent=0, dropped_in=0, dropped_out=0, bad_data=0, bad_bytes=0,
                       unsigned_rejected=0, backlog_dropped=0, forwarded=0)
        self._last_bad_warning_s = 0.0
        self.on_delivered: Callable[[str, object], None] | None = None
        self.delivered_ids: frozenset[int] | None = None   # on_delivered for these only (None: all)
        self.on_odometry: Callable[[str, object], None] | None = None
        self.on_client: Callable[[str], None] | None = None
        self.on_client_gone: Callable[[str], None] | None = None

    # ------------------------------------------------------------------ lifecycle
    async def start(self) -> None:
        loop = asyncio.get_running_loop()
        if self._tcp_ep is not None:
            try:
                self._server = await asyncio.start_server(self._serve_tcp, self._tcp_ep.host,
                                                          self._tcp_ep.port)
            except OSError as exc:
                raise LinkError(f"cannot listen on TCP {self._tcp_ep.host}:{self._tcp_ep.port}: "
                                f"{exc.strerror or exc}") from exc
            self.tcp_address = self._server.sockets[0].getsockname()[:2]
        if self._udp_ep is not None:
            try:
                self._udp_transport, _ = await loop.create_datagram_endpoint(
                    lambda: _UdpProtocol(self), local_addr=(self._udp_ep.host, self._udp_ep.port))
            except OSError as exc:
                raise LinkError(f"cannot bind UDP {self._udp_ep.host}:{self._udp_ep.port}: "
                                f"{exc.strerror or exc}") from exc
            self.udp_address = self._udp_transport.get_extra_info("sockname")[:2]

    async def close(self) -> None:
        if self._server is not None:
            self._server.close()
        for _, writer in list(self._tcp_clients.values()):
            writer.close()
        # Closing the transport ends each handler's read with EOF: let them return on their
        # own. A cancelled handler makes asyncio's StreamReaderProtocol log a CancelledError
        # traceback ("Exception in callback ... connection_made"), so cancel only stragglers.
        if self._handlers:
            _, pending = await asyncio.wait(list(self._handlers), timeout=CLOSE_TIMEOUT_S)
            for task in pending:
                task.cancel()
            if pending:
                await asyncio.gather(*pending, return_exceptions=True)
        if self._server is not None:
            await self._server.wait_closed()
        if self._udp_transport is not None:
            self._udp_transport.close()

    def set_signing_key(self, key: bytes, timestamp: int) -> None:
        """SETUP_SIGNING: the key (all zeros: off) and its initial timestamp, on every link at
        once and for every client that connects later (ArduPilot keeps one key for all links)."""
        use = key if any(key) else None
        self._signing_key = use
        for client in self._all_clients():
            client.set_signing(use, timestamp)
        log.info("signing %s by SETUP_SIGNING", "on" if use else "off")

    def _all_clients(self) -> list[_Client]:
        return [c for c, _ in self._tcp_clients.values()] + list(self._udp_clients.values())

    def statistics(self) -> LinkStatistics:
        return LinkStatistics(tcp_clients=len(self._tcp_clients),
                              udp_clients=len(self._udp_clients), **self._n)

    # ------------------------------------------------------------------ sending
    def broadcast(self, items: list[tuple[int, object]], only: str | None = None,
                  exclude: frozenset[str] = frozenset()) -> None:
        """Send each (component, message) to every client (or to the client named ``only``),
        but those named in ``exclude``."""
        if not items:
            return
        delivered, wanted = self.on_delivered, self.delivered_ids
        # Each message is packed once; the other links patch in their sequence number and CRC
        # (_Client.encode): the stub sends every message on every link, as ArduPilot does.
        packed: list[bytes | None] = [None] * len(items)

        def encode(client: _Client, index: int) -> bytes:
            comp, msg = items[index]
            data = client.encode(comp, msg, packed[index])
            if packed[index] is None and not client.signs:
                packed[index] = data
            return data
        # UDP first: a lock-step companion (UDP in the demo and the tests) starts on its
        # sample while the stub is still encoding for the ground stations.
        if self._udp_transport is not None:
            for addr, client in list(self._udp_clients.items()):
                if only not in (None, client.name) or client.name in exclude:
                    continue
                # A burst goes out in as few datagrams as fit (MAVLink over UDP is a stream of
                # whole packets; every receiver parses a datagram as one): one syscall and one
                # wake-up of the peer per step instead of one per message.
                chunks, size = [], 0
                for index, (_, msg) in enumerate(items):
                    data = encode(client, index)
                    if self._drop():
                        self._n["dropped_out"] += 1
                        continue
                    if chunks and size + len(data) > MAX_DATAGRAM_BYTES:
                        self._udp_transport.sendto(b"".join(chunks), addr)
                        chunks, size = [], 0
                    chunks.append(data)
                    size += len(data)
                    self._n["sent"] += 1
                    if delivered is not None and (wanted is None or msg.id in wanted):
                        delivered(client.name, msg)
                if chunks:
                    self._udp_transport.sendto(b"".join(chunks), addr)
        for name, (client, writer) in list(self._tcp_clients.items()):
            if writer.is_closing() or only not in (None, name) or name in exclude:
                continue
            chunks, msgs = [], []
            for index, (_, msg) in enumerate(items):
                data = encode(client, index)
                if self._drop():
                    self._n["dropped_out"] += 1
                    continue
                chunks.append(data)
                msgs.append(msg)
            if not chunks:
                continue
            if writer.transport.get_write_buffer_size() > MAX_TCP_BACKLOG_BYTES:
                self._n["backlog_dropped"] += len(chunks)
                continue
            writer.write(b"".join(chunks))
            self._n["sent"] += len(chunks)
            if delivered is not None:
                for msg in msgs:
                    if wanted is None or msg.id in wanted:
                        delivered(name, msg)

    def forward(self, packet: bytes, names: tuple[str, ...]) -> None:
        """A received packet, as it came, to the clients named (routing.py: ``--route``)."""
        for addr, client in list(self._udp_clients.items()):
            if client.name in names and self._udp_transport is not None:
                if self._drop():
                    self._n["dropped_out"] += 1
                    continue
                self._udp_transport.sendto(packet, addr)
                self._n["forwarded"] += 1
        for name, (_, writer) in list(self._tcp_clients.items()):
            if name in names and not writer.is_closing():
                if self._drop():
                    self._n["dropped_out"] += 1
                    continue
                if writer.transport.get_write_buffer_size() > MAX_TCP_BACKLOG_BYTES:
                    self._n["backlog_dropped"] += 1
                    continue
                writer.write(packet)
                self._n["forwarded"] += 1

    # ------------------------------------------------------------------ receiving
    def _drop(self) -> bool:
        return self._drop_rate > 0.0 and self._rng.random() < self._drop_rate

    def _new_client(self, name: str) -> _Client:
        self._next_link_id = (self._next_link_id + 1) % 256
        log.info("client connected: %s", name)
        return _Client(name, self._sysid, self._signing_key, self._next_link_id)

    def _feed(self, client: _Client, data: bytes, per_message_drop: bool) -> None:
        try:
            msgs = client.parser.parse_buffer(data) or []
        except Exception as exc:   # their fault: a parser error must never stop the stub
            self._count_bad(client, len(data), f"parser error: {exc}")
            return
        for msg in msgs:
            if msg.get_type() == "BAD_DATA":
                reason = str(getattr(msg, "reason", ""))
                if "signature" in reason.lower():
                    self._n["unsigned_rejected"] += 1
                    log.debug("unsigned/badly signed message from %s refused", client.name)
                else:
                    self._count_bad(client, len(getattr(msg, "data", b"")), reason)
                continue
            if msg.get_type() == "UNKNOWN" or msg.get_type().startswith("UNKNOWN"):
                continue
            is_clock = self.on_odometry is not None and msg.get_msgId() == _MSG_ID_ODOMETRY
            if per_message_drop and not is_clock and self._drop():
                self._n["dropped_in"] += 1
                continue
            self._n["received"] += 1
            if is_clock:
                self.on_odometry(client.name, msg)
            self._on_message(client.name, msg)

    def _count_bad(self, client: _Client, nbytes: int, reason: str) -> None:
        self._n["bad_data"] += 1
        self._n["bad_bytes"] += nbytes
        now = time.monotonic()
        if now - self._last_bad_warning_s > 1.0:   # rate-limited
            self._last_bad_warning_s = now
            log.warning("garbage from %s dropped (%s); %d bad chunks so far", client.name,
                        reason, self._n["bad_data"])

    async def _serve_tcp(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        task = asyncio.current_task()
        if task is not None:
            self._handlers.add(task)
        peer = writer.get_extra_info("peername")
        name = f"tcp:{peer[0]}:{peer[1]}" if peer else "tcp:?"
        client = self._new_client(name)
        self._tcp_clients[name] = (client, writer)
        if self.on_client is not None:
            self.on_client(name)
        try:
            while True:
                data = await reader.read(4096)
                if not data:
                    break
                self._feed(client, data, per_message_drop=True)
        except (ConnectionError, OSError) as exc:
            log.info("client %s: %s", name, exc)
        finally:
            self._tcp_clients.pop(name, None)
            if self.on_client_gone is not None:
                self.on_client_gone(name)
            writer.close()
            log.info("client disconnected: %s", name)
            if task is not None:
                self._handlers.discard(task)

    def _on_datagram(self, data: bytes, addr: tuple) -> None:
        lockstep = self.on_odometry is not None
        if not lockstep and self._drop():
            self._n["dropped_in"] += 1
            return
        client = self._udp_clients.get(addr)
        if client is None:
            client = self._new_client(f"udp:{addr[0]}:{addr[1]}")
            self._udp_clients[addr] = client
            if self.on_client is not None:
                self.on_client(client.name)
        self._feed(client, data, per_message_drop=lockstep)


class _UdpProtocol(asyncio.DatagramProtocol):
    def __init__(self, hub: LinkHub) -> None:
        self._hub = hub

    def datagram_received(self, data: bytes, addr: tuple) -> None:
        self._hub._on_datagram(data, addr)

    def error_received(self, exc: Exception) -> None:
        log.debug("UDP error: %s", exc)


@asynccontextmanager
async def open_links(hub: LinkHub) -> AsyncIterator[LinkHub]:
    """Start the hub's endpoints; close them (and every client) on exit."""
    try:
        await hub.start()
        yield hub
    finally:
        await hub.close()
