"""The autopilot's MAVLink behaviour without sockets: messages in, messages out, time passed in."""
import math

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from sitl_stub.autopilot import Autopilot
from sitl_stub.params import ParamTable
from sitl_stub.sim import Simulation
from sitl_stub.world import load_scenario

from .support import PAPER

SCENARIO = load_scenario(PAPER)
_ENC = mavlink.MAVLink(None, srcSystem=255, srcComponent=190)
_DEC = mavlink.MAVLink(None)


def wire(msg):
    """Pack and decode, so the message carries a real header like one from a socket."""
    return _DEC.decode(bytearray(msg.pack(_ENC)))


class Rig:
    def __init__(self, **params):
        self.sim = Simulation(SCENARIO, seed=1)
        self.ap = Autopilot(self.sim, ParamTable(**params))
        self.sent = []

    def send(self, msg):
        out = self.ap.handle(wire(msg), self.sim.t_s)
        self.sent += out
        return [m for _, m in out]

    def cmd(self, command, *p, target_system=1, target_component=1):
        p = list(p) + [0.0] * (7 - len(p))
        out = self.send(mavlink.MAVLink_command_long_message(target_system, target_component,
                                                             command, 0, *p))
        acks = [m for m in out if m.get_type() == "COMMAND_ACK"]
        return (acks[0].result if acks else None), out

    def target(self, mask=0x09C7, frame=1, x=0.0, y=0.0, vx=0.0, vy=0.0, yaw=0.0, yaw_rate=0.0,
               target_system=1):
        self.send(mavlink.MAVLink_set_position_target_local_ned_message(
            0, target_system, 1, frame, mask, x, y, 0.0, vx, vy, 0.0, 0.0, 0.0, 0.0, yaw, yaw_rate))

    def guided_armed(self):
        assert self.cmd(mavlink.MAV_CMD_DO_SET_MODE, 1, 4)[0] == mavlink.MAV_RESULT_ACCEPTED
        assert self.cmd(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1)[0] == mavlink.MAV_RESULT_ACCEPTED

    def airborne(self, alt_m=10.0):
        """GUIDED, armed, NAV_TAKEOFF and climbed: the docs' workflow."""
        self.guided_armed()
        assert self.cmd(mavlink.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, 0, 0, 0, alt_m)[0] == \
            mavlink.MAV_RESULT_ACCEPTED
        for _ in range(300):
            self.run(0.1)
            if self.ap.flight.takeoff.complete:
                return
        raise AssertionError("takeoff did not complete")

    def run(self, seconds):
        for _ in range(int(round(seconds / self.sim.dt_s))):
            self.sim.step(self.ap.demand(self.sim.t_s), self.ap.armed, self.ap.climb_limits())
            self.ap.after_step(self.sim.t_s)


def test_mode_and_arming_acks_and_heartbeat():
    rig = Rig()
    hb = rig.ap.periodic(0.0)[0][1]
    assert (hb.type, hb.autopilot, hb.custom_mode) == (2, 3, 0)
    assert hb.system_status == mavlink.MAV_STATE_STANDBY
    assert not hb.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED
    assert rig.cmd(mavlink.MAV_CMD_DO_SET_MODE, 1, 42)[0] == mavlink.MAV_RESULT_FAILED
    assert rig.cmd(mavlink.MAV_CMD_DO_SET_MODE, 0, 4)[0] == mavlink.MAV_RESULT_DENIED
    out = rig.send(mavlink.MAVLink_set_mode_message(1, 1, 4))
    assert out[0].command == mavlink.MAVLINK_MSG_ID_SET_MODE and out[0].result == 0
    assert out[0].target_system == 255 and out[0].target_component == 190
    assert rig.ap.mode == 4
    assert rig.cmd(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1)[0] == mavlink.MAV_RESULT_ACCEPTED
    hb = rig.ap.periodic(1.0)[0][1]
    assert hb.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED and hb.custom_mode == 4
    assert hb.system_status == mavlink.MAV_STATE_STANDBY    # armed but landed, as ArduCopter


def test_arming_refused_in_land_and_disarm_refused_in_flight():
    rig = Rig()
    rig.cmd(mavlink.MAV_CMD_DO_SET_MODE, 1, 9)
    assert rig.cmd(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1)[0] == mavlink.MAV_RESULT_FAILED
    rig.airborne()
    rig.target(vx=5.0)
    rig.run(2.0)
    assert rig.cmd(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 0)[0] == mavlink.MAV_RESULT_FAILED
    assert rig.ap.armed
    # LAND stops, descends (WPNAV_SPEED_DN above LAND_ALT_LOW, LAND_SPEED below), disarms landed
    assert rig.cmd(mavlink.MAV_CMD_NAV_LAND)[0] == mavlink.MAV_RESULT_ACCEPTED
    rig.run(2.0)
    assert rig.ap.flight.landed_state(True) == 4           # MAV_LANDED_STATE_LANDING
    assert -rig.sim.truth.vel_up_mps == pytest.approx(0.5, abs=0.01)
    rig.run(22.0)
    assert rig.sim.truth.up_m == 0.0 and rig.sim.truth.speed_mps == 0.0 and not rig.ap.armed


