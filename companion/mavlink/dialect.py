"""The MAVLink dialect every module here speaks, set up once, and its numbers named once.

MAVLink 2 (``MAVLINK20`` before pymavlink loads), ArduPilot's ``ardupilotmega`` dialect. Every
module of mavlink/ takes ``mavlink``, the message ids, the component ids, the severities and the
data-stream groups from here; no other module in companion/ imports pymavlink.
"""
from __future__ import annotations

import os

os.environ.setdefault("MAVLINK20", "1")
from pymavlink.dialects.v20 import ardupilotmega as mavlink  # noqa: E402


def msg_id(name: str) -> int:
    """The dialect's id of message ``name`` (``ATTITUDE``: MAVLINK_MSG_ID_ATTITUDE)."""
    return getattr(mavlink, f"MAVLINK_MSG_ID_{name}")


MSG_ID_ATTITUDE = msg_id("ATTITUDE")
MSG_ID_LOCAL_POSITION_NED = msg_id("LOCAL_POSITION_NED")
MSG_ID_GLOBAL_POSITION_INT = msg_id("GLOBAL_POSITION_INT")
MSG_ID_EXTENDED_SYS_STATE = msg_id("EXTENDED_SYS_STATE")
MSG_ID_HOME_POSITION = msg_id("HOME_POSITION")
MSG_ID_GPS_GLOBAL_ORIGIN = msg_id("GPS_GLOBAL_ORIGIN")
MSG_ID_GPS_RAW_INT = msg_id("GPS_RAW_INT")
MSG_ID_EKF_STATUS_REPORT = msg_id("EKF_STATUS_REPORT")
MSG_ID_SIMSTATE = msg_id("SIMSTATE")


# Component ids, STATUSTEXT severities and the REQUEST_DATA_STREAM groups the service names.
MAV_COMP_ID_AUTOPILOT1 = mavlink.MAV_COMP_ID_AUTOPILOT1
MAV_COMP_ID_ONBOARD_COMPUTER = mavlink.MAV_COMP_ID_ONBOARD_COMPUTER    # 191
MAV_COMP_ID_MISSIONPLANNER = mavlink.MAV_COMP_ID_MISSIONPLANNER        # 190, the demo's GCS
SEVERITY_WARNING = mavlink.MAV_SEVERITY_WARNING
SEVERITY_NOTICE = mavlink.MAV_SEVERITY_NOTICE
SEVERITY_INFO = mavlink.MAV_SEVERITY_INFO
SEVERITY_ERROR = mavlink.MAV_SEVERITY_ERROR
# REQUEST_DATA_STREAM fallback: LOCAL_POSITION_NED and GLOBAL_POSITION_INT ride POSITION,
# ATTITUDE rides EXTRA1, GPS_RAW_INT EXTENDED_STATUS, EKF_STATUS_REPORT EXTRA3 (ArduCopter
# GCS_Mavlink.cpp). EXTENDED_SYS_STATE rides no stream on ArduCopter (interval only).
DATA_STREAMS_FOR = {MSG_ID_LOCAL_POSITION_NED: mavlink.MAV_DATA_STREAM_POSITION,
                    MSG_ID_GLOBAL_POSITION_INT: mavlink.MAV_DATA_STREAM_POSITION,
                    MSG_ID_ATTITUDE: mavlink.MAV_DATA_STREAM_EXTRA1,
                    MSG_ID_GPS_RAW_INT: mavlink.MAV_DATA_STREAM_EXTENDED_STATUS,
                    MSG_ID_EKF_STATUS_REPORT: mavlink.MAV_DATA_STREAM_EXTRA3}
