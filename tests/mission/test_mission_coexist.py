"""Issue 32 (and 31's open ends): the mission download coexists with a ground station's transfers
(never during another's transfer, backed off on refusal, re-read when the vehicle accepts an
upload, even of the same length without mission_id), and NAV_WAYPOINT hold times are waited out."""
from __future__ import annotations

from companion.mavlink import codec
from companion.mavlink import mission_codec as mc
from companion.onboard.mission import build_plan
from companion.onboard.mission_follow import MissionFollower
from companion.onboard.mission_traffic import DOWNLOAD_QUIET_S, UPLOAD_TIMEOUT_S, TransferWatch
from tests.mission.test_mission_follow import HOME, VEHICLE, download, notices, wp

GCS = (255, 230)


def request_to(peer, seq=0):
    return mc.MissionRequestSeen(*VEHICLE, seq, 0, *peer)


def ack_to(peer, result=mc.MISSION_ACCEPTED, mission_type=0):
    return mc.MissionAck(*VEHICLE, result, mission_type, *peer)


def requests(out):
    return [o for o in out if isinstance(o, (mc.RequestList, mc.RequestItem))]


def test_the_watch_sees_an_upload_until_its_ack_or_the_vehicles_timeout():
    watch = TransferWatch(191)
    assert watch.busy(0.0) is None
    assert watch.on_event(0.0, request_to(GCS)) is None
    assert watch.busy(0.5).kind == "upload" and watch.busy(0.5).peer == GCS
    assert watch.on_event(1.0, ack_to(GCS)) == "uploaded"
    assert watch.busy(1.0) is None and watch.uploads_seen == 1
    watch.on_event(2.0, request_to(GCS))                    # an upload that is abandoned
    assert watch.busy(2.0 + UPLOAD_TIMEOUT_S - 0.1) is not None
    assert watch.busy(2.0 + UPLOAD_TIMEOUT_S + 0.1) is None


def test_the_watch_ignores_our_own_traffic_fences_and_refusals_and_times_downloads():
    watch = TransferWatch(191)
    assert watch.on_event(0.0, ack_to((1, 191))) is None            # ours
    assert watch.on_event(0.0, ack_to(GCS, mission_type=1)) is None  # a fence upload
    assert watch.on_event(0.0, ack_to(GCS, mc.MISSION_OPERATION_CANCELLED)) is None
    watch.on_event(1.0, mc.MissionCount(*VEHICLE, 4, 0, *GCS))     # the GCS lists the mission
    assert watch.busy(1.0 + DOWNLOAD_QUIET_S - 0.1).kind == "download"
    assert watch.busy(1.0 + DOWNLOAD_QUIET_S + 0.1) is None
    assert watch.uploads_seen == 0


def test_no_download_starts_while_a_ground_station_uploads_then_it_reads_the_new_mission():
    f = MissionFollower(191, 2.0)
    f.vehicle = VEHICLE
    f.on_event(0.0, request_to(GCS))                        # MAVProxy's wp load under way
    assert requests(f._start(0.1, "vehicle found")) == []
    assert requests(f.tick(0.5)) == []                      # still waiting, nothing sent
    assert f.deferred == 1
    out = f.on_event(0.8, ack_to(GCS))                      # the vehicle accepted it
    assert "companion: mission uploaded, re-reading" in notices(out)
    assert requests(out) == [mc.RequestList(*VEHICLE)]


def test_our_download_is_dropped_when_an_upload_starts_and_begun_again_after_it():
    f = MissionFollower(191, 2.0)
    assert requests(f.on_vehicle(0.0, VEHICLE)) == [mc.RequestList(*VEHICLE)]
    f.on_event(0.1, request_to(GCS))                        # the GCS's upload overtakes ours
    assert f.download is None
    f.on_event(0.2, ack_to((1, 191), 14))                   # DENIED to us: no longer ours
    assert requests(f.tick(0.3)) == []
    out = f.on_event(1.0, ack_to(GCS))
    assert requests(out) == [mc.RequestList(*VEHICLE)]
    assert not any("failed" in t for t in notices(out))


def test_a_refused_download_backs_off_and_says_so_once():
    f = MissionFollower(191, 2.0)
    f.on_vehicle(0.0, VEHICLE)
    sent, said, t = [0.0], [], 0.0
    for _ in range(5):                                       # DENIED each time: an upload
        said += notices(f.on_event(t, ack_to((1, 191), 14)))   # we cannot hear (own link)
        while True:
            t = round(t + 0.1, 3)
            if requests(f.tick(t)):
                sent.append(t)
                break
    gaps = [round(b - a, 1) for a, b in zip(sent, sent[1:])]
    assert gaps == [1.0, 2.0, 4.0, 8.0, 8.0]
    assert sum("mission download failed" in s for s in said) == 1


