"""Fuzz and property tests of the daemon's receive path: the link's parser, codec.decode,
Pipeline.handle, and the tlog reader.

Cases are built from a real recorded flight (conftest.recording), so mutations reach the
estimator and guidance, not just the parser: valid frames re-packed with NaN, infinities and
absurd values in every field the daemon reads; times going back or jumping ahead; duplicated,
reordered and dropped messages; other system ids; and byte-level damage (random bytes, bit
flips, truncation). Hypothesis runs derandomized (fixed seed) with a bounded number of examples;
``-m slow`` runs many more. Properties: no exception escapes, the estimate stays finite with a
PSD covariance, every setpoint is finite, within max_speed_mps, yaw in [-pi, pi].
"""
from __future__ import annotations

import math
import os
import random

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from companion.mavlink import codec
from companion.mavlink.tlog import TlogReader, TlogWriter
from tests.robustness.support import (check_estimate, check_outputs, clone, fresh_pipeline,
                                      rejections)

FAST, SLOW = 60, int(os.environ.get("FUZZ_SLOW_CASES", "1500"))
MAX_PACKET_BYTES = 280           # MAVLink 2: 10 header + 255 payload + 2 CRC + 13 signature
WINDOW = 150                     # messages of the recorded stream each case runs through


def fuzz_settings(examples: int):
    return settings(max_examples=examples, derandomize=True, deadline=None, database=None,
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])


NASTY = [math.nan, math.inf, -math.inf, 0.0, -0.0, -1.0, -1e6, 1e6, 3.4e38, -3.4e38, 1e-38,
         1e20, 7.0, -7.0, 100.0, 4.0 * math.pi]
nasty_floats = st.one_of(st.sampled_from(NASTY),
                         st.floats(width=32, allow_nan=True, allow_infinity=True))
FLOAT_FIELDS = {
    "ATTITUDE": ("yaw", "yawspeed", "roll", "pitch"),
    "LOCAL_POSITION_NED": ("x", "y", "vx", "vy", "z"),
    "OBSTACLE_DISTANCE_3D": ("x", "y", "z", "min_distance", "max_distance"),
    "OBSTACLE_DISTANCE": ("increment_f", "angle_offset"),
}
INT_FIELDS = {                   # field: (lowest, highest) the wire allows
    "obstacle_id": (0, 65535), "frame": (0, 255), "base_mode": (0, 255),
    "custom_mode": (0, 2 ** 32 - 1), "autopilot": (0, 255), "type": (0, 255),
    "increment": (0, 255), "min_distance": (0, 65535), "max_distance": (0, 65535),
    "command": (0, 65535), "result": (0, 255), "severity": (0, 255),
}
TIME_FIELDS = ("time_boot_ms", "time_usec")

mutation = st.one_of(
    st.tuples(st.just("float"), st.integers(0, 9), nasty_floats),
    st.tuples(st.just("int"), st.sampled_from(sorted(INT_FIELDS)), st.floats(0.0, 1.0)),
    st.tuples(st.just("time"), st.sampled_from([-1e6, -100.0, -2.0, -0.5, -0.05, 0.05, 3.0,
                                                100.0, 1e5, 0.0]), st.booleans()),
    st.tuples(st.just("distances"), st.lists(st.integers(0, 65535), min_size=1, max_size=8),
              st.booleans()),
    st.tuples(st.just("sysid"), st.integers(0, 255), st.booleans()),
    st.tuples(st.just("duplicate"), st.booleans(), st.booleans()),
    st.tuples(st.just("swap"), st.booleans(), st.booleans()),
    st.tuples(st.just("drop"), st.booleans(), st.booleans()),
)
mutations = st.lists(st.tuples(st.integers(0, WINDOW - 1), mutation), min_size=1, max_size=25)


class Repacker:
    """Packs a (mutated) message as its own source would, then parses it back: the values go
    through the wire (float32, integer widths) and the real parser."""

    def __init__(self) -> None:
        self.encoders: dict[tuple[int, int], codec.Encoder] = {}
        self.parser = codec.Parser()

    def __call__(self, msg, system_id: int | None = None):
        key = (msg.get_srcSystem() if system_id is None else system_id, msg.get_srcComponent())
        encoder = self.encoders.setdefault(key, codec.Encoder(*key))
        msgs = self.parser.feed(encoder.encode(msg))
        return msgs[0] if msgs else None


