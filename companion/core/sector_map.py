"""The map as a 360-degree proximity scan: nearest mapped surface per body-frame sector. Pure.

What ArduPilot's proximity library (PRX1_TYPE = 2, AP_Proximity_MAV) reads from OBSTACLE_DISTANCE:
element i covers the bearing ``i * increment_deg`` (clockwise from the vehicle's nose, body FRD),
and it keeps the smallest distance of the elements that fall in each of its own faces. Every
mapped obstacle is a disc (its estimated centre, a configured radius); a disc fills every sector
its outline subtends, at the distance of its nearest surface point along that sector's centre
ray (or the closest point of its outline when the ray misses it).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

SECTORS = 72                    # OBSTACLE_DISTANCE.distances has 72 elements


@dataclass(frozen=True)
class SectorScan:
    """distances_m (SECTORS,): nearest surface per sector, inf where nothing is mapped within
    range; sector i is centred on bearing i * increment_rad from the nose (clockwise)."""
    distances_m: np.ndarray
    increment_rad: float


def _surface_along(bearing_rad: np.ndarray, centre_range_m: float, centre_bearing_rad: float,
                   radius_m: float) -> np.ndarray:
    """Distance along each ray (body bearings) to a disc's outline: the first crossing where the
    ray meets the disc, else the range of the disc's point nearest the ray."""
    offset = np.angle(np.exp(1j * (bearing_rad - centre_bearing_rad)))
    along = centre_range_m * np.cos(offset)                # projection of the centre on the ray
    across = centre_range_m * np.abs(np.sin(offset))       # miss distance of the ray
    hit = (across <= radius_m) & (along > 0.0)
    first = along - np.sqrt(np.maximum(radius_m ** 2 - across ** 2, 0.0))
    nearest_outline = np.maximum(centre_range_m - radius_m, 0.0)
    return np.where(hit, np.maximum(first, 0.0), nearest_outline)


def scan_map(pose: np.ndarray, centres_ne_m: np.ndarray, radius_m: float,
             max_range_m: float, sectors: int = SECTORS) -> SectorScan:
    """The scan seen from ``pose`` [north_m, east_m, yaw_rad] of discs at ``centres_ne_m`` (n, 2).

    A disc touches a sector when its outline's angular span (asin(r / range) either side of its
    centre; all sectors when the vehicle is inside it) reaches the sector's centre ray or the
    sector's half-width. Surfaces beyond ``max_range_m`` are left out (inf).
    """
    if radius_m < 0.0 or max_range_m <= 0.0:
        raise ValueError("radius_m must be >= 0 and max_range_m > 0")
    increment = 2.0 * math.pi / sectors
    rays = np.arange(sectors) * increment
    distances = np.full(sectors, np.inf)
    centres = np.asarray(centres_ne_m, dtype=float).reshape(-1, 2)
    for north_m, east_m in centres:
        dn, de = north_m - pose[0], east_m - pose[1]
        rng = math.hypot(dn, de)
        if not math.isfinite(rng) or rng - radius_m > max_range_m:
            continue
        bearing = math.atan2(de, dn) - pose[2]
        half_span = math.pi if rng <= radius_m else math.asin(radius_m / rng)
        offset = np.abs(np.angle(np.exp(1j * (rays - bearing))))
        touched = offset <= half_span + 0.5 * increment
        surface = _surface_along(rays, rng, bearing, radius_m)
        distances = np.where(touched, np.minimum(distances, surface), distances)
    distances = np.where(distances <= max_range_m, distances, np.inf)
    return SectorScan(distances, increment)
