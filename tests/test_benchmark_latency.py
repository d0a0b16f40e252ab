"""benchmarks/system.py's obstacle -> setpoint latency, read off a daemon tlog: the pipeline
holds a camera frame (its reports of one time) until a message that is not part of it, so the
reacting setpoint follows that closing message (benchmarks once found no samples at all)."""
from benchmarks.system import tlog_latencies_ns
from companion.mavlink import codec
from companion.mavlink.dialect import mavlink
from companion.mavlink.tlog import TlogWriter

T0_US = 1_700_000_000_000_000
VEHICLE, CAMERA, US = codec.Encoder(1, 1), codec.Encoder(1, 100), codec.Encoder(1, 191)


def attitude(t_ms):
    return VEHICLE.encode(mavlink.MAVLink_attitude_message(t_ms, 0, 0, 0, 0, 0, 0))


def position(t_ms):
    return VEHICLE.encode(mavlink.MAVLink_local_position_ned_message(t_ms, 0, 0, -10, 0, 0, 0))


def report(t_ms, obstacle_id):
    return CAMERA.encode(mavlink.MAVLink_obstacle_distance_3d_message(
        t_ms, 0, mavlink.MAV_FRAME_BODY_FRD, obstacle_id, 30.0, 3.0, 0.0, 0.2, 40.0))


def setpoint(t_s):
    return US.encode(codec.set_position_target(
        codec.VelocitySetpoint(1, 1, t_s, 1.0, 0.0, 0.0, "goal")))


def write(path, records):
    with TlogWriter(path) as tlog:
        for t_us, data in records:
            tlog.write(T0_US + t_us, data)


def test_a_frame_is_answered_by_the_setpoint_after_the_message_that_closes_it(tmp_path):
    path = tmp_path / "daemon.tlog"
    write(path, [
        # one datagram: the pose, then a frame of two reports of the same time
        (1000, attitude(5000)), (1000, position(5000)), (1000, report(5000, 1)),
        (1000, report(5000, 2)),
        # the next datagram closes the frame: its setpoint answers it (5.1 ms after the reports)
        (6000, VEHICLE.encode(mavlink.MAVLink_sys_status_message(*[0] * 13))),
        (6100, setpoint(5.0)), (6120, setpoint(5.0)),
        # a decision on a pose with no frame waiting is not a reaction to a report
        (11000, position(5100)), (11050, setpoint(5.1)),
        # a report of a new time closes the frame before it; the last frame changes nothing
        (12000, report(5100, 1)), (13000, report(5200, 1)), (13040, setpoint(5.2)),
        (20000, VEHICLE.encode(codec.heartbeat())), (21000, position(5300)),
    ])
    found = tlog_latencies_ns(path)
    assert found.total == [5_100_000, 1_040_000]
    assert found.reaction == [100_000, 40_000]
    assert found.unanswered == 1
    figures = found.as_dict()
    assert figures["samples"] == 2 and figures["reaction"]["samples"] == 2
    assert figures["p50"] == (5.1 + 1.04) / 2 and figures["unanswered"] == 1
