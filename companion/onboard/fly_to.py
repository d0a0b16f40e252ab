"""A ground station's "fly to here" (SET_POSITION_TARGET_GLOBAL_INT with a position, or
MAV_CMD_DO_REPOSITION) as the service's new goal, or refused with a reason. Pure.

Accepted only: addressed to the vehicle (its system id; component 0 or the autopilot's), with a
global position, while the vehicle is in GUIDED (ArduCopter takes SET_POSITION_TARGET_* only in
GUIDED), once the EKF origin is known (the goal becomes LOCAL_NED metres with it,
companion/onboard/goal.py), and within the configured bounds: ``max_distance_from_origin_m`` of the EKF
origin and ``max_distance_from_vehicle_m`` of the vehicle's estimated position.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from companion.mavlink import codec
from companion.mavlink.mission_codec import GoalRequest
from companion.config.service import FlyToConfig
from companion.onboard.goal import goal_north_east


@dataclass(frozen=True)
class FlyToVerdict:
    accepted: bool
    reason: str                     # why refused, or 'ok'
    north_m: float = math.nan
    east_m: float = math.nan


def judge(request: GoalRequest, vehicle: tuple[int, int], in_guided: bool,
          reference: codec.GeoReference | None, position_ne_m: tuple[float, float] | None,
          limits: FlyToConfig) -> FlyToVerdict:
    if request.target_system != vehicle[0] or request.target_component not in (0, vehicle[1]):
        return FlyToVerdict(False, "not addressed to the vehicle")
    if request.problem is not None:
        return FlyToVerdict(False, request.problem)
    if not (math.isfinite(request.lat_deg) and math.isfinite(request.lon_deg)
            and -90.0 <= request.lat_deg <= 90.0 and -180.0 <= request.lon_deg <= 180.0):
        return FlyToVerdict(False, "latitude/longitude out of range")
    if not in_guided:
        return FlyToVerdict(False, "vehicle not in GUIDED")
    if reference is None:
        return FlyToVerdict(False, "EKF origin not known yet")
    try:
        north, east = goal_north_east(request.lat_deg, request.lon_deg, reference.lat_deg,
                                      reference.lon_deg, reference.north_m, reference.east_m)
    except ValueError:
        return FlyToVerdict(False, "too far for a flat earth")
    from_origin = math.hypot(north, east)
    if from_origin > limits.max_distance_from_origin_m:
        return FlyToVerdict(False, f"{from_origin:.0f} m from origin > "
                                   f"{limits.max_distance_from_origin_m:.0f}")
    if position_ne_m is not None:
        from_vehicle = math.hypot(north - position_ne_m[0], east - position_ne_m[1])
        if from_vehicle > limits.max_distance_from_vehicle_m:
            return FlyToVerdict(False, f"{from_vehicle:.0f} m away > "
                                       f"{limits.max_distance_from_vehicle_m:.0f}")
    return FlyToVerdict(True, "ok", north, east)
