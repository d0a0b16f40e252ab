"""A goal given as latitude/longitude, turned into LOCAL_NED metres. Pure: no I/O.

The conversion is ArduPilot's flat-earth one (Location::get_distance_NE): north = dlat x
LOCATION_SCALING_FACTOR, east = dlon x LOCATION_SCALING_FACTOR x cos(lat), from a point whose
LOCAL_NED position is known: the EKF origin (GPS_GLOBAL_ORIGIN, at 0, 0) or, without it, HOME
(HOME_POSITION: latitude/longitude and its x, y). Good to centimetres over a few kilometres.
"""
from __future__ import annotations

import math

# ArduPilot AP_Common/Location.h: metres per 1e-7 degree of latitude (RADIUS_OF_EARTH 6378100 m)
LOCATION_SCALING_FACTOR_M = 0.011131884502145034
MAX_GOAL_DISTANCE_M = 100_000.0     # beyond this the flat-earth conversion is not good enough


def goal_north_east(goal_lat_deg: float, goal_lon_deg: float, ref_lat_deg: float,
                    ref_lon_deg: float, ref_north_m: float, ref_east_m: float) -> tuple[float, float]:
    """LOCAL_NED (north_m, east_m) of a latitude/longitude, from a reference point known both
    ways. Raises ValueError when the goal is too far from the reference for a flat earth."""
    scale = LOCATION_SCALING_FACTOR_M * 1e7
    mid_lat = math.radians(0.5 * (goal_lat_deg + ref_lat_deg))
    north = (goal_lat_deg - ref_lat_deg) * scale
    dlon = (goal_lon_deg - ref_lon_deg + 180.0) % 360.0 - 180.0
    east = dlon * scale * max(math.cos(mid_lat), 0.01)
    if math.hypot(north, east) > MAX_GOAL_DISTANCE_M:
        raise ValueError(f"goal {goal_lat_deg:.7f}, {goal_lon_deg:.7f} is "
                         f"{math.hypot(north, east) / 1000:.0f} km from the vehicle's origin")
    return ref_north_m + north, ref_east_m + east
