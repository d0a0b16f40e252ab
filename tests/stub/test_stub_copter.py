"""ArduCopter 4.6 behaviours the stub learned, each pinned next to its source (sitl_stub/flight.py,
vehicle.py, telemetry.py name the ArduPilot functions). No sockets: messages in, messages out."""
import math

import numpy as np
import pytest
import yaml
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from sitl_stub import streams
from sitl_stub.autopilot import Autopilot
from sitl_stub.params import ParamTable
from sitl_stub.sim import PositionError, Simulation, YawBias
from sitl_stub.world import parse_scenario

from .support import PAPER
from .test_stub_autopilot import Rig

ON_GROUND, IN_AIR, TAKEOFF, LANDING = 1, 2, 3, 4
TAKEOFF_CMD = mavlink.MAV_CMD_NAV_TAKEOFF


def landed_state(rig):
    return rig.ap._stream_message(streams.MSG_EXTENDED_SYS_STATE, rig.sim.t_s,
                                  rig.sim.scenario.world.origin).landed_state


def gps_rig(seed=4, **noise):
    data = yaml.safe_load(PAPER.read_text())
    data["noise"].update(noise)
    rig = Rig()
    rig.sim = Simulation(parse_scenario(data, "gps.yaml"), seed=seed)
    rig.ap = Autopilot(rig.sim, ParamTable())
    return rig


def test_nav_takeoff_in_guided_climbs_to_the_target_at_wpnav_speed_up():
    rig = Rig()
    rig.guided_armed()
    assert landed_state(rig) == ON_GROUND
    ext = rig.ap._stream_message(streams.MSG_EXTENDED_SYS_STATE, 0.0, rig.sim.scenario.world.origin)
    assert ext.vtol_state == mavlink.MAV_VTOL_STATE_MC          # as the 4.6 binary sends it
    assert rig.cmd(TAKEOFF_CMD, 0, 0, 0, 0, 0, 0, 10.0)[0] == mavlink.MAV_RESULT_ACCEPTED
    rig.run(2.0)                                                 # spooling up (the binary: 2.8 s)
    assert landed_state(rig) == ON_GROUND and rig.sim.truth.up_m == 0.0
    rig.run(1.0)
    assert landed_state(rig) == TAKEOFF
    rig.run(3.0)
    assert rig.sim.truth.vel_up_mps == pytest.approx(2.5)       # WPNAV_SPEED_UP 250 cm/s
    assert rig.sim.truth.speed_mps == 0.0                        # straight up
    for _ in range(100):
        rig.run(0.1)
        if landed_state(rig) == IN_AIR:
            break
    assert landed_state(rig) == IN_AIR and rig.sim.truth.up_m == pytest.approx(10.0, abs=0.15)
    rig.run(10.0)                                                # holds the altitude, armed
    assert rig.ap.armed and rig.sim.truth.up_m == pytest.approx(10.0, abs=0.3)
    # GLOBAL_POSITION_INT relative_alt and LOCAL_POSITION_NED z say so
    origin = rig.sim.scenario.world.origin
    gpi = rig.ap._stream_message(streams.MSG_GLOBAL_POSITION_INT, rig.sim.t_s, origin)
    lpn = rig.ap._stream_message(streams.MSG_LOCAL_POSITION_NED, rig.sim.t_s, origin)
    assert gpi.relative_alt == pytest.approx(10000, abs=300) and lpn.z == pytest.approx(-10, abs=0.3)
    assert rig.ap.periodic(rig.sim.t_s + 1.0)[0][1].system_status == mavlink.MAV_STATE_ACTIVE


def test_takeoff_refused_when_disarmed_in_stabilize_flying_or_downwards():
    rig = Rig()
    rig.cmd(mavlink.MAV_CMD_DO_SET_MODE, 1, 4)
    assert rig.cmd(TAKEOFF_CMD, 0, 0, 0, 0, 0, 0, 10.0)[0] == mavlink.MAV_RESULT_FAILED  # disarmed
    rig.cmd(mavlink.MAV_CMD_DO_SET_MODE, 1, 0)
    rig.cmd(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1)
    assert rig.cmd(TAKEOFF_CMD, 0, 0, 0, 0, 0, 0, 10.0)[0] == mavlink.MAV_RESULT_FAILED  # STABILIZE
    rig.cmd(mavlink.MAV_CMD_DO_SET_MODE, 1, 4)
    assert rig.cmd(TAKEOFF_CMD, 0, 0, 0, 0, 0, 0, -1.0)[0] == mavlink.MAV_RESULT_FAILED  # downwards
    assert rig.cmd(TAKEOFF_CMD, 0, 0, 0, 0, 0, 0, 5.0)[0] == mavlink.MAV_RESULT_ACCEPTED
    rig.run(5.0)
    assert rig.cmd(TAKEOFF_CMD, 0, 0, 0, 0, 0, 0, 20.0)[0] == mavlink.MAV_RESULT_FAILED  # flying


