"""benchmarks/cpu_quota.py's obstacle-to-setpoint rule, on a tlog written and read back: a frame
is answered by the first setpoint sent after its last report that was made on a pose at or after
its capture, and a frame that saw nothing is not a frame to answer."""
import pytest

from benchmarks.cpu_quota import capture_to_setpoint_s
from companion.mavlink import codec
from companion.mavlink.dialect import mavlink
from companion.mavlink.tlog import TlogWriter

T0_US = 1_700_000_000_000_000
MAV_FRAME_BODY_FRD = 12


def report(capture_ms, ident):
    return mavlink.MAVLink_obstacle_distance_3d_message(capture_ms, 0, MAV_FRAME_BODY_FRD, ident,
                                                        10.0, 1.0, 0.0, 0.2, 60.0)


def empty_frame(capture_ms):
    return mavlink.MAVLink_obstacle_distance_message(capture_ms * 1000, 0, [6001] * 72, 0, 20,
                                                     6000, 1.25, -45.0, MAV_FRAME_BODY_FRD)


def position(t_ms):
    return mavlink.MAVLink_local_position_ned_message(t_ms, 0, 0, 0, 5, 0, 0)


def setpoint(t_ms):
    return codec.set_position_target(codec.VelocitySetpoint(1, 1, t_ms / 1000.0, 5.0, 0.0, 0.0, "goal"))


def write(path, records):
    """records: (ms after T0, encoder, message)."""
    with TlogWriter(path) as tlog:
        for at_ms, encoder, msg in records:
            tlog.write(T0_US + 1000 * at_ms, encoder.encode(msg))


def test_answer_is_the_first_setpoint_made_on_a_pose_at_or_after_the_capture(tmp_path):
    vehicle, camera, us = codec.Encoder(1, 1), codec.Encoder(1, 100), codec.Encoder(1, 191)
    path = tmp_path / "flight.tlog"
    # vehicle time = Unix time - T0 - 2 ms (the fastest delivery: position at 1000 ms got at 1002)
    write(path, [
        (1002, vehicle, position(1000)),
        (1003, us, setpoint(1000)),           # the first setpoint: commanding from here on
        (1035, camera, report(1033, 1)),
        (1036, camera, report(1033, 2)),      # the frame's last report
        (1040, us, setpoint(1000)),           # made on the older pose: has not seen the frame
        (1069, vehicle, position(1067)),
        (1070, camera, empty_frame(1067)),    # saw nothing: nothing to answer
        (1074, us, setpoint(1067)),           # the answer to 1033 (and not to 1067)
    ])
    frames, total, reaction, offset = capture_to_setpoint_s(path)
    assert offset == pytest.approx((T0_US / 1e6) + 0.002)
    assert frames.tolist() == pytest.approx([1.033])
    assert total.tolist() == pytest.approx([1.074 - 1.033 - 0.002], abs=1e-5)   # capture to it
    assert reaction.tolist() == pytest.approx([1.074 - 1.036], abs=1e-5)     # last report to it


def test_a_late_report_of_an_answered_frame_is_not_a_new_frame(tmp_path):
    vehicle, camera, us = codec.Encoder(1, 1), codec.Encoder(1, 100), codec.Encoder(1, 191)
    path = tmp_path / "flight.tlog"
    write(path, [
        (1000, vehicle, position(1000)),
        (1001, us, setpoint(1000)),
        (1010, camera, report(1000, 1)),
        (1012, us, setpoint(1000)),
        (1030, camera, report(1000, 2)),      # after its answer (a split frame)
        (1040, us, setpoint(1033)),
    ])
    frames, total, _, _ = capture_to_setpoint_s(path)
    assert frames.tolist() == pytest.approx([1.0])
    assert total.tolist() == pytest.approx([0.012], abs=1e-5)
