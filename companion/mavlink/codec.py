"""MAVLink <-> typed events for the service: its messages' field names and scalings live here.

The MAVLink layer is mavlink/: the dialect and message ids (dialect.py), this codec, the
mission protocol's (mission_codec.py), the demo ground station's (gcs_codec.py), the asyncio link
with signing (link.py) and tlogs (tlog.py); no module outside mavlink/ knows a field name.

Inbound messages become frozen events in SI units (seconds, metres, radians); outbound intents
become pymavlink messages. Times: ``t_s`` is the vehicle's time since boot (time_boot_ms / 1000),
the estimator's clock. Frames: LOCAL_NED (x north, y east, yaw clockwise from north) and body FRD
(x forward, y right; bearing = atan2(y, x), positive to the right). docs/messages.md lists every
message used here with its fields and units.
"""
from __future__ import annotations

import functools
import hashlib
import hmac
import math
import struct
import time
import types
from dataclasses import dataclass

from companion.core.estimation.slam_types import Observation
from companion.mavlink.dialect import (MSG_ID_ATTITUDE, MSG_ID_EKF_STATUS_REPORT,
                                       MSG_ID_GLOBAL_POSITION_INT, MSG_ID_GPS_RAW_INT,
                                       MSG_ID_LOCAL_POSITION_NED, mavlink)
from companion.mavlink.mission_codec import DECODERS as _mission_decoders
from companion.mavlink.mission_codec import GOAL_DECODERS as _goal_decoders
from companion.mavlink.param_codec import DECODERS as _param_decoders

MAV_COMP_ID_AUTOPILOT1 = mavlink.MAV_COMP_ID_AUTOPILOT1
MAV_COMP_ID_ONBOARD_COMPUTER = mavlink.MAV_COMP_ID_ONBOARD_COMPUTER    # 191
MAV_COMP_ID_MISSIONPLANNER = mavlink.MAV_COMP_ID_MISSIONPLANNER        # 190, the demo's GCS
NO_OBSTACLE_ID = 65535                                                # UINT16_MAX: "no id"
# SET_POSITION_TARGET_LOCAL_NED.type_mask: ignore position (0x7), acceleration (0x1C0) and yaw
# rate (0x800); use velocity (vx, vy and vz: ArduCopter flies vz as a climb rate) and yaw.
VELOCITY_YAW_TYPE_MASK = 0x09C7
# REQUEST_DATA_STREAM fallback: LOCAL_POSITION_NED and GLOBAL_POSITION_INT ride POSITION,
# ATTITUDE rides EXTRA1, GPS_RAW_INT EXTENDED_STATUS, EKF_STATUS_REPORT EXTRA3 (ArduCopter
# GCS_Mavlink.cpp). EXTENDED_SYS_STATE rides no stream on ArduCopter (interval only).
DATA_STREAMS_FOR = {MSG_ID_LOCAL_POSITION_NED: mavlink.MAV_DATA_STREAM_POSITION,
                    MSG_ID_GLOBAL_POSITION_INT: mavlink.MAV_DATA_STREAM_POSITION,
                    MSG_ID_ATTITUDE: mavlink.MAV_DATA_STREAM_EXTRA1,
                    MSG_ID_GPS_RAW_INT: mavlink.MAV_DATA_STREAM_EXTENDED_STATUS,
                    MSG_ID_EKF_STATUS_REPORT: mavlink.MAV_DATA_STREAM_EXTRA3}
# MAV_LANDED_STATE
LANDED_STATE_UNDEFINED = mavlink.MAV_LANDED_STATE_UNDEFINED      # 0
LANDED_STATE_ON_GROUND = mavlink.MAV_LANDED_STATE_ON_GROUND      # 1
LANDED_STATE_IN_AIR = mavlink.MAV_LANDED_STATE_IN_AIR            # 2
LANDED_STATE_TAKEOFF = mavlink.MAV_LANDED_STATE_TAKEOFF          # 3
LANDED_STATE_LANDING = mavlink.MAV_LANDED_STATE_LANDING          # 4
SEVERITY_WARNING = mavlink.MAV_SEVERITY_WARNING
SEVERITY_NOTICE = mavlink.MAV_SEVERITY_NOTICE
SEVERITY_INFO = mavlink.MAV_SEVERITY_INFO
SEVERITY_ERROR = mavlink.MAV_SEVERITY_ERROR
STATUSTEXT_MAX_CHARS = 50


def make_mavlink(system_id: int, component_id: int) -> mavlink.MAVLink:
    """A MAVLink 2 parser/encoder with no file: bytes go in via parse_buffer, out via pack."""
    mav = mavlink.MAVLink(None, srcSystem=system_id, srcComponent=component_id)
    mav.robust_parsing = True
    return mav


