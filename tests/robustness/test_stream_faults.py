"""Faults of the inbound stream on a real recorded flight: each kind of bad message is refused and
counted under its own name, a vehicle reboot resets the estimate cleanly, and a second system on
the link changes nothing the vehicle's own stream decides."""
from __future__ import annotations

import math

import numpy as np
import pytest

from companion.mavlink import codec
from companion.mavlink.dialect import mavlink
from companion.core.estimation.slam_types import Observation
from companion.onboard.pipeline import StreamsWanted, snapshot
from tests.robustness.support import (check_estimate, check_outputs, clone, fresh_pipeline,
                                      rejections)
from tests.robustness.test_fuzz_receive import Repacker

CAMERA = 100


def wire(msg, system_id=1, component_id=1):
    """A message as received: packed by its source, parsed back."""
    return Repacker()(_with_source(msg, system_id, component_id))


def _with_source(msg, system_id, component_id):
    encoder = codec.Encoder(system_id, component_id)
    return codec.Parser().feed(encoder.encode(msg))[0]


def obstacle_3d(t_s, x=20.0, y=1.0, frame=mavlink.MAV_FRAME_BODY_FRD, oid=7, max_m=40.0):
    return mavlink.MAVLink_obstacle_distance_3d_message(
        codec.ms_of(t_s), 0, frame, oid, x, y, 0.0, 0.5, max_m)


def sectors(t_s, angle_offset=-45.0):
    return mavlink.MAVLink_obstacle_distance_message(
        int(t_s * 1e6), 0, [2000] + [65535] * 71, 5, 50, 4000, 0.0, angle_offset,
        mavlink.MAV_FRAME_BODY_FRD)


def position(t_s, vx=5.0):
    return mavlink.MAVLink_local_position_ned_message(codec.ms_of(t_s), 10.0, 0.0, -10.0,
                                                      vx, 0.0, 0.0)


