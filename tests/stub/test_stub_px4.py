"""The stub's PX4 face (sitl_stub/px4.py), one rule a test: messages in, messages out, time passed in.

Each rule is PX4's (release 1.15; the module docstring cites the source files)."""
import math
import struct

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from sitl_stub import px4_tables as px4
from sitl_stub.px4 import LOCAL_Z_OFFSET_M, Px4Autopilot
from sitl_stub.px4_tables import Px4Params
from sitl_stub.sim import Simulation
from sitl_stub.world import load_scenario

from .support import PAPER
from .test_stub_autopilot import wire

SCENARIO = load_scenario(PAPER)
OK = mavlink.MAV_RESULT_ACCEPTED
LATER = mavlink.MAV_RESULT_TEMPORARILY_REJECTED
HOME_AMSL_M = SCENARIO.world.origin.alt_m
VELOCITY_YAW = 0x09C7


class Px4Rig:
    def __init__(self, arm_delay_s=5.0):
        self.sim = Simulation(SCENARIO, seed=1)
        self.ap = Px4Autopilot(self.sim, Px4Params(), arm_delay_s=arm_delay_s)

    def send(self, msg):
        return [m for _, m in self.ap.handle(wire(msg), self.sim.t_s)]

    def cmd(self, command, *p):
        p = list(p) + [0.0] * (7 - len(p))
        out = self.send(mavlink.MAVLink_command_long_message(1, 1, command, 0, *p))
        return [m for m in out if m.get_type() == "COMMAND_ACK"][0].result

    def set_mode(self, mode):
        return self.cmd(mavlink.MAV_CMD_DO_SET_MODE, 1, (mode >> 16) & 0xFF, (mode >> 24) & 0xFF)

    def setpoint(self, vx=0.0, frame=mavlink.MAV_FRAME_LOCAL_NED, mask=VELOCITY_YAW):
        self.send(mavlink.MAVLink_set_position_target_local_ned_message(
            0, 1, 1, frame, mask, 0, 0, 0, vx, 0, 0, 0, 0, 0, 0.0, 0))

    def run(self, seconds, stream_vx=None):
        for _ in range(int(round(seconds / self.sim.dt_s))):
            if stream_vx is not None:
                self.setpoint(stream_vx)
            self.sim.step(self.ap.demand(self.sim.t_s), self.ap.armed, self.ap.climb_limits())
            self.ap.after_step(self.sim.t_s)

    def heartbeat(self):
        return self.ap._stream_message(0, self.sim.t_s, SCENARIO.world.origin)

    def airborne(self, above_home_m=10.0):
        self.run(max(0.0, self.ap.arm_delay_s - self.sim.t_s) + 0.1)
        assert self.cmd(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1) == OK
        assert self.cmd(mavlink.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, math.nan, 0, 0,
                        HOME_AMSL_M + above_home_m) == OK
        for _ in range(400):
            self.run(0.1)
            if self.ap.mode == px4.HOLD:
                return
        raise AssertionError("takeoff did not end in Hold")


def test_heartbeat_is_px4s_with_main_and_sub_mode_bytes():
    rig = Px4Rig()
    hb = rig.heartbeat()
    assert hb.autopilot == mavlink.MAV_AUTOPILOT_PX4 == 12
    assert hb.custom_mode == 3 << 16                          # POSCTL at boot
    assert rig.set_mode(px4.HOLD) == OK
    hb = rig.heartbeat()
    assert (hb.custom_mode >> 16) & 0xFF == 4 and hb.custom_mode >> 24 == 3   # AUTO.LOITER


def test_arming_refused_until_the_preflight_checks_pass():
    rig = Px4Rig(arm_delay_s=5.0)
    assert rig.cmd(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1) == LATER
    rig.run(4.0)
    assert rig.cmd(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1) == LATER
    rig.run(1.1)
    assert rig.cmd(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1) == OK and rig.ap.armed


def test_armed_without_takeoff_disarms_after_com_disarm_prflt():
    rig = Px4Rig(arm_delay_s=0.0)
    assert rig.cmd(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1) == OK
    rig.run(9.5)
    assert rig.ap.armed
    rig.run(1.0)
    assert not rig.ap.armed