def source(msg) -> tuple[int, int]:
    """(system id, component id) of a received message."""
    return msg.get_srcSystem(), msg.get_srcComponent()


# ------------------------------------------------------------------ inbound events
@dataclass(frozen=True)
class TimeSyncReply:
    """TIMESYNC with tc1 != 0: a reply (tc1 the responder's clock, ts1 our request's, both ns).
    Requests to us (tc1 = 0) are not decoded: we do not answer them."""
    system_id: int
    component_id: int
    tc1_ns: int
    ts1_ns: int


@dataclass(frozen=True)
class Heartbeat:
    system_id: int
    component_id: int
    mav_type: int
    is_autopilot: bool        # autopilot field is not MAV_AUTOPILOT_INVALID
    armed: bool
    custom_mode: int


@dataclass(frozen=True)
class Attitude:
    system_id: int
    component_id: int
    t_s: float
    yaw_rad: float
    yaw_rate_rad_s: float


@dataclass(frozen=True)
class LocalPosition:
    system_id: int
    component_id: int
    t_s: float
    north_m: float
    east_m: float
    vel_north_mps: float
    vel_east_mps: float
    down_m: float = math.nan          # z: metres below the EKF origin
    vel_down_mps: float = math.nan    # vz


@dataclass(frozen=True)
class GlobalPosition:
    """GLOBAL_POSITION_INT: the altitude above home (relative_alt) and the climb rate."""
    system_id: int
    component_id: int
    t_s: float
    lat_deg: float
    lon_deg: float
    relative_alt_m: float
    vel_down_mps: float


@dataclass(frozen=True)
class LandedState:
    """EXTENDED_SYS_STATE (no time field of its own)."""
    system_id: int
    component_id: int
    landed_state: int                 # MAV_LANDED_STATE_*
    vtol_state: int


@dataclass(frozen=True)
class GeoReference:
    """A point known both on the globe and in LOCAL_NED: the EKF origin (GPS_GLOBAL_ORIGIN,
    at north = east = 0) or HOME_POSITION (at its x, y)."""
    system_id: int
    component_id: int
    kind: str                         # 'origin' or 'home'
    lat_deg: float
    lon_deg: float
    north_m: float
    east_m: float


@dataclass(frozen=True)
class ObstacleFrame:
    """Observations of one obstacle message (one OBSTACLE_DISTANCE_3D or all valid sectors)."""
    system_id: int
    component_id: int
    t_s: float
    observations: tuple[Observation, ...]
    rejected: str | None = None      # why the message gave no observation (frame, NaN, range)
    # OBSTACLE_DISTANCE: every element as (ranges_m with NaN where nothing, bearings_rad,
    # increment_rad), for core/perception/blobs.py; None for other messages
    sectors: tuple | None = None


@dataclass(frozen=True)
class CommandAck:
    system_id: int
    component_id: int
    command: int
    accepted: bool
    result: int


@dataclass(frozen=True)
class StatusText:
    system_id: int
    component_id: int
    severity: int
    text: str


@dataclass(frozen=True)
class GpsFix:
    """GPS_RAW_INT: the fix type (GPS_FIX_TYPE: 3 = 3D), HDOP (None: unknown) and the receiver's
    horizontal accuracy (None: not reported)."""
    system_id: int
    component_id: int
    fix_type: int
    hdop: float | None
    h_acc_m: float | None
    satellites: int | None


# EKF_STATUS_REPORT.flags (ESTIMATOR_STATUS_FLAGS) the position-fusion rule reads.
EKF_POS_HORIZ_ABS = mavlink.ESTIMATOR_POS_HORIZ_ABS
EKF_CONST_POS_MODE = mavlink.ESTIMATOR_CONST_POS_MODE
EKF_GPS_GLITCH = mavlink.ESTIMATOR_GPS_GLITCH


@dataclass(frozen=True)
class EkfStatus:
    """EKF_STATUS_REPORT: is the autopilot's absolute horizontal position good?"""
    system_id: int
    component_id: int
    flags: int

    @property
    def horizontal_position_ok(self) -> bool:
        """An absolute horizontal position, not the constant-position fallback, no GPS glitch."""
        bad = EKF_CONST_POS_MODE | EKF_GPS_GLITCH
        return bool(self.flags & EKF_POS_HORIZ_ABS) and not self.flags & bad


Event = Heartbeat | Attitude | LocalPosition | ObstacleFrame | CommandAck | StatusText \
    | GlobalPosition | LandedState | GeoReference | GpsFix | EkfStatus


def decode(msg) -> Event | None:
    """The event a received message carries, or None for messages the companion does not use."""
    kind = msg.get_type()
    handler = _DECODERS.get(kind)
    return handler(msg, *source(msg)) if handler else None


def _heartbeat(msg, sysid: int, compid: int) -> Heartbeat:
    return Heartbeat(sysid, compid, msg.type, msg.autopilot != mavlink.MAV_AUTOPILOT_INVALID,
                     bool(msg.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED), msg.custom_mode)


