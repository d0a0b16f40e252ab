"""The PX4 dialect (companion/onboard/autopilot_dialect.py) on synthetic streams: OFFBOARD as the
steering mode, the hold stream PX4's switch needs, who asks for OFFBOARD, Hold on a clean stop,
and the flight judged by the armed bit and the landed state, never by the mode alone."""
import dataclasses

import pytest

from companion.config.service import load_config
from companion.errors import ConfigError
from companion.mavlink import codec, px4_modes
from companion.mavlink.dialect import mavlink
from companion.mavlink.mission_codec import MissionItem
from companion.onboard.autopilot_dialect import OffboardEntry, OffboardParams, resolve
from companion.onboard.mission import build_plan
from companion.onboard.pipeline import Pipeline
from tests.service.test_pipeline import GOAL, Feed, setpoints

OFFBOARD, POSCTL, HOLD = px4_modes.OFFBOARD, px4_modes.POSCTL, px4_modes.AUTO_LOITER


def px4_config(offboard="operator", autopilot="auto"):
    base = load_config("config/companion.yaml")
    return dataclasses.replace(
        base, link=dataclasses.replace(base.link, autopilot=autopilot),
        px4=dataclasses.replace(base.px4, offboard=offboard),
        restart=dataclasses.replace(base.restart, look_around=False))


def px4_hb(armed=True, mode=POSCTL, autopilot=px4_modes.MAV_AUTOPILOT_PX4):
    return codec.Heartbeat(1, 1, 2, True, armed, mode, autopilot)


class Px4Feed(Feed):
    """Feed's vehicle with PX4's heartbeat (autopilot 12, PX4 custom modes)."""

    def __init__(self, pipeline, mode=POSCTL):
        super().__init__(pipeline)
        self.mode = mode

    def step(self, heartbeat=None, **kw):
        if heartbeat is None and (self.steps + 1) % 10 == 0:
            heartbeat = px4_hb(self.armed, self.mode)
        return super().step(heartbeat, **kw)

    def fly(self, steps, **kw):
        out = []
        for _ in range(steps):
            out += self.step(**kw)
        return out


def started(offboard="operator", mode=POSCTL):
    feed = Px4Feed(Pipeline(px4_config(offboard), GOAL, record_track=True), mode)
    feed.send(px4_hb(mode=mode))
    return feed


def mode_requests(outputs):
    return [o for o in outputs if isinstance(o, codec.ModeRequest)]


def test_custom_mode_main_and_sub_bytes():
    assert OFFBOARD == 6 << 16 == 393216
    assert px4_modes.main_mode(HOLD) == 4 and px4_modes.sub_mode(HOLD) == 3
    assert px4_modes.mode_name(HOLD) == "AUTO.LOITER"
    command = px4_modes.set_mode(1, 1, HOLD)
    assert (command.command, command.param1, command.param2, command.param3) == \
        (mavlink.MAV_CMD_DO_SET_MODE, 1.0, 4.0, 3.0)


def test_dialect_from_the_heartbeat_or_pinned():
    assert resolve("auto", 12, 4).name == "px4"
    assert resolve("auto", 3, 4).name == "ardupilot"
    assert resolve("px4", 3, 4).name == "px4"
    assert resolve("ardupilot", 12, 4).name == "ardupilot"
    # ArduPilot's GUIDED (4) is no OFFBOARD, and PX4's OFFBOARD number is not GUIDED
    assert not resolve("auto", 12, 4).steering(4)
    assert not resolve("auto", 3, 4).steering(OFFBOARD)


def test_bad_autopilot_setting_names_the_key(tmp_path):
    path = tmp_path / "c.yaml"
    shipped = open("config/companion.yaml").read()
    path.write_text(shipped.replace("autopilot: auto ", "autopilot: inav "))
    with pytest.raises(ConfigError, match="link.autopilot"):
        load_config(path)
    path.write_text(shipped.replace("offboard: operator ", "offboard: pilot "))
    with pytest.raises(ConfigError, match="px4.offboard"):
        load_config(path)


def test_operator_streams_holds_outside_offboard_and_never_asks_for_a_mode():
    feed = started("operator")
    out = feed.fly(60)
    holds = setpoints(out)
    assert holds and all(s.reason == "hold: offboard stream" for s in holds)
    assert all(s.vel_north_mps == s.vel_east_mps == s.vel_down_mps == 0.0 for s in holds)
    assert not mode_requests(out)
    assert feed.p.setpoints == 0              # none of them is a steering setpoint
    # the operator switches: the service steers
    feed.mode = OFFBOARD
    out = feed.fly(30)
    steering = [s for s in setpoints(out) if s.reason != "hold: offboard stream"]
    assert steering and steering[-1].vel_north_mps > 1.0
    assert not mode_requests(out)