def test_velocity_setpoint_while_landed_idles_the_motors_and_disarms_after_disarm_delay():
    """ArduCopter's answer to the companion that commanded before the takeoff (issue 13)."""
    rig = Rig()
    rig.guided_armed()
    assert rig.cmd(TAKEOFF_CMD, 0, 0, 0, 0, 0, 0, 10.0)[0] == mavlink.MAV_RESULT_ACCEPTED
    rig.target(vx=5.0)                      # replaces the takeoff at once: still on the ground
    for _ in range(95):
        rig.run(0.1)
        rig.target(vx=5.0)                  # kept coming
        assert rig.sim.truth.up_m == 0.0 and rig.sim.truth.speed_mps == 0.0
        assert landed_state(rig) == ON_GROUND
    assert rig.ap.armed
    rig.run(0.6)                            # DISARM_DELAY 10 s after the motors went idle
    assert not rig.ap.armed


def test_armed_on_the_ground_without_takeoff_disarms_after_disarm_delay_unless_zero():
    rig = Rig()
    rig.guided_armed()
    rig.run(9.9)
    assert rig.ap.armed
    rig.run(0.2)
    assert not rig.ap.armed
    rig = Rig()
    rig.send(mavlink.MAVLink_param_set_message(1, 1, b"DISARM_DELAY", 0.0, 2))
    rig.guided_armed()
    rig.run(30.0)
    assert rig.ap.armed


def test_velocity_with_yaw_crabs_and_turns_at_its_own_rate():
    rig = Rig()
    rig.airborne()
    for _ in range(40):                     # east at 5 m/s, nose kept north
        rig.target(vx=0.0, vy=5.0, yaw=0.0)
        rig.run(0.1)
    t = rig.sim.truth
    assert t.vel_east_mps == pytest.approx(5.0, abs=0.01) and abs(t.vel_north_mps) < 0.01
    assert t.yaw_rad == pytest.approx(0.0, abs=0.01)     # steered by the gyro's (drifting) yaw
    rig.target(vx=0.0, vy=5.0, yaw=math.pi / 2)
    rig.run(1.0)                            # 30 deg/s (the scenario's turn rate)
    assert rig.sim.truth.yaw_rad == pytest.approx(math.radians(30.0), abs=0.01)
    assert rig.sim.truth.vel_east_mps == pytest.approx(5.0, abs=0.01)   # course unchanged


def test_vz_is_a_climb_rate_and_zero_holds_the_altitude():
    rig = Rig()
    rig.airborne()

    def fly(vz, seconds):
        for _ in range(int(seconds * 10)):
            rig.send(mavlink.MAVLink_set_position_target_local_ned_message(
                0, 1, 1, 1, 0x09C7, 0, 0, 0, 3.0, 0.0, vz, 0, 0, 0, 0.0, 0))
            rig.run(0.1)

    fly(0.0, 5.0)
    assert rig.sim.truth.up_m == pytest.approx(10.0, abs=0.3)
    fly(-5.0, 4.0)                          # climb request above WPNAV_SPEED_UP: 2.5 m/s
    assert rig.sim.truth.vel_up_mps == pytest.approx(2.5)
    fly(5.0, 4.0)                           # descent request above WPNAV_SPEED_DN: 1.5 m/s
    assert rig.sim.truth.vel_up_mps == pytest.approx(-1.5)
    up = rig.sim.truth.up_m
    fly(0.0, 3.0)
    assert rig.sim.truth.up_m == pytest.approx(up - 0.75, abs=0.5)      # stops within ~1.5 s


def test_land_mode_descends_lands_and_disarms():
    rig = Rig()
    rig.airborne(15.0)
    assert rig.cmd(mavlink.MAV_CMD_DO_SET_MODE, 1, 9)[0] == mavlink.MAV_RESULT_ACCEPTED
    rig.run(3.0)
    assert landed_state(rig) == LANDING
    assert rig.sim.truth.vel_up_mps == pytest.approx(-1.5)      # above LAND_ALT_LOW: WPNAV_SPEED_DN
    states = []
    for _ in range(400):
        rig.run(0.1)
        states.append((landed_state(rig), rig.ap.armed))
        if not rig.ap.armed:
            break
    assert not rig.ap.armed and rig.sim.truth.up_m == 0.0
    assert (ON_GROUND, False) == states[-1] and (LANDING, True) in states


