"""Telemetry logs (.tlog): writer for the live daemon, tolerant reader for replay.

Format (as MAVProxy and Mission Planner write it, and as ``pymavlink.mavutil.mavlink_connection``
reads it): a sequence of records, each an 8-byte big-endian Unix time in microseconds followed by
one raw MAVLink packet (v1 0xFE or v2 0xFD framing). Nothing else: no header, no index.

The reader survives what real files suffer: an empty file, a tail cut mid-packet (a killed
recorder), corrupt bytes inside (it skips to the next record whose timestamp is plausible and
whose packet passes its CRC), unknown message ids, and files that are not tlogs at all (nothing
readable, said clearly).
"""
from __future__ import annotations

import logging
import struct
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Iterator

from companion.mavlink.codec import Parser

log = logging.getLogger(__name__)

_STAMP = struct.Struct(">Q")
_V1_MAGIC, _V2_MAGIC = 0xFE, 0xFD
_V1_HEADER, _V2_HEADER, _CRC_LEN, _SIGNATURE_LEN = 6, 10, 2, 13
# Timestamps must be Unix microseconds between 2000 and 2100, and a record may not jump more than
# a day from the previous one: that is what tells a record boundary from random bytes.
_EARLIEST_US, _LATEST_US = 946_684_800_000_000, 4_102_444_800_000_000
_MAX_JUMP_US = 86_400 * 1_000_000


class TlogWriter:
    """Appends (timestamp, packet) records; ``flush()`` is called at least once a second.

    ``max_bytes`` (None: unbounded): once the file holds that much, it is closed at a record
    boundary and rotated, ``PATH`` -> ``PATH.1`` -> ... -> ``PATH.<keep>`` (the oldest dropped),
    and a new ``PATH`` begun: at most (keep + 1) x max_bytes on disk for a flight of any length,
    every file a whole tlog (records are never split) that replay reads on its own.
    """

    def __init__(self, path: str | Path, flush_interval_s: float = 1.0,
                 max_bytes: int | None = None, keep: int = 3) -> None:
        if max_bytes is not None and max_bytes <= 0:
            raise ValueError(f"tlog max_bytes must be > 0, got {max_bytes}")
        if keep < 1:
            raise ValueError(f"tlog keep must be >= 1, got {keep}")
        self.path = Path(path)
        self._file = open(self.path, "wb")          # noqa: SIM115 - closed in close()
        self._flush_interval_s = flush_interval_s
        self._last_flush = time.monotonic()
        self.records = 0
        self.rotations = 0
        self._max_bytes, self._keep = max_bytes, keep
        self._bytes = 0

    def write(self, t_us: int, packet: bytes) -> None:
        record = _STAMP.pack(t_us) + packet
        if self._max_bytes is not None and self._bytes and \
                self._bytes + len(record) > self._max_bytes:
            self._rotate()
        self._file.write(record)
        self._bytes += len(record)
        self.records += 1
        if time.monotonic() - self._last_flush >= self._flush_interval_s:
            self.flush()

    def _rotate(self) -> None:
        self._file.close()
        for k in range(self._keep - 1, 0, -1):
            older = self.path.with_name(f"{self.path.name}.{k}")
            if older.exists():
                older.replace(self.path.with_name(f"{self.path.name}.{k + 1}"))
        self.path.replace(self.path.with_name(f"{self.path.name}.1"))
        self._file = open(self.path, "wb")          # noqa: SIM115 - closed in close()
        self._bytes = 0
        self.rotations += 1

    def flush(self) -> None:
        if not self._file.closed:
            self._file.flush()
        self._last_flush = time.monotonic()

    def close(self) -> None:
        if not self._file.closed:
            self._file.flush()
            self._file.close()

    def __enter__(self) -> "TlogWriter":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


@dataclass
class TlogStats:
    """What reading a tlog found. ``damaged`` is True if anything had to be skipped."""
    bytes_total: int = 0
    records: int = 0
    bytes_skipped: int = 0
    skipped_regions: int = 0
    bad_packets: int = 0
    truncated_tail_bytes: int = 0
    notes: list[str] = field(default_factory=list)

    @property
    def damaged(self) -> bool:
        return bool(self.bytes_skipped or self.truncated_tail_bytes or self.bad_packets)


