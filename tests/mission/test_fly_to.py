"""'Fly to here': a ground station's position target or DO_REPOSITION becomes the goal, in GUIDED,
within the bounds; otherwise refused with the reason (decoded from real MAVLink packets)."""
from __future__ import annotations

import math

import pytest

from companion.mavlink import codec
from companion.mavlink.mission_codec import GoalRequest
from companion.config.service import FlyToConfig
from companion.onboard.fly_to import judge
from companion.core.flat_earth import LOCATION_SCALING_FACTOR_M

ORIGIN = codec.GeoReference(1, 1, "origin", -35.363261, 149.165230, 0.0, 0.0)
LIMITS = FlyToConfig(max_distance_from_origin_m=1000.0, max_distance_from_vehicle_m=500.0)
DEG_PER_M = 1e-7 / LOCATION_SCALING_FACTOR_M       # latitude degrees per metre north


def decoded(msg) -> GoalRequest:
    packet = codec.Encoder(255, 190).encode(msg)
    parsed = codec.Parser().feed(packet)[0]
    return codec.decode(parsed)


def position_target(lat, lon, mask=0x0FF8, frame=6, target=(1, 1)):
    return decoded(codec.mavlink.MAVLink_set_position_target_global_int_message(
        0, *target, frame, mask, int(lat * 1e7), int(lon * 1e7), 10.0, 0, 0, 0, 0, 0, 0, 0, 0))


def reposition_int(lat, lon, target=(1, 1)):
    return decoded(codec.mavlink.MAVLink_command_int_message(
        *target, 6, 192, 0, 0, -1, 0, 0, 0, int(lat * 1e7), int(lon * 1e7), 10.0))


def test_a_position_target_in_guided_becomes_metres_from_the_origin():
    req = position_target(ORIGIN.lat_deg + 100 * DEG_PER_M, ORIGIN.lon_deg)
    verdict = judge(req, (1, 1), True, ORIGIN, (0.0, 0.0), LIMITS)
    assert verdict.accepted and verdict.north_m == pytest.approx(100.0, abs=0.02)
    assert abs(verdict.east_m) < 0.02


def test_a_reposition_command_int_and_long_are_read_alike():
    lat = ORIGIN.lat_deg + 50 * DEG_PER_M
    a = judge(reposition_int(lat, ORIGIN.lon_deg), (1, 1), True, ORIGIN, None, LIMITS)
    long_req = decoded(codec.mavlink.MAVLink_command_long_message(
        1, 0, 192, 0, -1, 0, 0, 0, lat, ORIGIN.lon_deg, 10.0))
    b = judge(long_req, (1, 1), True, ORIGIN, None, LIMITS)
    # COMMAND_LONG's float32 degrees resolve about 1 m at this latitude; COMMAND_INT's 1e-7
    assert a.accepted and b.accepted and a.north_m == pytest.approx(50.0, abs=0.02)
    assert math.hypot(b.north_m - 50.0, b.east_m) < 1.5


@pytest.mark.parametrize("request_, guided, ref, position, reason", [
    (lambda: position_target(-35.363261 + 5000 * DEG_PER_M, 149.16523), True, ORIGIN, None,
     "5000 m from origin > 1000"),
    (lambda: position_target(-35.363261 + 800 * DEG_PER_M, 149.16523), True, ORIGIN, (0.0, 0.0),
     "800 m away > 500"),
    (lambda: position_target(-35.36, 149.16, mask=0x0FC7), True, ORIGIN, None, "has no position"),
    (lambda: position_target(-35.36, 149.16, frame=1), True, ORIGIN, None, "not global"),
    (lambda: position_target(-35.36, 149.16), False, ORIGIN, None, "not in GUIDED"),
    (lambda: position_target(-35.36, 149.16), True, None, None, "EKF origin not known"),
    (lambda: position_target(-35.36, 149.16, target=(2, 1)), True, ORIGIN, None,
     "not addressed"),
])
def test_refused_with_the_reason(request_, guided, ref, position, reason):
    verdict = judge(request_(), (1, 1), guided, ref, position, LIMITS)
    assert not verdict.accepted and reason in verdict.reason
    assert len(f"companion: goal refused: {verdict.reason}") <= codec.STATUSTEXT_MAX_CHARS \
        or reason == "not addressed"
    assert math.isnan(verdict.north_m)