def test_takeoff_in_loiter_then_guided_holds_the_altitude():
    rig = Rig()
    rig.cmd(mavlink.MAV_CMD_DO_SET_MODE, 1, 5)
    rig.cmd(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1)
    assert rig.cmd(TAKEOFF_CMD, 0, 0, 0, 0, 0, 0, 8.0)[0] == mavlink.MAV_RESULT_ACCEPTED
    rig.run(12.0)
    assert rig.sim.truth.up_m == pytest.approx(8.0, abs=0.3) and landed_state(rig) == IN_AIR
    rig.cmd(mavlink.MAV_CMD_DO_SET_MODE, 1, 4)
    rig.run(12.0)                           # GUIDED's hold: no disarm, no sink
    assert rig.ap.armed and rig.sim.truth.up_m == pytest.approx(8.0, abs=0.3)


def test_sys_status_bits_as_arducopter_sets_them():
    rig = gps_rig(position_sigma_m=0.5)
    origin = rig.sim.scenario.world.origin
    st = rig.ap._stream_message(streams.MSG_SYS_STATUS, 0.0, origin)
    fence = mavlink.MAV_SYS_STATUS_GEOFENCE
    assert not st.onboard_control_sensors_enabled & fence      # a fence, not enabled ...
    assert st.onboard_control_sensors_health & fence            # ... and no breach
    for bit in (mavlink.MAV_SYS_STATUS_PREARM_CHECK, mavlink.MAV_SYS_STATUS_SENSOR_GPS,
                mavlink.MAV_SYS_STATUS_AHRS, mavlink.MAV_SYS_STATUS_SENSOR_3D_GYRO,
                mavlink.MAV_SYS_STATUS_SENSOR_BATTERY):
        assert st.onboard_control_sensors_present & bit
        assert st.onboard_control_sensors_enabled & bit
        assert st.onboard_control_sensors_health & bit
    xy = mavlink.MAV_SYS_STATUS_SENSOR_XY_POSITION_CONTROL
    assert st.onboard_control_sensors_present & xy and not st.onboard_control_sensors_enabled & xy
    rig.airborne()
    st = rig.ap._stream_message(streams.MSG_SYS_STATUS, rig.sim.t_s, origin)
    assert st.onboard_control_sensors_enabled & xy and st.onboard_control_sensors_health & xy
    assert st.voltage_battery < 12600 and 0 < st.battery_remaining <= 100
    bat = rig.ap._stream_message(streams.MSG_BATTERY_STATUS, rig.sim.t_s, origin)
    assert bat.current_battery == 2800 and bat.current_consumed > 0


def test_gps_raw_int_and_ekf_status_with_and_without_gps():
    origin = Rig().sim.scenario.world.origin
    denied = Rig()
    gps = denied.ap._stream_message(streams.MSG_GPS_RAW_INT, 0.0, origin)
    ekf = denied.ap._stream_message(streams.MSG_EKF_STATUS_REPORT, 0.0, origin)
    assert gps.fix_type == mavlink.GPS_FIX_TYPE_NO_GPS
    assert ekf.flags & mavlink.EKF_POS_HORIZ_REL and not ekf.flags & mavlink.EKF_POS_HORIZ_ABS
    rig = gps_rig(position_sigma_m=0.6, position_bias_sigma_m=0.8)
    gps = rig.ap._stream_message(streams.MSG_GPS_RAW_INT, 0.0, origin)
    ekf = rig.ap._stream_message(streams.MSG_EKF_STATUS_REPORT, 0.0, origin)
    assert gps.fix_type == mavlink.GPS_FIX_TYPE_3D_FIX and gps.eph == 100 and gps.h_acc == 1000
    healthy = (mavlink.EKF_ATTITUDE | mavlink.EKF_VELOCITY_HORIZ | mavlink.EKF_POS_HORIZ_ABS
               | mavlink.EKF_PRED_POS_HORIZ_ABS)
    assert ekf.flags & healthy == healthy
    assert not ekf.flags & (mavlink.EKF_CONST_POS_MODE | mavlink.EKF_UNINITIALIZED
                            | mavlink.EKF_GPS_GLITCHING)


def test_position_is_gps_like_white_noise_plus_slow_bias():
    rig = gps_rig(position_sigma_m=0.5, position_bias_sigma_m=1.0, position_bias_tau_s=100.0)
    rig.airborne()
    errors = []
    for _ in range(3000):                   # 300 s of hover at 10 Hz
        rig.run(0.1)
        n, e = rig.sim.reported_position_ne_m()
        errors.append((n - rig.sim.truth.north_m, e - rig.sim.truth.east_m))
    err = np.array(errors)
    white = np.diff(err, axis=0)            # the bias hardly moves in 0.1 s: diff ~ white * sqrt 2
    assert np.std(white) / math.sqrt(2) == pytest.approx(0.5, rel=0.1)
    assert abs(np.mean(err)) < 3.0            # bounded: GPS error does not drift like odometry


