"""TlogWriter's rotation (issue 31, long runs): a tlog bounded on disk for a flight of any length,
each file a whole tlog that the reader takes on its own, records never split."""
from __future__ import annotations

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from companion.mavlink.tlog import TlogReader, TlogWriter

T0_US = 1_760_000_000_000_000          # a Unix time in microseconds, as the daemon stamps


def packets(n: int) -> list[bytes]:
    enc = mavlink.MAVLink(None, srcSystem=1, srcComponent=1)
    return [bytes(mavlink.MAVLink_attitude_message(k, 0.0, 0.0, 0.1, 0.0, 0.0, 0.0).pack(enc))
            for k in range(n)]


def test_rotation_keeps_at_most_keep_plus_one_whole_files(tmp_path):
    path = tmp_path / "run.tlog"
    sent = packets(2000)
    record = 8 + len(sent[0])
    with TlogWriter(path, max_bytes=100 * record, keep=3) as tlog:
        for k, packet in enumerate(sent):
            tlog.write(T0_US + k, packet)
    files = sorted(tmp_path.glob("run.tlog*"))
    assert [f.name for f in files] == ["run.tlog", "run.tlog.1", "run.tlog.2", "run.tlog.3"]
    assert tlog.rotations == 19 and all(f.stat().st_size <= 100 * record for f in files)
    # newest in PATH, older ones in .1, .2, .3: the last 400 records, in order, none damaged
    times = []
    for f in [files[3], files[2], files[1], files[0]]:
        reader = TlogReader(f)
        times.extend(r.t_us for r in reader)
        assert not reader.stats.damaged
    assert times == [T0_US + k for k in range(1600, 2000)]


def test_without_a_limit_one_file_and_bad_limits_are_refused(tmp_path):
    with TlogWriter(tmp_path / "one.tlog") as tlog:
        for k, packet in enumerate(packets(300)):
            tlog.write(T0_US + k, packet)
    assert tlog.rotations == 0 and [f.name for f in tmp_path.iterdir()] == ["one.tlog"]
    with pytest.raises(ValueError):
        TlogWriter(tmp_path / "x.tlog", max_bytes=0)
