"""The map as OBSTACLE_DISTANCE: sectors worked out by hand, the message as AP_Proximity_MAV reads
it (increment_f, angle_offset 0, BODY_FRD, cm within [min, max], max + 1 for none)."""
from __future__ import annotations

import math
import os

import numpy as np
import pytest

os.environ.setdefault("MAVLINK20", "1")
from pymavlink.dialects.v20 import ardupilotmega as mavlink  # noqa: E402

from companion.mavlink import codec  # noqa: E402
from companion.config.service import MapOutputConfig  # noqa: E402
from companion.core.perception.sector_map import scan_map  # noqa: E402
from companion.onboard.map_output import MapPublisher  # noqa: E402


def test_a_disc_ahead_fills_the_sectors_its_outline_subtends():
    # 20 m north, radius 2 m, vehicle facing north. Ray at 0 deg: surface at 18 m. Ray at 5 deg:
    # miss distance 20 sin 5 = 1.743 m < 2, first crossing 20 cos 5 - sqrt(4 - 1.743^2) = 18.94 m.
    # Ray at 10 deg misses (3.47 m) and asin(2/20) = 5.74 deg + half a sector (2.5) < 10: empty.
    scan = scan_map(np.array([0.0, 0.0, 0.0]), np.array([[20.0, 0.0]]), 2.0, 100.0)
    d = scan.distances_m
    assert d[0] == pytest.approx(18.0)
    across = 20 * math.sin(math.radians(5))
    first = 20 * math.cos(math.radians(5)) - math.sqrt(4 - across ** 2)
    assert d[1] == pytest.approx(first) and d[71] == pytest.approx(first)
    assert np.isinf(np.delete(d, [71, 0, 1])).all()
    assert scan.increment_rad == pytest.approx(math.radians(5))


def test_sectors_are_body_frame_and_cover_all_around():
    # Facing east (yaw 90 deg): an obstacle north is 90 deg to the left (sector 54 = 270 deg);
    # one south is to the right (sector 18). Both are outside a 90-degree camera's view.
    pose = np.array([0.0, 0.0, math.pi / 2])
    scan = scan_map(pose, np.array([[30.0, 0.0], [-12.0, 0.0]]), 1.0, 100.0)
    d = scan.distances_m
    assert d[54] == pytest.approx(29.0) and d[18] == pytest.approx(11.0)
    # 30 m away a 1 m disc spans asin(1/30) = 1.9 deg: with half a sector (2.5) it stays in 54;
    # 12 m away, asin(1/12) = 4.8 deg + 2.5 > 5: it reaches sectors 17 and 19 too.
    assert set(np.flatnonzero(np.isfinite(d))) == {54, 17, 18, 19}


def test_nearest_surface_wins_and_far_ones_are_left_out():
    scan = scan_map(np.zeros(3), np.array([[50.0, 0.0], [10.0, 0.0], [0.0, 150.0]]), 2.0, 100.0)
    assert scan.distances_m[0] == pytest.approx(8.0)      # the nearer of the two ahead
    assert np.isinf(scan.distances_m[18])                 # 148 m to the right: beyond range


def test_inside_an_obstacle_every_sector_is_at_zero():
    scan = scan_map(np.zeros(3), np.array([[1.0, 0.0]]), 2.0, 100.0)
    assert np.all(scan.distances_m == 0.0)


def test_the_message_reads_back_as_the_map():
    pose = np.array([5.0, -3.0, math.radians(30)])
    centres = np.array([[25.0, -3.0], [5.0, 17.0]])
    scan = scan_map(pose, centres, 2.0, 100.0)
    sm = codec.SectorMap(12.5, tuple(scan.distances_m), 5.0, 0.2, 100.0)
    parser = mavlink.MAVLink(None)
    packet = codec.Encoder(1, 191).encode(codec.obstacle_distance_map(sm))
    msg = parser.parse_buffer(packet)[0]
    assert msg.frame == mavlink.MAV_FRAME_BODY_FRD and msg.angle_offset == 0.0
    assert msg.increment_f == 5.0 and msg.increment == 5
    assert (msg.min_distance, msg.max_distance) == (20, 10000)
    assert msg.time_usec == 12_500_000
    for i, cm in enumerate(msg.distances):
        if math.isfinite(scan.distances_m[i]):
            assert cm == int(scan.distances_m[i] * 100)
        else:
            assert cm == msg.max_distance + 1               # "no obstacle" in the spec
    # Our own decoder (ArduPilot's rule: element i at angle_offset + i * increment) puts every
    # valid sector on the surface of one of the two mapped discs.
    frame = codec.decode(msg)
    assert frame.observations
    for obs in frame.observations:
        bearing = pose[2] + obs.bearing_rad
        point = pose[:2] + obs.range_m * np.array([math.cos(bearing), math.sin(bearing)])
        gaps = np.hypot(*(centres - point).T)
        assert gaps.min() <= 2.0 + 0.02                    # on or at the outline (cm rounding)


def test_publisher_keeps_its_rate_and_never_sends_a_non_finite_map():
    pub = MapPublisher(MapOutputConfig(rate_hz=5.0))
    lm = np.array([[20.0, 0.0]])
    sent = [t for t in np.arange(0.0, 2.0, 0.1) if pub.scan(float(t), np.zeros(3), lm)]
    assert len(sent) == 10                                 # 5 Hz of vehicle time over 2 s
    assert pub.scan(5.0, np.array([np.nan, 0.0, 0.0]), lm) is None
    assert MapPublisher(MapOutputConfig(rate_hz=0.0)).scan(0.0, np.zeros(3), lm) is None


def test_the_scan_of_many_discs_is_the_nearest_of_each_alone():
    rng = np.random.default_rng(4)
    pose = np.array([3.0, -2.0, 0.7])
    centres = rng.uniform(-60, 60, (40, 2))
    together = scan_map(pose, centres, 1.5, 50.0).distances_m
    alone = np.min([scan_map(pose, c[None, :], 1.5, 50.0).distances_m for c in centres], axis=0)
    assert np.array_equal(together, alone)
    assert np.isfinite(together).sum() > 20
