"""The obstacle messages both ways: OBSTACLE_DISTANCE_3D and OBSTACLE_DISTANCE.

Inbound, the camera's reports (BODY_FRD) become :class:`ObstacleFrame` events (one observation per
3D point, one per valid sector); outbound, the mapped obstacles go to the autopilot as sectors
(AP_Proximity_MAV) and tracked movers to the ground station as LOCAL_NED points. Frames: body FRD
(x forward, y right; bearing = atan2(y, x), positive to the right).
"""
from __future__ import annotations

import functools
import math
from dataclasses import dataclass

from companion.core.estimation.slam_types import Observation
from companion.mavlink.dialect import mavlink
from companion.mavlink.events import ObstacleFrame
from companion.mavlink.outbound import ms_of

NO_OBSTACLE_ID = 65535                                                # UINT16_MAX: "no id"


# ------------------------------------------------------------------ inbound
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


# ------------------------------------------------------------------ outbound
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