def test_takeoff_altitude_is_amsl_then_hold():
    rig = Px4Rig()
    rig.airborne(above_home_m=10.0)
    assert rig.sim.truth.up_m == pytest.approx(10.0, abs=0.3)
    hb = rig.heartbeat()
    assert hb.custom_mode == px4.HOLD and hb.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED
    rig.run(5.0)
    assert rig.sim.truth.up_m == pytest.approx(10.0, abs=0.3)      # Hold holds


def test_takeoff_below_home_refused_and_nan_is_mis_takeoff_alt():
    rig = Px4Rig(arm_delay_s=0.0)
    rig.cmd(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1)
    # a relative altitude (10) read as AMSL is far below home: refused
    assert rig.cmd(mavlink.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, 0, 0, 0, 10.0) == mavlink.MAV_RESULT_FAILED
    assert rig.cmd(mavlink.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, 0, 0, 0, math.nan) == OK
    rig.run(15.0)
    assert rig.sim.truth.up_m == pytest.approx(2.5, abs=0.3)         # MIS_TAKEOFF_ALT


def test_offboard_refused_without_a_second_of_setpoints():
    rig = Px4Rig()
    rig.airborne()
    assert rig.set_mode(px4.OFFBOARD) == LATER                   # no signal at all
    rig.run(0.5, stream_vx=0.0)
    assert rig.set_mode(px4.OFFBOARD) == LATER                   # 0.5 s of it
    rig.run(0.6, stream_vx=0.0)
    assert rig.set_mode(px4.OFFBOARD) == OK                      # > 1 s
    assert rig.heartbeat().custom_mode == px4.OFFBOARD


def test_setpoints_outside_offboard_are_only_the_signal():
    rig = Px4Rig()
    rig.airborne()
    start = rig.sim.truth.north_m
    rig.run(3.0, stream_vx=5.0)                                  # in Hold: not flown
    assert rig.sim.truth.north_m == pytest.approx(start, abs=0.2)
    assert rig.set_mode(px4.OFFBOARD) == OK
    rig.run(3.0, stream_vx=5.0)
    assert rig.sim.truth.north_m - start > 5.0


def test_only_local_ned_and_body_ned_frames_count():
    rig = Px4Rig()
    rig.airborne()
    for _ in range(20):
        rig.setpoint(frame=mavlink.MAV_FRAME_LOCAL_OFFSET_NED)
        rig.run(0.1)
    assert rig.set_mode(px4.OFFBOARD) == LATER
    for _ in range(20):
        rig.setpoint(frame=mavlink.MAV_FRAME_BODY_NED)
        rig.run(0.1)
    assert rig.set_mode(px4.OFFBOARD) == OK


@pytest.mark.parametrize("action, fallback", [(5, px4.HOLD), (4, px4.LAND), (0, px4.RTL)])
def test_offboard_loss_after_com_of_loss_t_flies_com_obl_rc_act(action, fallback):
    rig = Px4Rig()
    rig.ap.params.set("COM_OBL_RC_ACT", float(action))
    rig.airborne()
    rig.run(1.2, stream_vx=2.0)
    assert rig.set_mode(px4.OFFBOARD) == OK
    rig.run(2.0, stream_vx=2.0)
    rig.run(0.9)                                                 # within COM_OF_LOSS_T (1 s)
    assert rig.heartbeat().custom_mode == px4.OFFBOARD
    rig.run(0.3)
    assert rig.heartbeat().custom_mode == fallback
    assert rig.ap.mode == px4.OFFBOARD                           # still the user's mode


def test_offboard_comes_back_with_the_signal():
    rig = Px4Rig()
    rig.ap.params.set("COM_OBL_RC_ACT", 5.0)
    rig.airborne()
    rig.run(1.2, stream_vx=0.0)
    rig.set_mode(px4.OFFBOARD)
    rig.run(3.0)                                                 # the companion died: Hold
    assert rig.heartbeat().custom_mode == px4.HOLD
    up = rig.sim.truth.up_m
    rig.run(3.0)
    assert rig.sim.truth.up_m == pytest.approx(up, abs=0.2) and rig.sim.truth.speed_mps < 0.1
    rig.run(0.5, stream_vx=3.0)                                  # a restarted companion streams
    assert rig.heartbeat().custom_mode == px4.OFFBOARD
    start = rig.sim.truth.north_m
    rig.run(2.0, stream_vx=3.0)
    assert rig.sim.truth.north_m - start > 2.0