def test_targets_ignored_unless_guided_and_armed_and_for_us():
    rig = Rig()
    rig.cmd(mavlink.MAV_CMD_DO_SET_MODE, 1, 4)
    rig.target(vx=5.0)                      # disarmed: ignored
    assert rig.ap.target.kind == "hold"
    rig.cmd(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1)
    rig.target(vx=5.0, target_system=7)     # another vehicle's target: ignored
    assert rig.ap.target.kind == "hold"
    rig.target(vx=5.0)
    assert rig.ap.target.kind == "velocity"
    rig.cmd(mavlink.MAV_CMD_DO_SET_MODE, 1, 5)  # LOITER drops the target
    assert rig.ap.target is None
    rig.target(vx=5.0)
    assert rig.ap.target is None


def test_velocity_flight_and_guided_timeout_from_param():
    rig = Rig()
    rig.airborne()
    out = rig.send(mavlink.MAVLink_param_set_message(1, 1, b"GUID_TIMEOUT", 1.0, 9))
    assert out[0].param_id == "GUID_TIMEOUT" and out[0].param_value == 1.0
    rig.target(vx=5.0)
    rig.run(1.0)
    assert rig.sim.truth.speed_mps > 2.0
    rig.run(3.0)                            # 1 s timeout + 2 s to stop from <= 5 m/s
    assert rig.sim.truth.speed_mps == 0.0


@pytest.mark.parametrize("kwargs", [
    dict(vx=float("nan")),
    dict(vx=float("inf")),
    dict(vx=2000.0),
    dict(frame=mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, vx=5.0),
    dict(mask=0x0FFF),                       # everything ignored
    dict(mask=0x0E3F, vx=5.0),               # acceleration only
])
def test_invalid_target_stops_the_vehicle(kwargs):
    rig = Rig()
    rig.airborne()
    rig.target(vx=5.0)
    rig.run(3.0)
    assert rig.sim.truth.speed_mps == pytest.approx(5.0)
    rig.target(**kwargs)
    assert rig.ap.target.kind == "hold"
    rig.run(2.1)
    assert rig.sim.truth.speed_mps == 0.0
    assert rig.sim.truth.up_m == pytest.approx(10.0, abs=0.3)     # the hold keeps the altitude


def test_body_frame_velocity_is_rotated_by_heading():
    rig = Rig()
    rig.airborne()
    rig.target(vx=0.0, vy=5.0, mask=0x0DC7)  # east in LOCAL_NED, no yaw: it faces the velocity
    rig.run(2.5)
    rig.target(vx=0.0, vy=5.0, mask=0x0DC7)  # refreshed before GUID_TIMEOUT
    rig.run(2.5)
    assert rig.sim.truth.yaw_rad == pytest.approx(math.pi / 2, abs=0.02)
    rig.target(frame=mavlink.MAV_FRAME_BODY_OFFSET_NED, vx=0.0, vy=5.0)   # body right = south
    assert rig.ap.target.vel_north_mps == pytest.approx(-5.0, abs=0.1)
    assert rig.ap.target.vel_east_mps == pytest.approx(0.0, abs=0.1)


def test_position_target_flies_there_and_stops_and_ignores_timeout():
    rig = Rig()
    rig.airborne()
    rig.send(mavlink.MAVLink_set_position_target_local_ned_message(
        0, 1, 1, 1, 0x0FF8, 40.0, 10.0, -15.0, 0, 0, 0, 0, 0, 0, 0, 0))
    assert rig.ap.target.kind == "position"
    rig.run(20.0)
    odom = rig.sim.odometry
    assert math.hypot(odom.north_m - 40.0, odom.east_m - 10.0) < 0.5
    assert rig.sim.truth.speed_mps < 0.05
    assert rig.sim.truth.up_m == pytest.approx(15.0, abs=0.1)     # z = -15: 15 m up
    rig.target(frame=mavlink.MAV_FRAME_LOCAL_OFFSET_NED, mask=0x0FF8, x=-10.0, y=0.0)
    assert rig.ap.target.north_m == pytest.approx(odom.north_m - 10.0)


def test_params_list_read_set():
    rig = Rig()
    values = rig.send(mavlink.MAVLink_param_request_list_message(1, 1))
    n = len(values)
    assert n == len(rig.ap.params) and n > 10
    assert [v.param_index for v in values] == list(range(n))
    assert all(v.param_count == n for v in values)
    names = {v.param_id for v in values}
    assert {"SYSID_THISMAV", "GUID_TIMEOUT", "SR0_POSITION", "SR1_EXTRA1", "WPNAV_SPEED"} <= names
    (by_name,) = rig.send(mavlink.MAVLink_param_request_read_message(1, 1, b"GUID_TIMEOUT", -1))
    assert by_name.param_value == 3.0
    (by_index,) = rig.send(mavlink.MAVLink_param_request_read_message(1, 1, b"", by_name.param_index))
    assert by_index.param_id == "GUID_TIMEOUT"
    assert rig.send(mavlink.MAVLink_param_request_read_message(1, 1, b"NO_SUCH", -1)) == []
    assert rig.send(mavlink.MAVLink_param_set_message(1, 1, b"GUID_TIMEOUT", float("nan"), 9)) == []