def _attitude(msg, sysid: int, compid: int) -> Attitude:
    return Attitude(sysid, compid, msg.time_boot_ms / 1000.0, msg.yaw, msg.yawspeed)


def _local_position(msg, sysid: int, compid: int) -> LocalPosition:
    return LocalPosition(sysid, compid, msg.time_boot_ms / 1000.0, msg.x, msg.y, msg.vx, msg.vy,
                         msg.z, msg.vz)


def _global_position(msg, sysid: int, compid: int) -> GlobalPosition:
    """lat, lon in 1e7 degrees; relative_alt in mm above home; vz in cm/s, down positive."""
    return GlobalPosition(sysid, compid, msg.time_boot_ms / 1000.0, msg.lat / 1e7, msg.lon / 1e7,
                          msg.relative_alt / 1000.0, msg.vz / 100.0)


def _extended_sys_state(msg, sysid: int, compid: int) -> LandedState:
    return LandedState(sysid, compid, msg.landed_state, msg.vtol_state)


def _gps_global_origin(msg, sysid: int, compid: int) -> GeoReference:
    return GeoReference(sysid, compid, "origin", msg.latitude / 1e7, msg.longitude / 1e7, 0.0, 0.0)


def _home_position(msg, sysid: int, compid: int) -> GeoReference:
    """latitude/longitude in 1e7 degrees; x, y: home in LOCAL_NED (m from the EKF origin)."""
    return GeoReference(sysid, compid, "home", msg.latitude / 1e7, msg.longitude / 1e7,
                        msg.x, msg.y)


def _obstacle_3d(msg, sysid: int, compid: int) -> ObstacleFrame:
    """OBSTACLE_DISTANCE_3D in MAV_FRAME_BODY_FRD: range = hypot(x, y), bearing = atan2(y, x).

    z (down, metres below the camera) rides on the observation as its top and bottom depth
    (one point: both); only avoidance.vertical reads it (onboard/heights.py). A non-finite x, y
    or z refuses the message. Other frames are refused: turning a LOCAL_NED point into a
    range and bearing needs the pose, and that belongs to the estimator, not here.
    """
    t_s = msg.time_boot_ms / 1000.0
    if msg.frame != mavlink.MAV_FRAME_BODY_FRD:
        return ObstacleFrame(sysid, compid, t_s, (), f"frame {msg.frame} not BODY_FRD")
    if not (math.isfinite(msg.x) and math.isfinite(msg.y) and math.isfinite(msg.z)):
        return ObstacleFrame(sysid, compid, t_s, (), "non-finite position")
    bounds = _bounds_problem(msg.min_distance, msg.max_distance)
    if bounds:
        return ObstacleFrame(sysid, compid, t_s, (), bounds)
    range_m = math.hypot(msg.x, msg.y)
    if range_m <= 0.0 or (msg.max_distance > 0.0 and range_m > msg.max_distance) \
            or range_m < msg.min_distance:
        return ObstacleFrame(sysid, compid, t_s, (), f"range {range_m:.2f} m outside the sensor's")
    oid = None if msg.obstacle_id == NO_OBSTACLE_ID else int(msg.obstacle_id)
    return ObstacleFrame(sysid, compid, t_s,
                         (Observation(range_m, math.atan2(msg.y, msg.x), oid,
                                      top_down_m=float(msg.z), bottom_down_m=float(msg.z)),))


def _bounds_problem(min_m: float, max_m: float) -> str | None:
    """Why a sensor's [min_distance, max_distance] cannot be believed (max 0: not given)."""
    if not (math.isfinite(min_m) and math.isfinite(max_m)):
        return "non-finite distance bounds"
    if min_m < 0.0 or max_m < 0.0:
        return "negative distance bounds"
    if max_m > 0.0 and min_m > max_m:
        return "min_distance above max_distance"
    return None


def sector_bearings_rad(increment_deg: float, increment_f_deg: float, angle_offset_deg: float,
                        count: int) -> list[float]:
    """Bearing of each OBSTACLE_DISTANCE element: element i lies at angle_offset + i * increment
    (the spec: angle_offset is 'the angle of the 0-index element'), clockwise positive.
    increment_f, when non-zero, overrides the integer increment."""
    step_deg = increment_f_deg if increment_f_deg > 0.0 else float(increment_deg)
    return [math.radians(angle_offset_deg + i * step_deg) for i in range(count)]


@functools.lru_cache(maxsize=64)
def _wrapped_sector_bearings_rad(increment_deg: float, increment_f_deg: float,
                                 angle_offset_deg: float, count: int) -> tuple[float, ...]:
    """sector_bearings_rad wrapped to [-pi, pi]: the same few sector layouts arrive at every
    frame (a camera's is fixed), so each is computed once."""
    return tuple(math.atan2(math.sin(b), math.cos(b))
                 for b in sector_bearings_rad(increment_deg, increment_f_deg, angle_offset_deg,
                                              count))