BAD = {   # case: (builder(t_s of the pipeline) -> (msg, sysid, compid), counter that must grow)
    "obstacle NaN x": (lambda t: (obstacle_3d(t, x=math.nan), 1, CAMERA),
                       "pipeline obstacle_rejected"),
    "obstacle inf y": (lambda t: (obstacle_3d(t, y=math.inf), 1, CAMERA),
                       "pipeline obstacle_rejected"),
    "obstacle beyond max_distance": (lambda t: (obstacle_3d(t, x=1e30), 1, CAMERA),
                                     "pipeline obstacle_rejected"),
    "obstacle at zero range": (lambda t: (obstacle_3d(t, x=0.0, y=0.0), 1, CAMERA),
                               "pipeline obstacle_rejected"),
    "obstacle in LOCAL_NED": (lambda t: (obstacle_3d(t, frame=mavlink.MAV_FRAME_LOCAL_NED), 1,
                                         CAMERA), "pipeline obstacle_rejected"),
    "sectors NaN angle": (lambda t: (sectors(t, math.nan), 1, CAMERA),
                          "pipeline obstacle_rejected"),
    "obstacle from another system": (lambda t: (obstacle_3d(t), 9, CAMERA),
                                     "pipeline ignored_other_source"),
    "obstacle from another component": (lambda t: (obstacle_3d(t), 1, 42),
                                        "pipeline ignored_other_source"),
    "position NaN velocity": (lambda t: (position(t + 0.05, vx=math.nan), 1, 1),
                              "navigator odometry_not_finite"),
    "position infinite velocity": (lambda t: (position(t + 0.05, vx=-math.inf), 1, 1),
                                   "navigator odometry_not_finite"),
    "position absurd velocity": (lambda t: (position(t + 0.05, vx=3.4e38), 1, 1),
                                 "pipeline odometry_implausible_speed"),
    "obstacle absurd range, no max_distance": (lambda t: (obstacle_3d(t, x=1e30, max_m=0.0), 1,
                                                          CAMERA),
                                               "pipeline observation_implausible_range"),
    "position not newer": (lambda t: (position(t - 0.5), 1, 1),
                           "pipeline odometry_not_newer"),
    "position without attitude": (lambda t: (position(t + 0.9), 1, 1),
                                  "pipeline odometry_without_attitude"),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_each_kind_of_bad_message_is_refused_and_counted_by_kind(primed, case, tally):
    base, rest = primed
    pipeline = clone(base)
    before = rejections(pipeline)
    mean_before = pipeline.navigator.slam.mean.copy()
    build, counter = BAD[case]
    msg, sysid, compid = build(pipeline.latest_t_s)
    out = pipeline.handle(rest[0][0], codec.decode(_with_source(msg, sysid, compid)))
    if case == "position without attitude":     # held until the next position shows no attitude
        out += pipeline.handle(rest[0][0], codec.decode(_with_source(
            position(pipeline.latest_t_s + 0.9), 1, 1)))
    elif case.startswith("position") and case != "position not newer":
        # a position waits for the attitude of its own time: send it
        attitude = mavlink.MAVLink_attitude_message(msg.time_boot_ms, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
        out += pipeline.handle(rest[0][0], codec.decode(_with_source(attitude, 1, 1)))
    check_outputs(out, pipeline.config.commanding.max_speed_mps)
    after = rejections(pipeline)
    assert after.get(counter, 0) == before.get(counter, 0) + 1, (case, before, after)
    assert pipeline.navigator.slam.landmark_count == base.navigator.slam.landmark_count
    if not case.startswith("position without"):
        np.testing.assert_array_equal(pipeline.navigator.slam.mean, mean_before)
    check_estimate(pipeline)
    tally("bad message table", {k: after[k] - before.get(k, 0) for k in after})


@pytest.mark.parametrize("observation, kind", [
    (Observation(math.nan, 0.1, 3), "observation_not_finite"),
    (Observation(20.0, math.inf, 3), "observation_not_finite"),
    (Observation(-5.0, 0.1, 3), "observation_range_not_positive"),
    (Observation(0.0, 0.1, None), "observation_range_not_positive"),
])
def test_the_navigator_refuses_impossible_observations(primed, observation, kind):
    nav = clone(primed[0]).navigator
    landmarks, mean = nav.slam.landmark_count, nav.slam.mean.copy()
    good = Observation(15.0, 0.2, 4242)
    nav.on_observations(nav.t_s, [observation, good])
    assert nav.rejected.get(kind) == 1
    assert nav.slam.landmark_count == landmarks + 1        # the good one still counts
    assert np.all(np.isfinite(nav.slam.mean)) and np.allclose(nav.slam.mean[:3], mean[:3],
                                                              atol=1.0)


def test_signing_refuses_unsigned_wrong_key_and_replayed_packets_and_counts_them():
    key, other = bytes(range(32)), bytes(range(1, 33))
    msg = mavlink.MAVLink_attitude_message(1000, 0.0, 0.0, 0.5, 0.0, 0.0, 0.0)
    signed = codec.Encoder(1, 1, key).encode(msg)
    parser = codec.Parser(key)
    assert [m.get_type() for m in parser.feed(signed)] == ["ATTITUDE"]
    assert parser.feed(signed) == []                                     # replayed
    assert parser.feed(codec.Encoder(1, 1).encode(msg)) == []            # unsigned
    assert parser.feed(codec.Encoder(1, 1, other).encode(msg)) == []     # another key
    assert parser.feed(codec.Encoder(2, 1, key, unix_s=0.0).encode(msg)) == []   # stale stream
    assert parser.signature_rejected == 4 and parser.bad_packets == 0
    assert signed[2] & 0x01 and key not in signed            # signed; the key never travels


# ------------------------------------------------------------------ reboot
def test_vehicle_reboot_resets_the_estimator_says_so_and_asks_for_streams(recording):
    messages = recording.messages()
    first_link_s, last_link_s = messages[0][0], messages[-1][0]
    # Pinned ids: the first pass uses the messages before the vehicle's first heartbeat too,
    # as the second pass (vehicle already known) does.
    pipeline = fresh_pipeline(recording, vehicle_system_id=1, vehicle_component_id=1)
    for t_link, msg in messages:
        pipeline.handle(t_link, codec.decode(msg))
    nav_before = pipeline.navigator
    mean_once, landmarks_once = nav_before.slam.mean.copy(), nav_before.slam.landmark_ids()
    assert pipeline.reset_counter == 0
    # The same flight again, the vehicle's clock restarting from boot; the link clock goes on.
    shift_s = last_link_s - first_link_s + 1.0
    outputs = []
    for t_link, msg in messages:
        out = pipeline.handle(t_link + shift_s, codec.decode(msg))
        check_outputs(out, pipeline.config.commanding.max_speed_mps)
        outputs.extend(out)
    assert pipeline.reset_counter == 1
    assert pipeline.navigator is not nav_before
    assert StreamsWanted("vehicle reboot") in outputs
    notices = [o.text for o in outputs if isinstance(o, codec.Notice)]
    assert any("reboot" in text for text in notices)
    poses = [o for o in outputs if isinstance(o, codec.PoseEstimate)]
    assert poses and {p.reset_counter for p in poses} == {1}
    check_estimate(pipeline)
    # a clean restart: the same stream rebuilds the same estimate and map
    assert pipeline.navigator.slam.landmark_ids() == landmarks_once
    np.testing.assert_allclose(pipeline.navigator.slam.mean, mean_once, atol=1e-9)


# ------------------------------------------------------------------ a second system
def intruded(messages: list) -> list:
    """After each of the vehicle's messages, a copy from system 2: heartbeats disarmed in
    another mode, obstacles moved 3 m and renumbered, positions and yaw offset."""
    repack = Repacker()
    out = []
    for t_link, msg in messages:
        out.append((t_link, msg))
        if msg.get_srcSystem() != 1:
            continue
        twin = Repacker()(msg)
        kind = twin.get_type()
        if kind == "HEARTBEAT":
            twin.base_mode, twin.custom_mode = 0, 5
        elif kind == "OBSTACLE_DISTANCE_3D":
            twin.x, twin.obstacle_id = twin.x - 3.0, (twin.obstacle_id + 500) % 65535
        elif kind == "LOCAL_POSITION_NED":
            twin.x, twin.vx = twin.x + 50.0, twin.vx + 2.0
        elif kind == "ATTITUDE":
            twin.yaw += 0.5
        out.append((t_link, repack(twin, system_id=2)))
    return out


def test_a_second_system_cannot_move_the_map_or_change_the_commands(recording):
    messages = recording.messages()
    runs = []
    for stream in (messages, intruded(recording.messages())):
        pipeline = fresh_pipeline(recording)
        setpoints = []
        for t_link, msg in stream:
            out = pipeline.handle(t_link, codec.decode(msg))
            setpoints += [o for o in out if isinstance(o, codec.VelocitySetpoint)]
        runs.append((pipeline, setpoints))
    (clean, clean_sp), (mixed, mixed_sp) = runs
    assert len(clean_sp) > 50 and mixed_sp == clean_sp
    a, b = snapshot(clean), snapshot(mixed)
    assert b["other_vehicles"] == [2] and a["other_vehicles"] == []
    assert b["counters"]["ignored_other_source"] > a["counters"].get("ignored_other_source", 0)
    for key in ("landmarks", "urgency_events", "vehicle", "arrival_t_s", "rejected_by_estimator",
                "setpoints"):
        assert a[key] == b[key], key
    np.testing.assert_array_equal(clean.navigator.slam.mean, mixed.navigator.slam.mean)
