"""benchmarks/mavlink_floor.py reads a lock-step flight's tlog back message for message (MAVLink 2
frames, signed ones 13 bytes longer), counts its control steps and gives strict JSON figures.
Timings are not checked here (benchmarks/run.py is where they live)."""
from __future__ import annotations

import json
import struct

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from benchmarks import mavlink_floor


class _Sink:
    def write(self, data: bytes) -> None:
        pass


def test_a_tlog_is_read_back_whole_and_measured(tmp_path):
    stub, companion = mavlink.MAVLink(_Sink(), 1, 1), mavlink.MAVLink(_Sink(), 1, 191)
    signed = mavlink.MAVLink(_Sink(), 1, 191)
    signed.signing.secret_key, signed.signing.sign_outgoing = b"k" * 32, True
    frames = []
    for step in range(5):
        frames.append(mavlink.MAVLink_local_position_ned_message(
            step * 100, 1.0 * step, 0.5, -10.0, 1.0, 0.0, 0.0).pack(stub))
        frames.append(mavlink.MAVLink_attitude_message(step * 100, 0.0, 0.0, 0.1, 0, 0, 0)
                      .pack(stub))
        frames.append(mavlink.MAVLink_statustext_message(6, b"step %d" % step).pack(companion))
    frames.append(mavlink.MAVLink_heartbeat_message(18, 8, 0, 0, 0, 3).pack(signed))
    tlog = tmp_path / "flight.tlog"
    tlog.write_bytes(b"".join(struct.pack(">Q", 1000 * i) + f for i, f in enumerate(frames)))

    records, steps = mavlink_floor.read_flight(tlog)
    assert steps == 5
    assert [cls.msgname for _, _, cls, _ in records] == \
        ["LOCAL_POSITION_NED", "ATTITUDE", "STATUSTEXT"] * 5 + ["HEARTBEAT"]
    assert records[2][:2] == (1, 191)

    floor = mavlink_floor.measure(tlog, repeats=1)
    assert floor["messages"] == 16 and floor["steps"] == 5
    assert floor["max_real_time_factor"] > 0.0
    json.dumps(floor, allow_nan=False)
