"""The service's MAVLink vocabulary in one import: events in, intents out, commands, framing.

mavlink/ is the MAVLink layer, and no module outside it knows a message's field names or
scalings (1e7 degrees, millimetres, centimetres). Its modules, one job each:

- dialect.py: the dialect (MAVLink 2, ArduPilot's ardupilotmega), set up once; message ids,
  component ids, severities and the data-stream groups, named once.
- events.py: the inbound events, frozen and in SI units; inbound.py: ``decode`` (received
  message -> event) and the readers of recorded messages.
- obstacle_forms.py: OBSTACLE_DISTANCE_3D and OBSTACLE_DISTANCE, both ways.
- outbound.py: our intents (setpoint, pose, notice) and the messages they become;
  commands.py: COMMAND_LONG and stream requests to the vehicle, and their acks.
- wire.py: bytes <-> messages (Parser, Encoder) and MAVLink 2 signing; link.py: the asyncio
  link; tlog.py: tlogs.
- px4_modes.py: PX4's custom_mode (main and sub mode), its mode command, our ModeRequest.
- mission_codec.py, param_codec.py: the mission and parameter protocols; gcs_codec.py: the
  demo ground station's view of an ArduPilot SITL.

This module defines nothing: it gathers the names the service, the tools and the tests use as
``codec.<name>``. Times: ``t_s`` is the vehicle's time since boot (time_boot_ms / 1000), the
estimator's clock. Frames: LOCAL_NED (x north, y east, yaw clockwise from north) and body FRD
(x forward, y right; bearing = atan2(y, x), positive to the right). docs/messages.md lists every
message used with its fields and units.
"""
from __future__ import annotations

from companion.mavlink.commands import (arm, is_ack_for, is_set_message_interval_ack,  # noqa: F401
                                        request_data_stream, request_message,
                                        set_message_interval, set_mode, takeoff)
from companion.mavlink.dialect import (DATA_STREAMS_FOR, MAV_COMP_ID_AUTOPILOT1,  # noqa: F401
                                       MAV_COMP_ID_MISSIONPLANNER, MAV_COMP_ID_ONBOARD_COMPUTER,
                                       SEVERITY_ERROR, SEVERITY_INFO, SEVERITY_NOTICE,
                                       SEVERITY_WARNING, mavlink)
from companion.mavlink.events import (EKF_CONST_POS_MODE, EKF_GPS_GLITCH,  # noqa: F401
                                      EKF_POS_HORIZ_ABS, LANDED_STATE_IN_AIR,
                                      LANDED_STATE_LANDING, LANDED_STATE_ON_GROUND,
                                      LANDED_STATE_TAKEOFF, LANDED_STATE_UNDEFINED, Attitude,
                                      CommandAck, EkfStatus, Event, GeoReference, GlobalPosition,
                                      GpsFix, Heartbeat, LandedState, LocalPosition,
                                      ObstacleFrame, StatusText, TimeSyncReply)
from companion.mavlink.inbound import (decode, is_from_us, message_type,  # noqa: F401
                                       packet_bytes, sender_component, source, vehicle_time_s)
from companion.mavlink.obstacle_forms import (MOVER_TRACK_ID_BASE, NO_OBSTACLE_ID,  # noqa: F401
                                              MoverReport, SectorMap, mover_obstacle,
                                              obstacle_distance_map, sector_bearings_rad)
from companion.mavlink.outbound import (STATUSTEXT_MAX_CHARS, VELOCITY_YAW_TYPE_MASK,  # noqa: F401
                                        Notice, PoseEstimate, VelocitySetpoint, float32,
                                        gcs_heartbeat, heartbeat, ms_of, odometry, odometry_key,
                                        pose_covariance_21, set_position_target, setpoint_key,
                                        setpoint_key_of, statustext, sys_status,
                                        timesync_request)
from companion.mavlink.px4_modes import AUTO_LOITER as PX4_AUTO_LOITER  # noqa: F401
from companion.mavlink.px4_modes import OFFBOARD as PX4_OFFBOARD  # noqa: F401
from companion.mavlink.px4_modes import ModeRequest, set_mode_command  # noqa: F401
from companion.mavlink.px4_modes import stream_request as px4_stream_request  # noqa: F401
from companion.mavlink.wire import (NEW_STREAM_WINDOW, SIGNING_EPOCH_UNIX_S,  # noqa: F401
                                    Encoder, Parser, make_mavlink, signing_timestamp)
