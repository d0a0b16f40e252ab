"""Obstacle reports with non-finite or inconsistent bounds or coordinates are refused (issue 14)."""
import math

import pytest

from companion.mavlink import codec
from companion.mavlink.dialect import mavlink
from tests.adapters.test_codec import roundtrip


def obstacle_3d(x=20.0, y=1.0, z=0.0, min_m=0.5, max_m=40.0):
    return mavlink.MAVLink_obstacle_distance_3d_message(
        1000, 0, mavlink.MAV_FRAME_BODY_FRD, 7, x, y, z, min_m, max_m)


@pytest.mark.parametrize("fields, problem", [
    (dict(min_m=math.nan), "non-finite distance bounds"),
    (dict(max_m=math.inf), "non-finite distance bounds"),
    (dict(min_m=-1.0), "negative distance bounds"),
    (dict(max_m=-40.0), "negative distance bounds"),
    (dict(min_m=30.0, max_m=10.0, x=20.0), "min_distance above max_distance"),
    (dict(z=math.nan), "non-finite position"),
    (dict(z=-math.inf), "non-finite position"),
])
def test_obstacle_3d_with_bad_bounds_or_z_is_refused(fields, problem):
    frame = codec.decode(roundtrip(obstacle_3d(**fields)))
    assert frame.observations == () and frame.rejected == problem


def test_obstacle_3d_within_sane_bounds_still_gives_its_observation():
    frame = codec.decode(roundtrip(obstacle_3d()))
    assert frame.rejected is None and len(frame.observations) == 1


def sectors(min_cm=50, max_cm=4000, increment=5, increment_f=0.0):
    return mavlink.MAVLink_obstacle_distance_message(
        1_000_000, 0, [2000] + [65535] * 71, increment, min_cm, max_cm, increment_f, -45.0,
        mavlink.MAV_FRAME_BODY_FRD)


@pytest.mark.parametrize("fields, problem", [
    (dict(min_cm=5000, max_cm=4000), "min_distance above max_distance"),
    (dict(increment=0, increment_f=0.0), "sector increment not positive"),
    (dict(increment_f=-1.0), "sector increment not positive"),
])
def test_sectors_with_inconsistent_bounds_or_no_increment_are_refused(fields, problem):
    frame = codec.decode(roundtrip(sectors(**fields)))
    assert frame.observations == () and frame.rejected == problem


def test_an_empty_sector_frame_is_a_frame_without_observations_not_a_refusal():
    msg = mavlink.MAVLink_obstacle_distance_message(
        1_000_000, 0, [4001] * 72, 0, 50, 4000, 1.25, -45.0, mavlink.MAV_FRAME_BODY_FRD)
    frame = codec.decode(roundtrip(msg))
    assert frame.rejected is None and frame.observations == ()