def test_streams_default_set_interval_get_interval_and_request_data_stream():
    rig = Rig()
    due = rig.ap.scheduler.due(0.0)
    assert {0, 1, 2, 30, 32, 33, 164} <= set(due)
    res, out = rig.cmd(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, 32, 100000)
    assert res == mavlink.MAV_RESULT_ACCEPTED
    res, out = rig.cmd(mavlink.MAV_CMD_GET_MESSAGE_INTERVAL, 32)
    mi = [m for m in out if m.get_type() == "MESSAGE_INTERVAL"][0]
    assert (mi.message_id, mi.interval_us) == (32, 100000)
    rig.cmd(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, 30, -1)
    assert rig.ap.scheduler.interval_s(30) is None
    rig.cmd(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, 30, 0)          # back to the SR0_EXTRA1 rate
    assert rig.ap.scheduler.interval_s(30) == pytest.approx(0.25)
    rig.send(mavlink.MAVLink_request_data_stream_message(1, 1, 10, 10, 1))  # EXTRA1 at 10 Hz
    assert rig.ap.scheduler.interval_s(164) == pytest.approx(0.1)
    assert rig.ap.params.get("SR0_EXTRA1") == 10 and rig.ap.params.get("SR1_EXTRA1") == 10
    rig.send(mavlink.MAVLink_request_data_stream_message(1, 1, 0, 0, 0))    # ALL off
    assert all(rig.ap.scheduler.interval_s(i) is None for i in (1, 2, 30, 33, 164))
    assert rig.ap.scheduler.interval_s(32) is None   # a stream request resets its messages
    assert rig.cmd(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, 9999, 1000)[0] == mavlink.MAV_RESULT_FAILED


def test_streams_off_sends_only_heartbeat():
    rig = Rig(streams_off=True)
    assert rig.ap.scheduler.due(0.0) == [0]


def test_requests_and_refusals():
    rig = Rig()
    res, out = rig.cmd(mavlink.MAV_CMD_REQUEST_MESSAGE, mavlink.MAVLINK_MSG_ID_AUTOPILOT_VERSION)
    assert res == mavlink.MAV_RESULT_ACCEPTED and out[1].get_type() == "AUTOPILOT_VERSION"
    res, out = rig.cmd(mavlink.MAV_CMD_REQUEST_MESSAGE, mavlink.MAVLINK_MSG_ID_HOME_POSITION)
    assert res == mavlink.MAV_RESULT_ACCEPTED and out[1].get_type() == "HOME_POSITION"
    res, out = rig.cmd(mavlink.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES, 1)
    assert res == mavlink.MAV_RESULT_ACCEPTED and out[1].get_type() == "AUTOPILOT_VERSION"
    assert rig.cmd(mavlink.MAV_CMD_DO_MOTOR_TEST)[0] == mavlink.MAV_RESULT_UNSUPPORTED
    assert rig.cmd(mavlink.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, 0, 0, 0, 10)[0] == mavlink.MAV_RESULT_FAILED
    rig.guided_armed()
    assert rig.cmd(mavlink.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, 0, 0, 0, 10)[0] == mavlink.MAV_RESULT_ACCEPTED
    assert rig.cmd(mavlink.MAV_CMD_DO_SET_MODE, 1, 4, target_system=9)[0] is None
    (count,) = rig.send(mavlink.MAVLink_mission_request_list_message(1, 1, 0))
    assert count.get_type() == "MISSION_COUNT" and count.count == 1   # home only (item 0), as ArduCopter once home is set
    (nak,) = rig.send(mavlink.MAVLink_file_transfer_protocol_message(
        0, 1, 1, [0, 0, 0, 4] + [0] * 247))
    assert nak.payload[3] == 129 and nak.payload[5] == 4 and nak.payload[12] == 10
    assert rig.send(mavlink.MAVLink_param_ext_request_list_message(1, 1)) == []
    res, out = rig.cmd(mavlink.MAV_CMD_REQUEST_MESSAGE, 33, target_component=100)
    assert res == mavlink.MAV_RESULT_UNSUPPORTED and rig.sent[-1][0] == 100


def test_position_target_report_in_guided_only():
    rig = Rig()
    assert rig.ap._stream_message(85, 0.0, SCENARIO.world.origin) is None
    rig.guided_armed()
    rig.target(vx=3.0, vy=4.0)
    rep = rig.ap._stream_message(85, 0.0, SCENARIO.world.origin)
    assert (rep.type_mask, rep.vx, rep.vy) == (0x0FC7, 3.0, 4.0)
