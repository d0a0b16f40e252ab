"""Latitude/longitude <-> north/east metres near an origin (flat earth, as ArduPilot does).

ArduPilot's ``Location::get_distance_NE`` scales degrees by a constant and the longitude by the
cosine of the latitude; over the few hundred metres of a flight the error is far below a
centimetre per metre. Radius: WGS-84 equatorial, as the stub uses.
"""
from __future__ import annotations

import math

EARTH_RADIUS_M = 6378137.0


def to_north_east_m(origin_lat_deg: float, origin_lon_deg: float, lat_deg: float,
                    lon_deg: float) -> tuple[float, float]:
    """(north_m, east_m) of a point from the origin."""
    north_m = math.radians(lat_deg - origin_lat_deg) * EARTH_RADIUS_M
    east_m = (math.radians(lon_deg - origin_lon_deg) * EARTH_RADIUS_M
              * math.cos(math.radians(origin_lat_deg)))
    return north_m, east_m


def to_lat_lon_deg(origin_lat_deg: float, origin_lon_deg: float, north_m: float,
                   east_m: float) -> tuple[float, float]:
    """The inverse of to_north_east_m."""
    lat_deg = origin_lat_deg + math.degrees(north_m / EARTH_RADIUS_M)
    lon_deg = origin_lon_deg + math.degrees(
        east_m / (EARTH_RADIUS_M * math.cos(math.radians(origin_lat_deg))))
    return lat_deg, lon_deg
