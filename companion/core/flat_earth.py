"""Latitude/longitude <-> north/east metres near a reference point: ArduPilot's flat earth.

ArduPilot's ``Location::get_distance_NE`` (AP_Common/Location.cpp): north = dlat x
LOCATION_SCALING_FACTOR, east = dlon x LOCATION_SCALING_FACTOR x longitude_scale, the longitude
scale being the cosine of the two points' mean latitude (at least 0.01) and dlon wrapped to
[-180, 180) degrees; ``Location::offset`` is its inverse. LOCATION_SCALING_FACTOR is metres per
1e-7 degree, from ArduPilot's RADIUS_OF_EARTH (6378100 m). The one conversion of the package:
the service's latitude/longitude goals (onboard/goal.py) and the ArduPilot SITL demo's home and
truth (tools/) both use it. Good to centimetres over a few kilometres.
"""
from __future__ import annotations

import math

# ArduPilot AP_Common/Location.h: metres per 1e-7 degree of latitude (RADIUS_OF_EARTH 6378100 m)
LOCATION_SCALING_FACTOR_M = 0.011131884502145034
MIN_LONGITUDE_SCALE = 0.01      # ArduPilot's longitude_scale floor (near the poles)


def to_north_east_m(origin_lat_deg: float, origin_lon_deg: float, lat_deg: float,
                    lon_deg: float) -> tuple[float, float]:
    """(north_m, east_m) of a point from the origin (Location::get_distance_NE)."""
    scale = LOCATION_SCALING_FACTOR_M * 1e7
    mid_lat = math.radians(0.5 * (lat_deg + origin_lat_deg))
    north = (lat_deg - origin_lat_deg) * scale
    dlon = (lon_deg - origin_lon_deg + 180.0) % 360.0 - 180.0
    east = dlon * scale * max(math.cos(mid_lat), MIN_LONGITUDE_SCALE)
    return north, east


def to_lat_lon_deg(origin_lat_deg: float, origin_lon_deg: float, north_m: float,
                   east_m: float) -> tuple[float, float]:
    """The point ``north_m``, ``east_m`` from the origin (Location::offset): the inverse of
    to_north_east_m, the longitude scale taken at the mean latitude as there."""
    scale = LOCATION_SCALING_FACTOR_M * 1e7
    dlat = north_m / scale
    mid_lat = math.radians(origin_lat_deg + 0.5 * dlat)
    dlon = east_m / (scale * max(math.cos(mid_lat), MIN_LONGITUDE_SCALE))
    return origin_lat_deg + dlat, (origin_lon_deg + dlon + 180.0) % 360.0 - 180.0