def _obstacle_sectors(msg, sysid: int, compid: int) -> ObstacleFrame:
    """OBSTACLE_DISTANCE: one observation (no id) per sector holding a valid distance.

    distances are centimetres; UINT16_MAX means unknown, max_distance + 1 means nothing seen,
    anything outside [min_distance, max_distance] is not a detection. time_usec is read as time
    since boot (ArduPilot and the stub stamp it so); frame 0 (unset) is taken as BODY_FRD.
    """
    t_s = msg.time_usec / 1e6
    if msg.frame not in (0, mavlink.MAV_FRAME_BODY_FRD):
        return ObstacleFrame(sysid, compid, t_s, (), f"frame {msg.frame} not BODY_FRD")
    if not (math.isfinite(msg.angle_offset) and math.isfinite(msg.increment_f)):
        return ObstacleFrame(sysid, compid, t_s, (), "non-finite sector angles")
    if msg.increment_f < 0.0 or (msg.increment_f == 0.0 and msg.increment == 0):
        return ObstacleFrame(sysid, compid, t_s, (), "sector increment not positive")
    if msg.min_distance > msg.max_distance:
        return ObstacleFrame(sysid, compid, t_s, (), "min_distance above max_distance")
    wrapped = _wrapped_sector_bearings_rad(msg.increment, msg.increment_f, msg.angle_offset,
                                           len(msg.distances))
    low, high = msg.min_distance, msg.max_distance
    valid = [cm != NO_OBSTACLE_ID and low <= cm <= high for cm in msg.distances]
    observations = tuple(Observation(cm / 100.0, b, None)
                         for cm, b, ok in zip(msg.distances, wrapped, valid) if ok)
    step_deg = msg.increment_f if msg.increment_f > 0.0 else float(msg.increment)
    sectors = (tuple(cm / 100.0 if ok else math.nan for cm, ok in zip(msg.distances, valid)),
               wrapped, math.radians(step_deg))
    return ObstacleFrame(sysid, compid, t_s, observations, sectors=sectors)


def _command_ack(msg, sysid: int, compid: int) -> CommandAck:
    return CommandAck(sysid, compid, msg.command, msg.result == mavlink.MAV_RESULT_ACCEPTED,
                      msg.result)


def _statustext(msg, sysid: int, compid: int) -> StatusText:
    text = msg.text if isinstance(msg.text, str) else msg.text.decode("utf-8", "replace")
    return StatusText(sysid, compid, msg.severity, text.rstrip("\x00"))


def _gps_raw(msg, sysid: int, compid: int) -> GpsFix:
    """GPS_RAW_INT: eph is HDOP x 100 (UINT16_MAX unknown); h_acc, a MAVLink 2 extension, is
    millimetres (0 when not sent); satellites_visible 255 is unknown."""
    hdop = None if msg.eph == 65535 else msg.eph / 100.0
    h_acc = getattr(msg, "h_acc", 0) or 0
    sats = None if msg.satellites_visible == 255 else int(msg.satellites_visible)
    return GpsFix(sysid, compid, int(msg.fix_type), hdop, h_acc / 1000.0 if h_acc > 0 else None,
                  sats)


def _ekf_status(msg, sysid: int, compid: int) -> EkfStatus:
    return EkfStatus(sysid, compid, int(msg.flags))


def _timesync(msg, sysid: int, compid: int) -> TimeSyncReply | None:
    return TimeSyncReply(sysid, compid, int(msg.tc1), int(msg.ts1)) if msg.tc1 != 0 else None


_DECODERS = {
    "TIMESYNC": _timesync,
    "GPS_RAW_INT": _gps_raw,
    "EKF_STATUS_REPORT": _ekf_status,
    "HEARTBEAT": _heartbeat,
    "ATTITUDE": _attitude,
    "LOCAL_POSITION_NED": _local_position,
    "GLOBAL_POSITION_INT": _global_position,
    "EXTENDED_SYS_STATE": _extended_sys_state,
    "GPS_GLOBAL_ORIGIN": _gps_global_origin,
    "HOME_POSITION": _home_position,
    "OBSTACLE_DISTANCE_3D": _obstacle_3d,
    "OBSTACLE_DISTANCE": _obstacle_sectors,
    "COMMAND_ACK": _command_ack,
    "STATUSTEXT": _statustext,
}
_DECODERS.update(_mission_decoders)
_DECODERS.update(_goal_decoders)
_DECODERS.update(_param_decoders)