def test_position_bias_is_a_slow_gauss_markov_process():
    err = PositionError(0.0, 1.0, 100.0, np.random.default_rng(2))
    bias = []
    for _ in range(100_000):                  # 10 000 s = 100 correlation times
        err.step(0.1)
        bias.append(err.bias_ne_m)
    b = np.array(bias)
    assert np.std(b) == pytest.approx(1.0, rel=0.2)
    lag_10s = np.mean([np.corrcoef(b[:-100, k], b[100:, k])[0, 1] for k in range(2)])
    assert lag_10s == pytest.approx(math.exp(-0.1), abs=0.05)


def test_attitude_yaw_carries_a_slow_ahrs_bias_that_the_vehicle_steers_by():
    # ArduCopter 4.6 SITL's ATTITUDE yaw stays 1.3-1.5 deg off SIMSTATE for a whole flight: a
    # bias, not white noise. The stub's: the bias (seeded, per flight) plus white noise, and the
    # vehicle turns to a commanded yaw by its AHRS, so its true heading is off by the bias.
    rig = gps_rig(seed=2, position_sigma_m=0.3, yaw_sigma_deg=0.5, yaw_bias_sigma_deg=1.5,
                  yaw_bias_tau_s=3600.0, heading_change_sigma_deg=0.0)   # no gyro drift
    bias = rig.sim.yaw_bias.bias_rad
    assert abs(math.degrees(bias)) > 1.0                   # this seed's draw: not a tiny one
    rig.airborne()
    errors, truth = [], []
    for _ in range(600):                    # 60 s north at 5 m/s, nose commanded north
        rig.target(vx=5.0, vy=0.0, yaw=0.0)
        rig.run(0.1)
        errors.append(rig.sim.reported_yaw_rad() - rig.sim.truth.yaw_rad)
        truth.append(rig.sim.truth.yaw_rad)
    err = np.array(errors)
    assert np.mean(err) == pytest.approx(rig.sim.yaw_bias.bias_rad, abs=math.radians(0.3))
    assert abs(np.mean(err)) > 10 * np.std(err) / math.sqrt(60)     # not zero-mean white noise
    assert math.degrees(np.std(np.diff(err))) / math.sqrt(2) == pytest.approx(0.5, rel=0.15)
    assert np.mean(truth[-100:]) == pytest.approx(-np.mean(err[-100:]), abs=math.radians(0.2))


def test_yaw_bias_is_off_by_default_and_a_gauss_markov_process_across_seeds():
    rig = gps_rig(position_sigma_m=0.3)
    assert rig.sim.yaw_bias.bias_rad == 0.0                # paper.yaml and friends: unchanged
    draws = [YawBias(math.radians(1.5), 600.0, np.random.default_rng([s, 5])).bias_rad
             for s in range(400)]
    assert math.degrees(np.std(draws)) == pytest.approx(1.5, rel=0.12)
    bias = YawBias(1.0, 60.0, np.random.default_rng(3))
    b = []
    for _ in range(60_000):                   # 6000 s = 100 correlation times
        bias.step(0.1)
        b.append(bias.bias_rad)
    b = np.array(b)
    assert np.std(b) == pytest.approx(1.0, rel=0.2)
    assert np.corrcoef(b[:-100], b[100:])[0, 1] == pytest.approx(math.exp(-10 / 60), abs=0.06)


def test_home_and_gps_global_origin_on_request():
    rig = Rig()
    res, out = rig.cmd(mavlink.MAV_CMD_REQUEST_MESSAGE, mavlink.MAVLINK_MSG_ID_GPS_GLOBAL_ORIGIN)
    assert res == mavlink.MAV_RESULT_ACCEPTED and out[1].get_type() == "GPS_GLOBAL_ORIGIN"
    origin = rig.sim.scenario.world.origin
    assert out[1].latitude == round(origin.lat_deg * 1e7)
    res, out = rig.cmd(mavlink.MAV_CMD_GET_HOME_POSITION)
    assert out[1].get_type() == "HOME_POSITION" and out[1].x == 20.0
    res, out = rig.cmd(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, 245, 500000)
    assert res == mavlink.MAV_RESULT_ACCEPTED
    assert rig.ap.scheduler.interval_s(245) == 0.5


def test_extended_sys_state_only_when_asked():
    rig = Rig()
    assert 245 not in rig.ap.scheduler.due(0.0)
    rig.cmd(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, 245, 200000)
    assert 245 in rig.ap.scheduler.due(0.1)
