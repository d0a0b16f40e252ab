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


def _surface_along(offset_rad: np.ndarray, centre_range_m: np.ndarray,
                   radius_m: float) -> np.ndarray:
    """Distance along each ray to each disc's outline, (n, sectors): the first crossing where the
    ray meets the disc, else the range of the disc's point nearest the ray. ``offset_rad``
    (n, sectors): ray bearing less the disc centre's bearing; ``centre_range_m`` (n, 1)."""
    along = centre_range_m * np.cos(offset_rad)            # projection of the centre on the ray
    across = centre_range_m * np.abs(np.sin(offset_rad))   # miss distance of the ray
    hit = (across <= radius_m) & (along > 0.0)
    first = along - np.sqrt(np.maximum(radius_m ** 2 - across ** 2, 0.0))
    nearest_outline = np.maximum(centre_range_m - radius_m, 0.0)
    return np.where(hit, np.maximum(first, 0.0), nearest_outline)


def scan_map(pose: np.ndarray, centres_ne_m: np.ndarray, radius_m: float,
             max_range_m: float, sectors: int = SECTORS) -> SectorScan:
    """The scan seen from ``pose`` [north_m, east_m, yaw_rad] of discs at ``centres_ne_m`` (n, 2).

    A disc touches a sector when its outline's angular span (asin(r / range) either side of its
    centre; all sectors when the vehicle is inside it) reaches the sector's centre ray or the
    sector's half-width. Surfaces beyond ``max_range_m`` are left out (inf). O(n x sectors).
    """
    if radius_m < 0.0 or max_range_m <= 0.0:
        raise ValueError("radius_m must be >= 0 and max_range_m > 0")
    increment = 2.0 * math.pi / sectors
    rays = np.arange(sectors) * increment
    centres = np.asarray(centres_ne_m, dtype=float).reshape(-1, 2)
    d_ne = centres - np.asarray(pose[:2], dtype=float)
    rng = np.hypot(d_ne[:, 0], d_ne[:, 1])
    keep = np.isfinite(rng) & (rng - radius_m <= max_range_m)
    d_ne, rng = d_ne[keep], rng[keep]
    if rng.size == 0:
        return SectorScan(np.full(sectors, np.inf), increment)
    bearing = np.arctan2(d_ne[:, 1], d_ne[:, 0]) - pose[2]
    inside = rng <= radius_m
    half_span = np.where(inside, math.pi,
                         np.arcsin(np.minimum(radius_m / np.maximum(rng, 1e-12), 1.0)))
    offset = np.angle(np.exp(1j * (rays[None, :] - bearing[:, None])))
    touched = np.abs(offset) <= half_span[:, None] + 0.5 * increment
    surface = np.where(touched, _surface_along(offset, rng[:, None], radius_m), np.inf)
    distances = surface.min(axis=0)
    distances = np.where(distances <= max_range_m, distances, np.inf)
    return SectorScan(distances, increment)
