"""A goal given as latitude/longitude, turned into LOCAL_NED metres. Pure: no I/O.

The conversion is ArduPilot's flat-earth one (core/flat_earth.py, Location::get_distance_NE),
from a point whose LOCAL_NED position is known: the EKF origin (GPS_GLOBAL_ORIGIN, at 0, 0) or, without it, HOME
(HOME_POSITION: latitude/longitude and its x, y). Good to centimetres over a few kilometres.
"""
from __future__ import annotations

import math

from companion.core.flat_earth import to_north_east_m

MAX_GOAL_DISTANCE_M = 100_000.0     # beyond this the flat-earth conversion is not good enough


def goal_north_east(goal_lat_deg: float, goal_lon_deg: float, ref_lat_deg: float,
                    ref_lon_deg: float, ref_north_m: float, ref_east_m: float) -> tuple[float, float]:
    """LOCAL_NED (north_m, east_m) of a latitude/longitude, from a reference point known both
    ways. Raises ValueError when the goal is too far from the reference for a flat earth."""
    north, east = to_north_east_m(ref_lat_deg, ref_lon_deg, goal_lat_deg, goal_lon_deg)
    if math.hypot(north, east) > MAX_GOAL_DISTANCE_M:
        raise ValueError(f"goal {goal_lat_deg:.7f}, {goal_lon_deg:.7f} is "
                         f"{math.hypot(north, east) / 1000:.0f} km from the vehicle's origin")
    return ref_north_m + north, ref_east_m + east
