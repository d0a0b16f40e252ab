"""A PX4 ground station (pymavlink, on the stub's TCP port) for the e2e tests of the PX4 face:
PX4's parameters bytewise, arming while TEMPORARILY_REJECTED, NAV_TAKEOFF to an AMSL altitude,
OFFBOARD by the operator, PX4's mission upload (item 0 is the first waypoint)."""
from __future__ import annotations

import struct
import time

from tests.e2e.support import TAKEOFF_ALT_M, mavutil

MAV = mavutil.mavlink
OFFBOARD = 6 << 16
HOLD = (4 << 16) | (3 << 24)          # AUTO.LOITER


class Px4GroundStation:
    def __init__(self, tcp_port: int) -> None:
        self.conn = mavutil.mavlink_connection(f"tcp:127.0.0.1:{tcp_port}", source_system=255,
                                               source_component=190)
        self.conn.wait_heartbeat(timeout=10)

    def command(self, command: int, *params: float, timeout_s: float = 30.0) -> None:
        """COMMAND_LONG until accepted: resent 0.3 s after a refusal or silence."""
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            self.conn.mav.command_long_send(1, 1, command, 0, *params, *[0] * (7 - len(params)))
            ack = self.conn.recv_match(type="COMMAND_ACK", blocking=True, timeout=0.3)
            if ack is not None and ack.command == command and ack.result == 0:
                return
            time.sleep(0.3 if ack is not None else 0.0)
        raise AssertionError(f"command {command} not accepted within {timeout_s} s")

    def set_param_int(self, name: str, value: int) -> None:
        """PARAM_SET of an INT32, bytewise as PX4 reads it; waits for its PARAM_VALUE."""
        raw = struct.unpack("<f", struct.pack("<i", value))[0]
        for _ in range(10):
            self.conn.mav.param_set_send(1, 1, name.encode(), raw, MAV.MAV_PARAM_TYPE_INT32)
            msg = self.conn.recv_match(type="PARAM_VALUE", blocking=True, timeout=1.0)
            if msg is not None and msg.param_id == name and \
                    struct.unpack("<i", struct.pack("<f", msg.param_value))[0] == value:
                return
        raise AssertionError(f"{name} not set to {value}")

    def home_amsl_m(self) -> float:
        msg = self.conn.recv_match(type="GLOBAL_POSITION_INT", blocking=True, timeout=10.0)
        return msg.alt / 1000.0 - msg.relative_alt / 1000.0

    def wait_mode(self, custom_mode: int, timeout_s: float = 60.0) -> None:
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            hb = self.conn.recv_match(type="HEARTBEAT", blocking=True, timeout=1.0)
            if hb is not None and hb.get_srcComponent() == 1 and hb.custom_mode == custom_mode:
                return
        raise AssertionError(f"mode {custom_mode} not seen within {timeout_s} s")

    def take_off_to_hold(self, above_home_m: float = TAKEOFF_ALT_M) -> None:
        """Arm (PX4 refuses until its preflight checks pass), NAV_TAKEOFF to home's AMSL
        altitude plus ``above_home_m``, then Hold."""
        self.command(MAV.MAV_CMD_COMPONENT_ARM_DISARM, 1)
        nan = float("nan")            # yaw, latitude, longitude: here (not 0, 0)
        self.command(MAV.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, nan, nan, nan,
                     self.home_amsl_m() + above_home_m)
        self.wait_mode(HOLD)

    def offboard(self) -> None:
        """The operator's switch: refused until the service's setpoints have flowed > 1 s."""
        self.command(MAV.MAV_CMD_DO_SET_MODE, 1, 6, 0)

    def upload_mission(self, lat_lon_deg: list[tuple[float, float]], alt_m: float = 10.0,
                       acceptance_m: float = 2.0) -> None:
        """PX4's upload: MISSION_COUNT, then MISSION_REQUEST_INT seq 0.. answered with
        MISSION_ITEM_INT (seq 0 is the first waypoint), MISSION_ACK accepted."""
        self.conn.mav.mission_count_send(1, 1, len(lat_lon_deg), 0)
        while True:
            msg = self.conn.recv_match(type=["MISSION_REQUEST_INT", "MISSION_REQUEST",
                                             "MISSION_ACK"], blocking=True, timeout=5.0)
            assert msg is not None, "no mission request"
            if msg.get_type() == "MISSION_ACK":
                assert msg.type == 0, msg
                return
            lat, lon = lat_lon_deg[msg.seq]
            self.conn.mav.mission_item_int_send(
                1, 1, msg.seq, MAV.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, MAV.MAV_CMD_NAV_WAYPOINT,
                0, 1, 0, acceptance_m, 0, float("nan"), int(round(lat * 1e7)),
                int(round(lon * 1e7)), alt_m, 0)

    def close(self) -> None:
        self.conn.close()