# ------------------------------------------------------------------ outbound intents
@dataclass(frozen=True)
class VelocitySetpoint:
    """Velocity (LOCAL_NED, autopilot frame) and yaw for the vehicle; t_s is the vehicle's time.
    vel_down_mps: the vertical term (ArduCopter flies vz as a climb rate; 0 holds the altitude)."""
    target_system: int
    target_component: int
    t_s: float
    vel_north_mps: float
    vel_east_mps: float
    yaw_rad: float
    reason: str                 # 'goal', 'avoid', 'escape', 'arrived', 'hold: ...'
    vel_down_mps: float = 0.0


@dataclass(frozen=True)
class PoseEstimate:
    """The SLAM pose [north_m, east_m, yaw_rad] with its (3,3) covariance at vehicle time t_s."""
    t_s: float
    north_m: float
    east_m: float
    yaw_rad: float
    cov: tuple[tuple[float, ...], ...]
    reset_counter: int
    quality: int = 0            # ODOMETRY.quality: 100 best, 1 worst, 0 unknown, -1 failed


@dataclass(frozen=True)
class MoverReport:
    """A tracked moving obstacle's estimated position (LOCAL_NED, SLAM frame) at vehicle time t_s."""
    t_s: float
    obstacle_id: int | None
    track_id: int
    north_m: float
    east_m: float


# Tracks without a sensor id are published with ids from here up, clear of the camera's ids.
MOVER_TRACK_ID_BASE = 60000


def mover_obstacle(report: MoverReport) -> mavlink.MAVLink_obstacle_distance_3d_message:
    """OBSTACLE_DISTANCE_3D in MAV_FRAME_LOCAL_NED: a tracked mover's position for the ground
    station (the camera's own reports are BODY_FRD; the frame tells the two apart)."""
    oid = report.obstacle_id if report.obstacle_id is not None else \
        min(MOVER_TRACK_ID_BASE + report.track_id, 65534)
    return mavlink.MAVLink_obstacle_distance_3d_message(
        ms_of(report.t_s), mavlink.MAV_DISTANCE_SENSOR_UNKNOWN, mavlink.MAV_FRAME_LOCAL_NED,
        oid, report.north_m, report.east_m, 0.0, 0.0, 0.0)


@dataclass(frozen=True)
class SectorMap:
    """The mapped obstacles as OBSTACLE_DISTANCE sectors (companion/core/perception/sector_map.py): nearest
    surface per sector in metres (inf: none within range), body FRD from the nose, clockwise."""
    t_s: float
    distances_m: tuple[float, ...]
    increment_deg: float
    min_distance_m: float
    max_distance_m: float


def obstacle_distance_map(scan: SectorMap) -> mavlink.MAVLink_obstacle_distance_message:
    """OBSTACLE_DISTANCE in MAV_FRAME_BODY_FRD as AP_Proximity_MAV reads it: increment_f (and the
    integer increment), angle_offset 0 (element 0 on the nose), centimetres within [min, max],
    max + 1 for 'nothing there'; a surface nearer than min_distance is sent as min_distance (an
    obstacle at the sensor's limit, not none). time_usec is the vehicle's time since boot."""
    min_cm = max(1, int(math.ceil(scan.min_distance_m * 100.0)))
    max_cm = min(65533, int(scan.max_distance_m * 100.0))
    distances = []
    for d_m in scan.distances_m:
        if not math.isfinite(d_m) or d_m * 100.0 > max_cm:
            distances.append(max_cm + 1)
        else:
            distances.append(min(max(int(d_m * 100.0), min_cm), max_cm))
    return mavlink.MAVLink_obstacle_distance_message(
        int(round(scan.t_s * 1e6)), mavlink.MAV_DISTANCE_SENSOR_UNKNOWN, distances,
        int(round(scan.increment_deg)), min_cm, max_cm, float(scan.increment_deg), 0.0,
        mavlink.MAV_FRAME_BODY_FRD)


@dataclass(frozen=True)
class Notice:
    """A STATUSTEXT to the ground station."""
    severity: int
    text: str


def ms_of(t_s: float) -> int:
    """Vehicle time in whole milliseconds, as MAVLink carries it."""
    return int(round(t_s * 1000.0)) & 0xFFFFFFFF


def timesync_request(ts1_ns: int) -> mavlink.MAVLink_timesync_message:
    """A TIMESYNC request: tc1 = 0, ts1 = our clock in ns (safety/timesync.py)."""
    return mavlink.MAVLink_timesync_message(0, int(ts1_ns))


def heartbeat(system_status: int = mavlink.MAV_STATE_ACTIVE) -> mavlink.MAVLink_heartbeat_message:
    """Our HEARTBEAT: an onboard controller, not an autopilot; system_status a MAV_STATE
    (companion/onboard/health.py: standby, active, critical)."""
    return mavlink.MAVLink_heartbeat_message(
        mavlink.MAV_TYPE_ONBOARD_CONTROLLER, mavlink.MAV_AUTOPILOT_INVALID, 0, 0,
        system_status, 3)