def test_land_then_disarmed_the_heartbeat_shows_the_users_mode():
    rig = Px4Rig()
    rig.ap.params.set("COM_OBL_RC_ACT", 4.0)                     # Land on offboard loss
    rig.airborne()
    rig.run(1.2, stream_vx=0.0)
    rig.set_mode(px4.OFFBOARD)
    rig.run(1.5)
    assert rig.heartbeat().custom_mode == px4.LAND
    assert rig.ap._stream_message(245, rig.sim.t_s, None).landed_state == \
        mavlink.MAV_LANDED_STATE_LANDING
    rig.run(25.0)
    hb = rig.heartbeat()
    assert not rig.ap.armed and rig.sim.truth.up_m == 0.0
    assert hb.custom_mode == px4.OFFBOARD                        # OFFBOARD again, disarmed
    assert not hb.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED


def test_nav_land_descends_at_mpc_land_speed_and_disarms():
    rig = Px4Rig()
    rig.airborne()
    assert rig.cmd(mavlink.MAV_CMD_NAV_LAND) == OK
    rig.run(3.0)
    assert -rig.sim.truth.vel_up_mps == pytest.approx(0.7, abs=0.01)
    rig.run(20.0)
    assert not rig.ap.armed and rig.heartbeat().custom_mode == px4.LAND


def test_default_streams_are_px4s_onboard_ones():
    rig = Px4Rig()
    due = rig.ap.streams.shared.due(0.0)
    assert px4.MSG_ESTIMATOR_STATUS in due and 193 not in due        # no EKF_STATUS_REPORT
    assert {30, 32, 33, 245, 24} <= set(due)
    assert rig.ap.streams.shared.interval_s(32) == pytest.approx(1 / 30)
    assert rig.ap.streams.shared.interval_s(30) == pytest.approx(1 / 100)
    status = rig.ap._stream_message(px4.MSG_ESTIMATOR_STATUS, 1.0, SCENARIO.world.origin)
    assert bool(status.flags & mavlink.ESTIMATOR_POS_HORIZ_ABS) == SCENARIO.noise.has_gps
    assert status.flags & mavlink.ESTIMATOR_VELOCITY_HORIZ
    lpn = rig.ap._stream_message(32, 1.0, SCENARIO.world.origin)
    assert lpn.z == pytest.approx(LOCAL_Z_OFFSET_M, abs=0.01)       # origin above the ground


def test_parameters_are_served_bytewise():
    rig = Px4Rig()
    out = rig.send(mavlink.MAVLink_param_request_read_message(1, 1, b"COM_OBL_RC_ACT", -1))
    assert out[0].param_type == mavlink.MAV_PARAM_TYPE_INT32
    assert struct.unpack("<i", struct.pack("<f", out[0].param_value))[0] == 0
    five = struct.unpack("<f", struct.pack("<i", 5))[0]
    out = rig.send(mavlink.MAVLink_param_set_message(1, 1, b"COM_OBL_RC_ACT", five,
                                                     mavlink.MAV_PARAM_TYPE_INT32))
    assert rig.ap.params.get("COM_OBL_RC_ACT") == 5.0
    out = rig.send(mavlink.MAVLink_param_request_read_message(1, 1, b"COM_OF_LOSS_T", -1))
    assert out[0].param_value == pytest.approx(1.0)


def test_mission_item_0_is_a_mission_item():
    rig = Px4Rig()
    store = rig.ap.mission
    out = rig.send(mavlink.MAVLink_mission_count_message(1, 1, 2, 0))
    assert out[0].get_type() == "MISSION_REQUEST_INT" and out[0].seq == 0
    for seq in range(2):
        out = rig.send(mavlink.MAVLink_mission_item_int_message(
            1, 1, seq, mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, mavlink.MAV_CMD_NAV_WAYPOINT,
            0, 1, 0, 0, 0, 0, -353632610 + seq * 1000, 1491652300, 10.0, 0))
    assert out[0].get_type() == "MISSION_ACK" and out[0].type == 0
    assert store.count == 2 and store.mission_current().total == 2
    out = rig.send(mavlink.MAVLink_mission_request_list_message(1, 1, 0))
    assert out[0].count == 2
    out = rig.send(mavlink.MAVLink_mission_request_int_message(1, 1, 0, 0))
    assert out[0].x == -353632610
