"""The MAVLink dialect every module here speaks, set up once, and the message ids named once.

MAVLink 2 (``MAVLINK20`` before pymavlink loads), ArduPilot's ``ardupilotmega`` dialect. The
codecs (codec.py, mission_codec.py, param_codec.py, gcs_codec.py) take ``mavlink`` and the ids from here.
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
