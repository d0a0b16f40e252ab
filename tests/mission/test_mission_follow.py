"""Following the mission: the goal is the current waypoint (global ones via the EKF origin), each
arrival is announced, and a MISSION_CURRENT that says the mission changed starts a new download."""
from __future__ import annotations

import pytest

from companion.mavlink import codec
from companion.mavlink import mission_codec as mc
from companion.core.flat_earth import LOCATION_SCALING_FACTOR_M
from companion.onboard.mission_follow import MissionFollower

VEHICLE = (1, 1)


def download(follower, items, t_s=0.0):
    out = follower.on_vehicle(t_s, VEHICLE)
    out += follower.on_event(t_s, mc.MissionCount(*VEHICLE, len(items), 0, 1, 191))
    for it in items:
        out += follower.on_event(t_s, it)
    return out


def wp(seq, frame, x, y):
    return mc.MissionItem(*VEHICLE, seq, frame, mc.CMD_NAV_WAYPOINT, (0.0, 0.0, 0.0, 0.0),
                          x, y, 10.0, 0, 1, 191)


HOME = wp(0, mc.FRAME_GLOBAL, -353632610, 1491652300)


def notices(out):
    return [o.text for o in out if isinstance(o, codec.Notice)]


def test_waypoints_in_order_global_ones_from_the_ekf_origin():
    f = MissionFollower(191, 2.0)
    out = download(f, [HOME, wp(1, mc.FRAME_LOCAL_NED, 300000, 0),
                       wp(2, mc.FRAME_GLOBAL_RELATIVE_ALT_INT, -353632610 + 1000, 1491652300)])
    assert "companion: mission of 2 waypoints" in notices(out)
    assert f.goal() == (30.0, 0.0, 2.0)
    assert notices(f.on_arrived(10.0)) == ["companion: waypoint 1 reached"]
    assert f.goal() is None and f.needs_geo_reference            # waits for the origin
    f.on_geo_reference(codec.GeoReference(*VEHICLE, "origin", -35.3632610, 149.1652300, 0, 0))
    north, east, radius = f.goal()
    assert north == pytest.approx(1000 * LOCATION_SCALING_FACTOR_M) and abs(east) < 1e-6
    assert notices(f.on_arrived(20.0)) == ["companion: waypoint 2 reached",
                                           "companion: mission complete"]
    assert f.complete and f.reached == [1, 2] and f.goal()[:2] == (north, east)   # hold there


def test_a_changed_mission_is_read_again_and_flown_from_its_start():
    f = MissionFollower(191, 2.0)
    download(f, [HOME, wp(1, mc.FRAME_LOCAL_NED, 300000, 0)])
    f.on_arrived(5.0)
    assert f.on_event(6.0, mc.MissionCurrent(*VEHICLE, 0, 1, 0)) == []    # first: recorded
    assert f.on_event(6.5, mc.MissionCurrent(*VEHICLE, 0, 1, 0)) == []    # unchanged
    out = f.on_event(7.0, mc.MissionCurrent(*VEHICLE, 0, 2, 0))           # now 2 items
    assert "companion: mission changed, re-reading" in notices(out)
    assert mc.RequestList(1, 1) in out
    f.on_event(7.1, mc.MissionCount(*VEHICLE, 3, 0, 1, 191))
    for it in (HOME, wp(1, mc.FRAME_LOCAL_NED, 300000, 0), wp(2, mc.FRAME_LOCAL_NED, 0, 300000)):
        f.on_event(7.2, it)
    assert f.downloads == 2 and f.index == 0 and f.goal() == (30.0, 0.0, 2.0)


def test_a_failed_download_is_said_and_tried_again_later():
    f = MissionFollower(191, 2.0)
    f.on_vehicle(0.0, VEHICLE)
    out = []
    for k in range(1, 8):
        out += f.tick(1.6 * k)
    assert any("mission download failed" in t for t in notices(out))
    assert f.download is None
    assert mc.RequestList(1, 1) in f.tick(1.6 * 7 + 5.0)                  # retried