def test_no_stream_on_the_ground_and_none_disarmed_in_offboard():
    feed = started("companion")
    feed.landed_state = codec.LANDED_STATE_ON_GROUND
    out = feed.fly(40)
    assert not setpoints(out) and not mode_requests(out)
    # after landing PX4 shows OFFBOARD again while disarmed: still nothing
    feed.armed, feed.mode = False, OFFBOARD
    feed.send(px4_hb(False, OFFBOARD))
    feed.landed_state = codec.LANDED_STATE_IN_AIR      # even a stale in-air word
    out = feed.fly(40)
    assert not setpoints(out) and not mode_requests(out)


def test_companion_asks_for_offboard_after_the_stream_then_retries_bounded():
    feed = started("companion")
    out, first = [], None
    for _ in range(200):
        step = feed.step()
        if first is None and mode_requests(step):
            first = feed.t_s
        out += step
    requests = mode_requests(out)
    assert all(r.custom_mode == OFFBOARD for r in requests)
    assert len(requests) == 5                 # px4.offboard_request_attempts
    stream_start = min(s.t_s for s in setpoints(out))
    assert first - stream_start >= 1.5 - 1e-9
    asked_at = [s.t_s for s in setpoints(out)]  # each request rides with a hold
    assert asked_at


def test_companion_engages_once_hands_to_hold_on_stop_and_never_fights_the_pilot():
    feed = started("companion")
    for _ in range(40):
        if mode_requests(feed.step()):
            break
    feed.mode = OFFBOARD                     # PX4 accepted
    feed.fly(20)
    assert feed.p.offboard.engaged_by_us
    stop = feed.p.stop_setpoint(feed.link_s)
    assert [r.custom_mode for r in mode_requests(stop)] == [HOLD]
    assert setpoints(stop)[0].reason == "stop"
    # another flight: the pilot leaves OFFBOARD for Position: never asked again this flight
    feed = started("companion")
    for _ in range(40):
        if mode_requests(feed.step()):
            break
    feed.mode = OFFBOARD
    feed.fly(20)
    feed.mode = POSCTL
    out = feed.fly(100)
    assert not mode_requests(out)
    assert not mode_requests(feed.p.stop_setpoint(feed.link_s))


def test_operator_stop_asks_no_mode():
    feed = started("operator", mode=OFFBOARD)
    feed.fly(30)
    stop = feed.p.stop_setpoint(feed.link_s)
    assert setpoints(stop) and not mode_requests(stop)


def test_offboard_entry_resets_at_disarm():
    entry = OffboardEntry(OffboardParams("companion", 1.5, 1.0, 2))
    assert not entry.step(0.0, True).request
    assert entry.step(1.6, True).request
    entry.on_mode(True)
    entry.on_mode(False)
    assert not entry.step(5.0, True).request          # left OFFBOARD: the pilot's
    entry.on_armed(False)
    assert not entry.step(6.0, True).request          # a new flight's stream starts
    assert entry.step(7.6, True).request


def test_px4_mission_item_0_is_a_waypoint():
    items = [MissionItem(1, 1, seq, mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
                         mavlink.MAV_CMD_NAV_WAYPOINT, (0.0, 0.0, 0.0, 0.0), 473977000 + seq,
                         85455000, 10.0, 0, 191, 0)
             for seq in range(3)]
    assert [w.seq for w in build_plan(items, 2.0).waypoints] == [1, 2]         # ArduPilot
    assert [w.seq for w in build_plan(items, 2.0, None).waypoints] == [0, 1, 2]


def test_streams_asked_of_px4_never_below_its_onboard_rates():
    assert px4_modes.stream_request(mavlink.MAVLINK_MSG_ID_ATTITUDE, 10.0) == \
        (mavlink.MAVLINK_MSG_ID_ATTITUDE, 100.0)
    assert px4_modes.stream_request(mavlink.MAVLINK_MSG_ID_EKF_STATUS_REPORT, 2.0) == \
        (mavlink.MAVLINK_MSG_ID_ESTIMATOR_STATUS, 2.0)
    assert px4_modes.stream_request(mavlink.MAVLINK_MSG_ID_GPS_RAW_INT, 2.0)[1] == 2.0


def test_estimator_status_flags_feed_position_trust():
    msg = mavlink.MAVLink_estimator_status_message(
        0, mavlink.ESTIMATOR_POS_HORIZ_ABS | mavlink.ESTIMATOR_VELOCITY_HORIZ, 0, 0, 0, 0, 0,
        0, 0, 0)
    msg.pack(mavlink.MAVLink(None, 1, 1))
    event = codec.decode(msg)
    assert isinstance(event, codec.EkfStatus) and event.horizontal_position_ok
