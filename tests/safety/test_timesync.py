"""TIMESYNC (safety/timesync.py): the offset from a request and its reply, the shortest round
trip kept, replies to nobody's request refused; the pipeline maps a Unix-stamped camera frame by
it once it has one; the stub answers as ArduPilot's handle_timesync does."""
from __future__ import annotations

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from companion.mavlink import codec
from companion.onboard.safety.timesync import TimeSync

S = 1_000_000_000


def test_offset_is_the_reply_against_the_midpoint_and_the_shortest_round_trip_wins():
    sync = TimeSync()
    unix0 = 1_760_000_000 * S
    # the vehicle booted 1000 s of our clock ago; the first reply was delayed 80 ms on the way
    # back (its offset is 40 ms off), the second came in 2 ms each way
    ts1 = sync.request(unix0)
    late = sync.on_reply((unix0 - unix0) + 1000 * S + 2_000_000, ts1, unix0 + 82_000_000)
    ts1 = sync.request(unix0 + S)
    good = sync.on_reply(1001 * S + 2_000_000, ts1, unix0 + S + 4_000_000)
    assert late.round_trip_ns == 82_000_000 and good.round_trip_ns == 4_000_000
    assert sync.best() == good and good.offset_ns == 1000 * S - unix0
    assert abs(sync.vehicle_time_s(unix0 / S + 5.0) - 1005.0) < 1e-6
    assert sync.on_reply(7 * S, 12345, unix0) is None and sync.refused == 1   # not our request
    sync.forget()
    assert sync.vehicle_time_s(unix0 / S) is None


def test_the_codec_decodes_replies_only_and_encodes_a_request():
    enc = mavlink.MAVLink(None, srcSystem=1, srcComponent=1)
    reply = mavlink.MAVLink_timesync_message(5 * S, 42)
    reply.pack(enc)
    assert codec.decode(reply) == codec.TimeSyncReply(1, 1, 5 * S, 42)
    request = mavlink.MAVLink_timesync_message(0, 42)
    request.pack(enc)
    assert codec.decode(request) is None
    assert (codec.timesync_request(99).tc1, codec.timesync_request(99).ts1) == (0, 99)


def test_the_stub_answers_a_request_with_its_time_since_boot():
    from sitl_stub.autopilot import Autopilot
    from sitl_stub.params import ParamTable
    from sitl_stub.sim import Simulation
    from sitl_stub.world import load_scenario

    ap = Autopilot(Simulation(load_scenario("config/scenarios/paper.yaml")), ParamTable())
    enc = mavlink.MAVLink(None, srcSystem=255, srcComponent=190)
    request = mavlink.MAVLink_timesync_message(0, 777)
    request.pack(enc)
    [(_, answer)] = ap.handle(request, 12.5)
    assert (answer.tc1, answer.ts1) == (12_500_000_000, 777)
    reply = mavlink.MAVLink_timesync_message(1, 777)
    reply.pack(enc)
    assert ap.handle(reply, 12.5) == []


def test_the_pipeline_maps_a_unix_stamped_frame_by_timesync_once_it_has_one():
    from companion.config.service import load_config
    from companion.onboard.pipeline import Pipeline

    pipeline = Pipeline(load_config("config/companion.yaml"), None)
    pipeline.clock.on_autopilot(100.0, None)
    unix_s = 1_760_000_000.0
    ts1 = pipeline.timesync.request(int(unix_s * S))
    pipeline.timesync.on_reply(int(100.0 * S), ts1, int(unix_s * S) + 2_000_000)
    frame = codec.ObstacleFrame(1, 100, unix_s + 0.25, ())
    mapped = pipeline.frames.in_vehicle_time(frame, [])
    assert abs(mapped.t_s - 100.249) < 1e-6 and pipeline.wants_timesync