def sys_status(enabled: bool, healthy: bool) -> mavlink.MAVLink_sys_status_message:
    """Our SYS_STATUS: only MAV_SYS_STATUS_OBSTACLE_AVOIDANCE, present, enabled and healthy as
    companion/onboard/health.py judges; no battery (voltage UINT16_MAX, current and remaining -1)."""
    bit = mavlink.MAV_SYS_STATUS_OBSTACLE_AVOIDANCE
    return mavlink.MAVLink_sys_status_message(
        bit, bit if enabled else 0, bit if healthy else 0, 0, 0xFFFF, -1, -1, 0, 0, 0, 0, 0, 0)


def gcs_heartbeat() -> mavlink.MAVLink_heartbeat_message:
    return mavlink.MAVLink_heartbeat_message(
        mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, mavlink.MAV_STATE_ACTIVE, 3)


def set_position_target(sp: VelocitySetpoint) -> mavlink.MAVLink_set_position_target_local_ned_message:
    """SET_POSITION_TARGET_LOCAL_NED, MAV_FRAME_LOCAL_NED, velocity (vx, vy, vz) + yaw."""
    return mavlink.MAVLink_set_position_target_local_ned_message(
        ms_of(sp.t_s), sp.target_system, sp.target_component, mavlink.MAV_FRAME_LOCAL_NED,
        VELOCITY_YAW_TYPE_MASK, 0.0, 0.0, 0.0, sp.vel_north_mps, sp.vel_east_mps,
        sp.vel_down_mps, 0.0, 0.0, 0.0, sp.yaw_rad, 0.0)


_FLOAT32 = struct.Struct("<f")


def float32(value: float) -> float:
    """A float as a MAVLink float field carries it (IEEE single, round to nearest)."""
    return _FLOAT32.unpack(_FLOAT32.pack(value))[0]


def setpoint_key_of(sp: VelocitySetpoint) -> tuple:
    """``setpoint_key`` of the message ``set_position_target(sp)`` once sent and parsed, without
    packing it (replay compares thousands of them)."""
    return (ms_of(sp.t_s), sp.target_system, sp.target_component, mavlink.MAV_FRAME_LOCAL_NED,
            VELOCITY_YAW_TYPE_MASK, float32(sp.vel_north_mps), float32(sp.vel_east_mps),
            float32(sp.vel_down_mps), float32(sp.yaw_rad))


def setpoint_key(msg) -> tuple:
    """The fields of a SET_POSITION_TARGET_LOCAL_NED that define it, for comparisons (float32)."""
    return (msg.time_boot_ms, msg.target_system, msg.target_component, msg.coordinate_frame,
            msg.type_mask, msg.vx, msg.vy, msg.vz, msg.yaw)


# ODOMETRY.pose_covariance: upper triangle, row-major, of the 6x6 covariance of
# (x, y, z, roll, pitch, yaw): 21 floats. Our (north, east, yaw) rows and columns land here.
_POSE_COV_INDEX = {(0, 0): 0, (0, 1): 1, (0, 2): 5, (1, 1): 6, (1, 2): 10, (2, 2): 20}


def pose_covariance_21(cov: tuple[tuple[float, ...], ...]) -> list[float]:
    """The 21-float upper triangle from a (3,3) covariance over (north, east, yaw); NaN elsewhere
    (z, roll, pitch are not estimated)."""
    out = [math.nan] * 21
    for (i, j), k in _POSE_COV_INDEX.items():
        out[k] = float(cov[i][j])
    return out


def odometry(pose: PoseEstimate) -> mavlink.MAVLink_odometry_message:
    """ODOMETRY: the SLAM pose in MAV_FRAME_LOCAL_NED, body FRD child frame, estimator VIO.

    z, velocities and rates are not estimated: NaN, with velocity_covariance[0] = NaN (the spec's
    'unknown'). time_usec is the vehicle's time since boot.
    """
    half = 0.5 * pose.yaw_rad
    nan = math.nan
    return mavlink.MAVLink_odometry_message(
        int(round(pose.t_s * 1e6)), mavlink.MAV_FRAME_LOCAL_NED, mavlink.MAV_FRAME_BODY_FRD,
        pose.north_m, pose.east_m, nan, [math.cos(half), 0.0, 0.0, math.sin(half)],
        nan, nan, nan, nan, nan, nan, pose_covariance_21(pose.cov), [nan] * 21,
        pose.reset_counter & 0xFF, mavlink.MAV_ESTIMATOR_TYPE_VIO, max(-1, min(100, pose.quality)))


def odometry_fields(msg) -> tuple[float, float, float]:
    """(t_s, north_m, east_m) of a recorded ODOMETRY."""
    return msg.time_usec / 1e6, msg.x, msg.y