def mutate(window: list, plan: list) -> list:
    """Apply the plan to a window of (link time, packet): returns (link time, message) pairs."""
    parser, repack = codec.Parser(), Repacker()
    items = [(t, parser.decode_packet(p)) for t, p in window]
    for index, (op, a, b) in plan:
        if index >= len(items):
            continue
        t_link, msg = items[index]
        kind = msg.get_type()
        if op == "float":
            fields = FLOAT_FIELDS.get(kind)
            if fields:
                setattr(msg, fields[a % len(fields)], b)
                items[index] = (t_link, repack(msg))
        elif op == "int" and hasattr(msg, a):
            low, high = INT_FIELDS[a]
            setattr(msg, a, int(low + b * (high - low)))
            items[index] = (t_link, repack(msg))
        elif op == "time":
            field = next((f for f in TIME_FIELDS if hasattr(msg, f)), None)
            if field is not None:
                scale = 1000.0 if field == "time_boot_ms" else 1e6
                top = 2 ** 32 - 1 if field == "time_boot_ms" else 2 ** 63
                value = 0 if (a == 0.0 and b) else getattr(msg, field) + int(a * scale)
                setattr(msg, field, min(max(value, 0), top))
                items[index] = (t_link, repack(msg))
        elif op == "distances" and kind == "OBSTACLE_DISTANCE":
            msg.distances = (a * (72 // len(a) + 1))[:72]
            items[index] = (t_link, repack(msg))
        elif op == "sysid":
            items[index] = (t_link, repack(msg, system_id=a))
        elif op == "duplicate":
            items.insert(index + 1, (t_link, msg))
        elif op == "swap" and index + 1 < len(items):
            (t1, m1), (t2, m2) = items[index], items[index + 1]
            items[index], items[index + 1] = (t1, m2), (t2, m1)
        elif op == "drop":
            items.pop(index)
    return [(t, m) for t, m in items if m is not None]


def run_through(pipeline, items) -> list:
    """Feed (link time, message) pairs; check the invariants after every message."""
    max_speed = pipeline.config.commanding.max_speed_mps
    outputs = []
    for t_link, msg in items:
        out = pipeline.handle(t_link, codec.decode(msg))
        check_outputs(out, max_speed)
        outputs.extend(out)
    check_estimate(pipeline)
    return outputs


def field_fuzz(primed, tally, name):
    base, rest = primed

    @given(plan=mutations)
    def case(plan):
        pipeline = clone(base)
        run_through(pipeline, mutate(rest[:WINDOW], plan))
        # and the clean remainder afterwards: the pipeline recovers, invariants still hold
        run_through(pipeline, mutate(rest[WINDOW:2 * WINDOW], []))
        tally(name, rejections(pipeline))
    return case


def test_fuzzed_fields_times_order_and_sources_never_break_the_invariants(primed, tally):
    fuzz_settings(FAST)(field_fuzz(primed, tally, "fields"))()


@pytest.mark.slow
def test_fuzzed_fields_many_cases(primed, tally):
    fuzz_settings(SLOW)(field_fuzz(primed, tally, "fields (slow)"))()


# ------------------------------------------------------------------ bytes
def damage(packets: list[bytes], plan: list, rng: random.Random) -> bytes:
    """Concatenate packets, damaging the planned ones: bit flips, truncation, garbage."""
    out = bytearray()
    ops = dict(plan)
    for i, packet in enumerate(packets):
        op = ops.get(i)
        data = bytearray(packet)
        if op == "flip":
            for _ in range(rng.randint(1, 3)):
                data[rng.randrange(len(data))] ^= 1 << rng.randrange(8)
        elif op == "truncate":
            data = data[:rng.randrange(1, len(data))]
        elif op == "garbage":
            data = bytearray(rng.randbytes(rng.randint(1, 40))) + data
        out += data
    return bytes(out)


byte_plans = st.lists(st.tuples(st.integers(0, WINDOW - 1),
                                st.sampled_from(["flip", "truncate", "garbage"])),
                      min_size=1, max_size=20)


def byte_fuzz(primed, tally, name):
    base, rest = primed
    packets = [p for _, p in rest[:WINDOW]]
    times = [t for t, _ in rest[:WINDOW]]
    originals = set(packets)

    @given(plan=byte_plans, seed=st.integers(0, 2 ** 32 - 1), chunk=st.integers(1, 300))
    def case(plan, seed, chunk):
        rng = random.Random(seed)
        stream = damage(packets, plan, rng)
        parser = codec.Parser()
        msgs = []
        for start in range(0, len(stream), chunk):     # TCP-like arbitrary chunking
            msgs.extend(parser.feed(stream[start:start + chunk]))
        # nothing forged: every message out is one that was sent, intact
        assert all(bytes(m.get_msgbuf()) in originals for m in msgs)
        damaged = {i for i, _ in plan}
        # A damaged packet costs at most the bytes its (maybe damaged) header claims, up to one
        # largest MAVLink 2 packet, of the intact packets after it (pymavlink drops what it
        # swallowed when the CRC fails), plus the packet that region ends in.
        got = {bytes(m.get_msgbuf()) for m in msgs}
        lost = sum(len(p) for i, p in enumerate(packets) if i not in damaged and p not in got)
        assert lost <= len(damaged) * 2 * MAX_PACKET_BYTES
        if min(damaged) < len(packets) - 3:
            # counted: a flipped message id reads as an unknown message, anything else fails
            # its CRC or framing (damage at the very end may still wait for more bytes)
            assert parser.bad_packets + parser.unknown_packets >= 1
        pipeline = clone(base)
        run_through(pipeline, [(times[min(i, len(times) - 1)], m) for i, m in enumerate(msgs)])
        tally(name, {"link bad_packets": parser.bad_packets,
                     "link unknown_packets": parser.unknown_packets, **rejections(pipeline)})
    return case


def test_bit_flipped_truncated_and_garbled_frames_are_counted_never_forged(primed, tally):
    fuzz_settings(FAST)(byte_fuzz(primed, tally, "bytes"))()


@pytest.mark.slow
def test_bit_flipped_frames_many_cases(primed, tally):
    fuzz_settings(SLOW)(byte_fuzz(primed, tally, "bytes (slow)"))()


def random_bytes_fuzz(recording, tally, name):
    @given(data=st.binary(max_size=4096), chunk=st.integers(1, 512))
    def case(data, chunk):
        parser = codec.Parser()
        pipeline = fresh_pipeline(recording)
        for start in range(0, len(data), chunk):
            for msg in parser.feed(data[start:start + chunk]):
                check_outputs(pipeline.handle(0.0, codec.decode(msg)), 8.0)
        check_estimate(pipeline)
        tally(name, {"link bad_packets": parser.bad_packets})
    return case


def test_random_bytes_never_escape_the_parser(recording, tally):
    fuzz_settings(FAST * 2)(random_bytes_fuzz(recording, tally, "random bytes"))()


@pytest.mark.slow
def test_random_bytes_many_cases(recording, tally):
    fuzz_settings(SLOW)(random_bytes_fuzz(recording, tally, "random bytes (slow)"))()


# ------------------------------------------------------------------ tlog
def tlog_fuzz(recording, tmp_path_factory, tally, name):
    records = recording.packets[:400]
    path = tmp_path_factory.mktemp("tlogfuzz") / "base.tlog"
    with TlogWriter(path) as writer:
        for t_us, packet in records:
            writer.write(t_us, packet)
    clean = path.read_bytes()
    originals = {p for _, p in records}

    @given(ops=st.lists(st.tuples(st.sampled_from(["flip", "cut", "insert", "delete"]),
                                  st.floats(0.0, 1.0), st.integers(1, 64)), max_size=12))
    def case(ops):
        data = bytearray(clean)
        for op, where, size in ops:
            pos = int(where * max(len(data) - 1, 0))
            if op == "flip" and data:
                data[pos] ^= 1 << (size % 8)
            elif op == "cut":
                del data[pos:]
            elif op == "insert":
                data[pos:pos] = random.Random(size).randbytes(size)
            elif op == "delete":
                del data[pos:pos + size]
        broken = path.with_name("broken.tlog")
        broken.write_bytes(bytes(data))
        reader = TlogReader(broken)
        got = list(reader)
        assert all(bytes(r.msg.get_msgbuf()) in originals for r in got)
        if not ops:
            assert len(got) == len(records) and not reader.stats.damaged
        assert reader.stats.records == len(got)
        tally(name, {"tlog bad_packets": reader.stats.bad_packets,
                     "tlog skipped_regions": reader.stats.skipped_regions})
    return case


def test_damaged_tlogs_read_without_exception_and_forge_nothing(recording, tmp_path_factory,
                                                                tally):
    fuzz_settings(FAST)(tlog_fuzz(recording, tmp_path_factory, tally, "tlog"))()


@pytest.mark.slow
def test_damaged_tlogs_many_cases(recording, tmp_path_factory, tally):
    fuzz_settings(SLOW // 3)(tlog_fuzz(recording, tmp_path_factory, tally, "tlog (slow)"))()
