"""Bytes <-> pymavlink messages: the parser, the encoder and MAVLink 2 signing.

The link (link.py) and the tlog reader (tlog.py) use these; the messages' meaning is elsewhere
(inbound.py, outbound.py). Signing checks the signature before it records a stream's timestamp
(pymavlink's own order lets one forged packet lock a stream out).
"""
from __future__ import annotations

import hashlib
import hmac
import time
import types

from companion.mavlink.dialect import mavlink


def make_mavlink(system_id: int, component_id: int) -> mavlink.MAVLink:
    """A MAVLink 2 parser/encoder with no file: bytes go in via parse_buffer, out via pack."""
    mav = mavlink.MAVLink(None, srcSystem=system_id, srcComponent=component_id)
    mav.robust_parsing = True
    return mav


# MAVLink 2 signing timestamps count 10 us units from 2015-01-01 00:00:00 UTC.
SIGNING_EPOCH_UNIX_S = 1420070400


def signing_timestamp(unix_s: float) -> int:
    """The signing timestamp for a Unix time (10 us units since 2015)."""
    return int(max(0.0, unix_s - SIGNING_EPOCH_UNIX_S) * 100_000)


# A stream not seen before is accepted if stamped at most a minute before our timestamp (the
# MAVLink 2 signing rule), in 10 us units.
NEW_STREAM_WINDOW = 60 * 100_000


def _enable_signing(mav: mavlink.MAVLink, key: bytes, unix_s: float, sign_outgoing: bool) -> None:
    mav.signing.secret_key = key
    mav.signing.timestamp = signing_timestamp(unix_s)
    mav.signing.sign_outgoing = sign_outgoing
    # No unsigned message is let through (ArduPilot lets RADIO_STATUS pass; we use none).
    mav.signing.allow_unsigned_callback = None
    if not sign_outgoing:
        mav.check_signature = types.MethodType(_verify_then_order, mav)


def _verify_then_order(mav: mavlink.MAVLink, msgbuf: bytearray, src_system: int,
                       src_component: int) -> bool:
    """pymavlink's check_signature in the safe order: the signature first, the timestamp after.

    pymavlink 2.4.x records the stream's timestamp before it checks the signature, so one forged
    packet stamped 2^47 made every genuine packet of that stream "old" for good. Here nothing is
    recorded unless the packet is signed with our key; then the timestamp must advance on a
    known stream (replays refused), and a new stream may start at most a minute before our
    timestamp.
    """
    signing = mav.signing
    digest = hashlib.sha256(signing.secret_key + bytes(msgbuf[:-6])).digest()[:6]
    if not hmac.compare_digest(digest, bytes(msgbuf[-6:])):
        return False
    timestamp = int.from_bytes(bytes(msgbuf[-12:-6]), "little")
    stream = (msgbuf[-13], src_system, src_component)          # (link id, system, component)
    last = signing.stream_timestamps.get(stream)
    if last is not None and timestamp <= last:
        return False
    if last is None and timestamp + NEW_STREAM_WINDOW < signing.timestamp:
        return False
    signing.stream_timestamps[stream] = timestamp
    signing.timestamp = max(signing.timestamp, timestamp)
    return True


class Encoder:
    """Packs outbound messages with our ids; MAVLink.send() advances the sequence number.

    With ``signing_key`` (32 bytes) every packet is MAVLink 2 signed, its timestamp starting at
    ``unix_s`` (now, so that a receiver that has seen recent traffic accepts the new stream).
    """

    def __init__(self, system_id: int, component_id: int, signing_key: bytes | None = None,
                 unix_s: float | None = None) -> None:
        self._mav = make_mavlink(system_id, component_id)
        self._mav.file = self
        self._last = b""
        if signing_key is not None:
            _enable_signing(self._mav, signing_key, time.time() if unix_s is None else unix_s,
                            sign_outgoing=True)

    @property
    def signing(self) -> bool:
        return self._mav.signing.sign_outgoing

    def write(self, data: bytes) -> None:        # MAVLink.send()'s file
        self._last = bytes(data)

    @property
    def system_id(self) -> int:
        return self._mav.srcSystem

    @system_id.setter
    def system_id(self, value: int) -> None:
        self._mav.srcSystem = value

    def encode(self, msg) -> bytes:
        self._mav.send(msg)
        return self._last


class Parser:
    """Bytes in, messages out. Counts packets that failed their CRC or could not be decoded.

    With ``signing_key``, only packets signed with that key are accepted; unsigned packets,
    packets signed with another key and replayed (old-timestamp) packets are refused and
    counted in ``signature_rejected``.
    """

    def __init__(self, signing_key: bytes | None = None, unix_s: float | None = None) -> None:
        self._mav = make_mavlink(0, 0)
        self.bad_packets = 0
        self.unknown_packets = 0
        self.signature_rejected = 0
        self._fixed_time = unix_s is not None
        if signing_key is not None:
            # A new stream must be stamped at most a minute before ``unix_s`` (now): a packet
            # recorded earlier cannot be replayed at us; within a stream time must advance.
            _enable_signing(self._mav, signing_key, time.time() if unix_s is None else unix_s,
                            sign_outgoing=False)

    @property
    def signing(self) -> bool:
        return self._mav.signing.secret_key is not None

    def discard_partial(self) -> None:
        """Forget a half-received packet (a new connection, or a datagram from elsewhere); the
        signing state (each stream's last timestamp) is kept."""
        self._mav.buf = bytearray()
        self._mav.buf_index = 0
        self._mav.expected_length = mavlink.HEADER_LEN_V1 + 2

    def feed(self, data: bytes) -> list:
        if self.signing and not self._fixed_time:
            # "now" moves on: a new stream must start within a minute of the present, not of
            # the daemon's start
            signing = self._mav.signing
            signing.timestamp = max(signing.timestamp, signing_timestamp(time.time()))
        try:
            msgs = self._mav.parse_buffer(data) or []
        except mavlink.MAVError:
            self.bad_packets += 1
            return []
        good = []
        for msg in msgs:
            kind = msg.get_type()
            if kind == "BAD_DATA" and "signature" in str(getattr(msg, "reason", "")).lower():
                self.signature_rejected += 1
            elif kind == "BAD_DATA":
                self.bad_packets += 1
            elif kind.startswith("UNKNOWN_"):
                self.unknown_packets += 1
            else:
                good.append(msg)
        return good

    def decode_packet(self, packet: bytes):
        """One whole packet -> message, or None (bad CRC, unknown id, malformed).

        An unknown message id is refused too: pymavlink cannot check its CRC (no CRC extra), so
        random bytes that merely frame would otherwise pass for a message.
        """
        try:
            msg = self._mav.decode(bytearray(packet))
        except Exception:   # pymavlink raises MAVError, struct.error, IndexError... on garbage
            self.bad_packets += 1
            return None
        if msg.get_type().startswith("UNKNOWN"):
            self.unknown_packets += 1
            return None
        return msg