def statustext(notice: Notice) -> mavlink.MAVLink_statustext_message:
    text = notice.text[:STATUSTEXT_MAX_CHARS].encode("ascii", "replace")
    return mavlink.MAVLink_statustext_message(notice.severity, text, 0, 0)


def set_message_interval(target_system: int, target_component: int, msg_id: int,
                         rate_hz: float) -> mavlink.MAVLink_command_long_message:
    return mavlink.MAVLink_command_long_message(
        target_system, target_component, mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, 0,
        float(msg_id), 1e6 / rate_hz, 0, 0, 0, 0, 0)


def request_message(target_system: int, target_component: int,
                    msg_id: int) -> mavlink.MAVLink_command_long_message:
    """MAV_CMD_REQUEST_MESSAGE: send one message now (HOME_POSITION, GPS_GLOBAL_ORIGIN)."""
    return mavlink.MAVLink_command_long_message(
        target_system, target_component, mavlink.MAV_CMD_REQUEST_MESSAGE, 0, float(msg_id),
        0, 0, 0, 0, 0, 0)


def takeoff(target_system: int, target_component: int,
            alt_m: float) -> mavlink.MAVLink_command_long_message:
    """MAV_CMD_NAV_TAKEOFF: param7 = altitude above home in metres (ArduCopter)."""
    return mavlink.MAVLink_command_long_message(
        target_system, target_component, mavlink.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, 0, 0, 0, 0,
        float(alt_m))


def is_set_message_interval_ack(ack: CommandAck) -> bool:
    return ack.command == mavlink.MAV_CMD_SET_MESSAGE_INTERVAL


def request_data_stream(target_system: int, target_component: int, msg_id: int,
                        rate_hz: float) -> mavlink.MAVLink_request_data_stream_message:
    return mavlink.MAVLink_request_data_stream_message(
        target_system, target_component, DATA_STREAMS_FOR[msg_id], max(1, round(rate_hz)), 1)


def set_mode(target_system: int, target_component: int,
             custom_mode: int) -> mavlink.MAVLink_command_long_message:
    """MAV_CMD_DO_SET_MODE with a custom (ArduPilot) mode number."""
    return mavlink.MAVLink_command_long_message(
        target_system, target_component, mavlink.MAV_CMD_DO_SET_MODE, 0,
        mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, float(custom_mode), 0, 0, 0, 0, 0)


def arm(target_system: int, target_component: int,
        armed: bool = True) -> mavlink.MAVLink_command_long_message:
    return mavlink.MAVLink_command_long_message(
        target_system, target_component, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 0,
        1.0 if armed else 0.0, 0, 0, 0, 0, 0, 0)


def is_ack_for(ack: CommandAck, command_name: str) -> bool:
    """True if the ack answers the named command ('set_mode', 'arm' or 'takeoff')."""
    wanted = {"set_mode": mavlink.MAV_CMD_DO_SET_MODE,
              "arm": mavlink.MAV_CMD_COMPONENT_ARM_DISARM,
              "takeoff": mavlink.MAV_CMD_NAV_TAKEOFF}[command_name]
    return ack.command == wanted


def is_from_us(msg, component_id: int) -> bool:
    """A message sent by a companion with our component id (for tlog replay)."""
    return msg.get_srcComponent() == component_id and msg.get_type() != "BAD_DATA"


def message_type(msg) -> str:
    return msg.get_type()


# MAVLink 2 signing timestamps count 10 us units from 2015-01-01 00:00:00 UTC.
SIGNING_EPOCH_UNIX_S = 1420070400


def signing_timestamp(unix_s: float) -> int:
    """The signing timestamp for a Unix time (10 us units since 2015)."""
    return int(max(0.0, unix_s - SIGNING_EPOCH_UNIX_S) * 100_000)


# A stream not seen before is accepted if stamped at most a minute before our timestamp (the
# MAVLink 2 signing rule), in 10 us units.
NEW_STREAM_WINDOW = 60 * 100_000


def _enable_signing(mav: mavlink.MAVLink, key: bytes, unix_s: float, sign_outgoing: bool) -> None:
    mav.signing.secret_key = key
    mav.signing.timestamp = signing_timestamp(unix_s)
    mav.signing.sign_outgoing = sign_outgoing
    # No unsigned message is let through (ArduPilot lets RADIO_STATUS pass; we use none).
    mav.signing.allow_unsigned_callback = None
    if not sign_outgoing:
        mav.check_signature = types.MethodType(_verify_then_order, mav)