def test_a_re_upload_of_the_same_length_without_mission_id_is_read_again():
    f = MissionFollower(191, 2.0)
    download(f, [HOME, wp(1, mc.FRAME_LOCAL_NED, 300000, 0)])
    f.on_event(1.0, mc.MissionCurrent(*VEHICLE, 0, 1, 0))
    f.on_event(2.0, request_to(GCS))
    f.on_event(2.1, request_to(GCS, 1))
    assert f.on_event(2.5, mc.MissionCurrent(*VEHICLE, 0, 1, 0)) == []   # same total, id 0
    out = f.on_event(2.6, ack_to(GCS))
    assert requests(out) == [mc.RequestList(*VEHICLE)]
    f.on_event(2.7, mc.MissionCount(*VEHICLE, 2, 0, 1, 191))
    f.on_event(2.8, HOME)
    f.on_event(2.9, wp(1, mc.FRAME_LOCAL_NED, 0, 300000))
    assert f.goal() == (0.0, 30.0, 2.0) and f.downloads == 2


def test_the_recheck_reads_the_mission_again_on_a_link_that_hears_nothing():
    f = MissionFollower(191, 2.0, recheck_s=10.0)
    download(f, [HOME, wp(1, mc.FRAME_LOCAL_NED, 300000, 0)])
    assert requests(f.tick(9.9)) == []
    assert requests(f.tick(10.0)) == [mc.RequestList(*VEHICLE)]
    assert requests(MissionFollower(191, 2.0).tick(100.0)) == []      # off by default


def hold_wp(seq, north_dm, hold_s):
    return mc.MissionItem(*VEHICLE, seq, mc.FRAME_LOCAL_NED, mc.CMD_NAV_WAYPOINT,
                          (hold_s, 0.0, 0.0, 0.0), north_dm, 0, 10.0, 0, 1, 191)


def test_a_waypoints_hold_time_is_waited_out_on_vehicle_time_before_the_next():
    f = MissionFollower(191, 2.0)
    download(f, [HOME, hold_wp(1, 300000, 5.0), hold_wp(2, 600000, 0.0)])
    assert f.plan.waypoints[0].hold_s == 5.0
    assert notices(f.on_arrived(10.0)) == ["companion: waypoint 1, hold 5 s"]
    assert f.on_arrived(14.9) == [] and f.goal()[:2] == (30.0, 0.0)      # still holding there
    assert notices(f.on_arrived(15.0)) == ["companion: waypoint 1 reached"]
    assert f.goal()[:2] == (60.0, 0.0)
    assert "companion: waypoint 2 reached" in notices(f.on_arrived(15.1))  # no hold: at once


def test_a_bad_hold_time_is_named_and_not_flown():
    plan = build_plan([HOME, hold_wp(1, 300000, -3.0), hold_wp(2, 300000, float("nan"))], 2.0)
    assert [w.hold_s for w in plan.waypoints] == [0.0, 0.0]
    assert len(plan.skipped) == 2 and "hold" in plan.skipped[0]


def test_the_codec_decodes_the_vehicles_requests_to_an_uploader():
    msg = mc.mavlink.MAVLink_mission_request_message(255, 230, 3, 0)
    msg._header = type("H", (), {"srcSystem": 1, "srcComponent": 1})()
    event = codec.decode(msg)
    assert isinstance(event, mc.MissionRequestSeen)
    assert (event.target_system, event.target_component, event.seq) == (255, 230, 3)


def test_a_mission_current_change_during_a_download_is_checked_when_it_is_done():
    f = MissionFollower(191, 2.0)
    f.on_vehicle(0.0, VEHICLE)
    f.on_event(0.1, mc.MissionCurrent(*VEHICLE, 0, 0, 0))
    f.on_event(0.2, mc.MissionCount(*VEHICLE, 2, 0, 1, 191))
    assert f.on_event(0.3, mc.MissionCurrent(*VEHICLE, 0, 1, 0)) == []     # not begun again
    f.on_event(0.4, HOME)
    out = f.on_event(0.5, wp(1, mc.FRAME_LOCAL_NED, 300000, 0))
    assert requests(out) == [] and f.downloads == 1                         # 1 item = total 1
    f.on_event(0.6, mc.MissionCurrent(*VEHICLE, 0, 2, 0))                   # changed again
    assert f.download is not None and f.download.active


def test_a_download_shorter_than_the_vehicles_total_is_read_again():
    f = MissionFollower(191, 2.0)
    f.on_vehicle(0.0, VEHICLE)
    f.on_event(0.1, mc.MissionCount(*VEHICLE, 1, 0, 1, 191))
    f.on_event(0.15, mc.MissionCurrent(*VEHICLE, 0, 3, 0))                  # first: recorded
    out = f.on_event(0.2, HOME)
    assert requests(out) == [mc.RequestList(*VEHICLE)]                      # 0 read, 3 there
