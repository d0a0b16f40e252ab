"""Tlog writer and tolerant reader, checked against pymavlink's own tlog reader."""
import random

from pymavlink import mavutil

from companion.mavlink import codec
from companion.mavlink.dialect import mavlink
from companion.mavlink.tlog import TlogReader, TlogWriter

T0_US = 1_700_000_000_000_000


def sample_packets(n=20):
    vehicle, us = codec.Encoder(1, 1), codec.Encoder(1, 191)
    out = []
    for i in range(n):
        if i % 2:
            msg = mavlink.MAVLink_attitude_message(100 * i, 0, 0, 0.01 * i, 0, 0, 0)
            out.append(vehicle.encode(msg))
        else:
            sp = codec.VelocitySetpoint(1, 1, 0.1 * i, 1.0, float(i), 0.0, "goal")
            out.append(us.encode(codec.set_position_target(sp)))
    return out


def write_log(path, packets):
    with TlogWriter(path) as tlog:
        for i, packet in enumerate(packets):
            tlog.write(T0_US + 1000 * i, packet)


def test_written_tlog_reads_back_in_pymavlink_with_timestamps(tmp_path):
    path = tmp_path / "a.tlog"
    packets = sample_packets()
    write_log(path, packets)
    conn = mavutil.mavlink_connection(str(path))
    seen = []
    while (msg := conn.recv_match()) is not None:
        seen.append((round(msg._timestamp * 1e6), bytes(msg.get_msgbuf())))
    assert seen == [(T0_US + 1000 * i, p) for i, p in enumerate(packets)]


def test_reader_returns_every_record_of_a_clean_log(tmp_path):
    path = tmp_path / "a.tlog"
    packets = sample_packets()
    write_log(path, packets)
    reader = TlogReader(path)
    records = list(reader)
    assert [bytes(r.msg.get_msgbuf()) for r in records] == packets
    assert [r.t_us for r in records] == [T0_US + 1000 * i for i in range(len(packets))]
    assert not reader.stats.damaged


def test_reader_keeps_everything_before_a_cut_tail(tmp_path):
    path = tmp_path / "a.tlog"
    write_log(path, sample_packets())
    data = path.read_bytes()
    path.write_bytes(data[:-7])
    reader = TlogReader(path)
    assert len(list(reader)) == 19
    assert reader.stats.truncated_tail_bytes > 0 and "mid-packet" in reader.stats.notes[0]


def test_reader_skips_corrupt_bytes_and_resyncs(tmp_path):
    path = tmp_path / "a.tlog"
    packets = sample_packets()
    write_log(path, packets)
    data = bytearray(path.read_bytes())
    middle = len(data) // 2
    data[middle:middle + 40] = random.Random(3).randbytes(40)      # tears through one or two records
    path.write_bytes(bytes(data))
    reader = TlogReader(path)
    got = [bytes(r.msg.get_msgbuf()) for r in reader]
    assert 15 <= len(got) < 20
    assert got[:5] == packets[:5] and got[-5:] == packets[-5:]
    assert reader.stats.damaged


def test_reader_on_empty_and_foreign_files(tmp_path):
    empty = tmp_path / "empty.tlog"
    empty.write_bytes(b"")
    reader = TlogReader(empty)
    assert list(reader) == [] and reader.stats.notes == ["empty file"]
    foreign = tmp_path / "notes.tlog"
    foreign.write_bytes(b"this is a text file, not a telemetry log\n" * 50)
    reader = TlogReader(foreign)
    assert list(reader) == [] and "not a tlog" in reader.stats.notes[0]


def test_writer_flushes_within_its_interval(tmp_path):
    path = tmp_path / "a.tlog"
    tlog = TlogWriter(path, flush_interval_s=0.0)
    tlog.write(T0_US, sample_packets(1)[0])
    assert path.stat().st_size == 8 + len(sample_packets(1)[0])   # on disk before close
    tlog.close()