def _verify_then_order(mav: mavlink.MAVLink, msgbuf: bytearray, src_system: int,
                       src_component: int) -> bool:
    """pymavlink's check_signature in the safe order: the signature first, the timestamp after.

    pymavlink 2.4.x records the stream's timestamp before it checks the signature, so one forged
    packet stamped 2^47 made every genuine packet of that stream "old" for good. Here nothing is
    recorded unless the packet is signed with our key; then the timestamp must advance on a
    known stream (replays refused), and a new stream may start at most a minute before our
    timestamp.
    """
    signing = mav.signing
    digest = hashlib.sha256(signing.secret_key + bytes(msgbuf[:-6])).digest()[:6]
    if not hmac.compare_digest(digest, bytes(msgbuf[-6:])):
        return False
    timestamp = int.from_bytes(bytes(msgbuf[-12:-6]), "little")
    stream = (msgbuf[-13], src_system, src_component)          # (link id, system, component)
    last = signing.stream_timestamps.get(stream)
    if last is not None and timestamp <= last:
        return False
    if last is None and timestamp + NEW_STREAM_WINDOW < signing.timestamp:
        return False
    signing.stream_timestamps[stream] = timestamp
    signing.timestamp = max(signing.timestamp, timestamp)
    return True


class Encoder:
    """Packs outbound messages with our ids; MAVLink.send() advances the sequence number.

    With ``signing_key`` (32 bytes) every packet is MAVLink 2 signed, its timestamp starting at
    ``unix_s`` (now, so that a receiver that has seen recent traffic accepts the new stream).
    """

    def __init__(self, system_id: int, component_id: int, signing_key: bytes | None = None,
                 unix_s: float | None = None) -> None:
        self._mav = make_mavlink(system_id, component_id)
        self._mav.file = self
        self._last = b""
        if signing_key is not None:
            _enable_signing(self._mav, signing_key, time.time() if unix_s is None else unix_s,
                            sign_outgoing=True)

    @property
    def signing(self) -> bool:
        return self._mav.signing.sign_outgoing

    def write(self, data: bytes) -> None:        # MAVLink.send()'s file
        self._last = bytes(data)

    @property
    def system_id(self) -> int:
        return self._mav.srcSystem

    @system_id.setter
    def system_id(self, value: int) -> None:
        self._mav.srcSystem = value

    def encode(self, msg) -> bytes:
        self._mav.send(msg)
        return self._last


class Parser:
    """Bytes in, messages out. Counts packets that failed their CRC or could not be decoded.

    With ``signing_key``, only packets signed with that key are accepted; unsigned packets,
    packets signed with another key and replayed (old-timestamp) packets are refused and
    counted in ``signature_rejected``.
    """

    def __init__(self, signing_key: bytes | None = None, unix_s: float | None = None) -> None:
        self._mav = make_mavlink(0, 0)
        self.bad_packets = 0
        self.unknown_packets = 0
        self.signature_rejected = 0
        self._fixed_time = unix_s is not None
        if signing_key is not None:
            # A new stream must be stamped at most a minute before ``unix_s`` (now): a packet
            # recorded earlier cannot be replayed at us; within a stream time must advance.
            _enable_signing(self._mav, signing_key, time.time() if unix_s is None else unix_s,
                            sign_outgoing=False)

    @property
    def signing(self) -> bool:
        return self._mav.signing.secret_key is not None

    def discard_partial(self) -> None:
        """Forget a half-received packet (a new connection, or a datagram from elsewhere); the
        signing state (each stream's last timestamp) is kept."""
        self._mav.buf = bytearray()
        self._mav.buf_index = 0
        self._mav.expected_length = mavlink.HEADER_LEN_V1 + 2

    def feed(self, data: bytes) -> list:
        if self.signing and not self._fixed_time:
            # "now" moves on: a new stream must start within a minute of the present, not of
            # the daemon's start
            signing = self._mav.signing
            signing.timestamp = max(signing.timestamp, signing_timestamp(time.time()))
        try:
            msgs = self._mav.parse_buffer(data) or []
        except mavlink.MAVError:
            self.bad_packets += 1
            return []
        good = []
        for msg in msgs:
            kind = msg.get_type()
            if kind == "BAD_DATA" and "signature" in str(getattr(msg, "reason", "")).lower():
                self.signature_rejected += 1
            elif kind == "BAD_DATA":
                self.bad_packets += 1
            elif kind.startswith("UNKNOWN_"):
                self.unknown_packets += 1
            else:
                good.append(msg)
        return good

    def decode_packet(self, packet: bytes):
        """One whole packet -> message, or None (bad CRC, unknown id, malformed).

        An unknown message id is refused too: pymavlink cannot check its CRC (no CRC extra), so
        random bytes that merely frame would otherwise pass for a message.
        """
        try:
            msg = self._mav.decode(bytearray(packet))
        except Exception:   # pymavlink raises MAVError, struct.error, IndexError... on garbage
            self.bad_packets += 1
            return None
        if msg.get_type().startswith("UNKNOWN"):
            self.unknown_packets += 1
            return None
        return msg
