"""The mission download as the MAVLink mission protocol says (mavlink.io services/mission):
REQUEST_LIST -> COUNT -> REQUEST_INT n -> ITEM_INT n ... -> ACK; 1.5 s timeouts, 5 retries."""
from __future__ import annotations

from companion.mavlink import mission_codec as mc
from companion.onboard.mission import MissionDownload, build_plan

VEHICLE = (1, 1)
OWN = 191


def count(n, target_component=OWN):
    return mc.MissionCount(*VEHICLE, n, 0, 1, target_component)


def item(seq, command=mc.CMD_NAV_WAYPOINT, frame=mc.FRAME_GLOBAL_RELATIVE_ALT_INT,
         x=-353620000, y=1491652000, radius=0.0):
    return mc.MissionItem(*VEHICLE, seq, frame, command, (0.0, radius, 0.0, 0.0), x, y, 10.0,
                          0, 1, OWN)


def test_a_full_download_in_order_ends_with_an_accepted_ack():
    dl = MissionDownload(VEHICLE, OWN)
    assert dl.start(0.0) == [mc.RequestList(1, 1)]
    assert dl.on_event(0.1, count(3)) == [mc.RequestItem(1, 1, 0)]
    assert dl.on_event(0.2, item(0)) == [mc.RequestItem(1, 1, 1)]
    assert dl.on_event(0.3, item(1)) == [mc.RequestItem(1, 1, 2)]
    assert dl.on_event(0.4, item(2)) == [mc.AckDownload(1, 1, mc.MISSION_ACCEPTED)]
    assert dl.state == "done" and [i.seq for i in dl.items] == [0, 1, 2]


def test_an_empty_mission_is_acknowledged_at_once():
    dl = MissionDownload(VEHICLE, OWN)
    dl.start(0.0)
    assert dl.on_event(0.1, count(0)) == [mc.AckDownload(1, 1, mc.MISSION_ACCEPTED)]
    assert dl.state == "done" and dl.items == []


def test_a_lost_item_is_asked_again_after_the_timeout_and_then_given_up():
    dl = MissionDownload(VEHICLE, OWN)
    dl.start(0.0)
    dl.on_event(0.0, count(2))
    assert dl.tick(1.4) == []                               # before 1.5 s: wait
    resent = [dl.tick(1.6 * k) for k in range(1, 6)]
    assert resent == [[mc.RequestItem(1, 1, 0)]] * 5        # five retries
    assert dl.tick(9.7) == [mc.AckDownload(1, 1, mc.MISSION_OPERATION_CANCELLED)]
    assert dl.state == "failed" and "item 0" in dl.failure


def test_a_retry_that_is_answered_carries_on():
    dl = MissionDownload(VEHICLE, OWN)
    dl.start(0.0)
    assert dl.tick(1.6) == [mc.RequestList(1, 1)]           # MISSION_COUNT lost
    assert dl.on_event(1.7, count(1)) == [mc.RequestItem(1, 1, 0)]
    assert dl.on_event(1.8, item(0)) == [mc.AckDownload(1, 1, mc.MISSION_ACCEPTED)]
    assert dl.resends == 1


def test_strays_duplicates_and_other_peoples_replies_are_ignored():
    dl = MissionDownload(VEHICLE, OWN)
    dl.start(0.0)
    assert dl.on_event(0.1, count(5, target_component=190)) == []    # a GCS's download
    dl.on_event(0.1, count(2))
    dl.on_event(0.2, item(0))
    assert dl.on_event(0.3, item(0)) == []                  # duplicate: request 1 still pending
    assert dl.on_event(0.3, item(1)) == [mc.AckDownload(1, 1, mc.MISSION_ACCEPTED)]


def test_an_error_ack_from_the_autopilot_fails_the_download():
    dl = MissionDownload(VEHICLE, OWN)
    dl.start(0.0)
    dl.on_event(0.1, mc.MissionAck(*VEHICLE, mc.mavlink.MAV_MISSION_DENIED, 0, 1, OWN))
    assert dl.state == "failed" and "refused" in dl.failure


def test_the_plan_flies_waypoints_skips_home_and_names_the_rest():
    items = [item(0, frame=mc.FRAME_GLOBAL, x=-353632610, y=1491652300),  # home
             item(1, command=mc.mavlink.MAV_CMD_NAV_TAKEOFF),
             item(2, radius=3.0),
             item(3, frame=mc.FRAME_LOCAL_NED, x=400000, y=-50000),         # 40 m N, 5 m W
             item(4, command=mc.mavlink.MAV_CMD_DO_CHANGE_SPEED),
             item(5, x=0, y=0),
             item(6, frame=mc.mavlink.MAV_FRAME_BODY_FRD)]
    plan = build_plan(items, default_radius_m=2.0)
    assert [w.seq for w in plan.waypoints] == [2, 3]
    assert plan.waypoints[0].radius_m == 3.0 and plan.waypoints[0].lat_deg == -35.362
    assert (plan.waypoints[1].north_m, plan.waypoints[1].east_m, plan.waypoints[1].radius_m) \
        == (40.0, -5.0, 2.0)
    assert len(plan.skipped) == 4
    assert plan.skipped[0] == "1: NAV_TAKEOFF not flown"
    assert plan.skipped[1] == "4: DO_CHANGE_SPEED not flown"
    assert "0, 0" in plan.skipped[2] and plan.skipped[3] == "6: frame BODY_FRD not flown"
    assert all(len(f"companion: skip {s}") <= 50 for s in plan.skipped)    # one STATUSTEXT each