@dataclass(frozen=True)
class TlogRecord:
    t_us: int
    msg: object          # a pymavlink message


class TlogReader:
    """Iterate the readable records of a tlog, in file order; ``stats`` fills as it goes."""

    def __init__(self, path: str | Path,
                 progress: Callable[[int], None] | None = None) -> None:
        self.path = Path(path)
        self._data = self.path.read_bytes()
        self.stats = TlogStats(bytes_total=len(self._data))
        self._parser = Parser()
        self._progress = progress

    def __iter__(self) -> Iterator[TlogRecord]:
        data = self._data
        pos, prev_us = 0, None
        while pos < len(data):
            record = self._record_at(pos, prev_us)
            if record is None:
                nxt = self._resync(pos + 1, prev_us)
                if nxt is None:
                    self._note_tail(pos, len(data) - pos, prev_us)
                    break
                self.stats.bytes_skipped += nxt - pos
                self.stats.skipped_regions += 1
                log.warning("%s: skipped %d unreadable bytes at offset %d",
                            self.path, nxt - pos, pos)
                pos = nxt
                continue
            t_us, msg, size = record
            pos += size
            prev_us = t_us
            if self._progress:
                self._progress(size)
            if msg is None:          # framing fine, packet unreadable (unknown id, bad CRC)
                self.stats.bad_packets += 1
                continue
            self.stats.records += 1
            yield TlogRecord(t_us, msg)
        if not self.stats.records and self.stats.bytes_total:
            self.stats.notes.append("no readable MAVLink record: not a tlog, or wholly corrupt")
        elif not self.stats.bytes_total:
            self.stats.notes.append("empty file")

    # ------------------------------------------------------------ framing
    def _frame_at(self, pos: int, prev_us: int | None) -> tuple[int, int] | None:
        """(timestamp, record size) if a plausible record header starts at pos."""
        data = self._data
        if pos + 8 + _V1_HEADER > len(data):
            return None
        (t_us,) = _STAMP.unpack_from(data, pos)
        if not _EARLIEST_US <= t_us <= _LATEST_US:
            return None
        if prev_us is not None and abs(t_us - prev_us) > _MAX_JUMP_US:
            return None
        magic = data[pos + 8]
        length = data[pos + 9]
        if magic == _V2_MAGIC:
            if pos + 8 + _V2_HEADER > len(data):
                return None
            incompat = data[pos + 10]
            if incompat & ~0x01:
                return None
            size = _V2_HEADER + length + _CRC_LEN + (_SIGNATURE_LEN if incompat & 0x01 else 0)
        elif magic == _V1_MAGIC:
            size = _V1_HEADER + length + _CRC_LEN
        else:
            return None
        return t_us, 8 + size

    def _record_at(self, pos: int, prev_us: int | None):
        """(t_us, msg or None, size) for a whole, well-framed record at pos, else None.

        A packet that fails to decode still counts as a record (msg None) if the next record
        frames correctly right after it: then only that packet is lost, not the alignment.
        """
        frame = self._frame_at(pos, prev_us)
        if frame is None:
            return None
        t_us, size = frame
        end = pos + size
        if end > len(self._data):
            return None
        msg = self._parser.decode_packet(self._data[pos + 8:end])
        if msg is None and end < len(self._data) and self._frame_at(end, t_us) is None:
            return None
        return t_us, msg, size

    def _resync(self, start: int, prev_us: int | None) -> int | None:
        """The next offset from ``start`` where a record frames AND decodes."""
        data = self._data
        for pos in range(start, len(data) - 8):
            if data[pos + 8] not in (_V1_MAGIC, _V2_MAGIC):
                continue
            frame = self._frame_at(pos, prev_us)
            if frame is None or pos + frame[1] > len(data):
                continue
            if self._parser.decode_packet(data[pos + 8:pos + frame[1]]) is not None:
                return pos
        return None

    def _note_tail(self, pos: int, size: int, prev_us: int | None) -> None:
        frame = self._frame_at(pos, prev_us)
        if frame is not None and pos + frame[1] > len(self._data):
            self.stats.truncated_tail_bytes = size
            self.stats.notes.append(f"file ends mid-packet: last {size} bytes ignored")
        else:
            self.stats.bytes_skipped += size
            if self.stats.records:
                self.stats.notes.append(f"{size} unreadable bytes at the end ignored")
