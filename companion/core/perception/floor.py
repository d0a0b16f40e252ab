"""The floor in a depth frame's level points: removed before anything is called an obstacle.

Two ways, both counted by the caller:
- by the altitude: a point whose height above the ground (the vehicle's altitude less its depth
  below the vehicle) is at most ``ground_margin_m`` is the floor (the rule of
  core/perception/vertical_extent.py, applied per point), widened by three of the point's own
  height errors (``height_sigma_m``: the stereo error along its ray, the level's error);
- by a fitted plane, when the altitude is unsure or absent (a barometer's drift, a slope): the
  floor is the densest level of points below the vehicle (a histogram of their depths: a level
  floor piles its points into one bin, a wall or a trunk spreads them), refined by least squares
  on the points near it, z = a x + b y + c, twice with a shrinking band. A fit that is too tilted
  (the points are levelled by ATTITUDE already), has too few points, or whose points lie along
  a line (a wall's horizontal stripe) is refused: then the
  altitude's rule, if there is an altitude, else nothing is removed.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

MIN_BELOW_M = 0.3            # a floor lies at least this far below the vehicle's centre
HISTOGRAM_BIN_M = 0.2
FLOOR_SIGMAS = 3.0           # a point within this many of its height errors of the floor is floor
MIN_SPREAD_M = 0.5           # the plane's points spread at least this far both ways (sigma)


@dataclass(frozen=True)
class FloorPlane:
    """z_down = a x + b y + c in the local level frame (metres); ``c`` is the height of the
    vehicle above the floor below it; ``inliers``: the points the last fit used."""
    a: float
    b: float
    c: float
    inliers: int

    def height_above_m(self, xyz_m: np.ndarray) -> np.ndarray:
        """(n,): each point's height above the plane (up positive)."""
        return self.a * xyz_m[:, 0] + self.b * xyz_m[:, 1] + self.c - xyz_m[:, 2]

    @property
    def tilt_rad(self) -> float:
        return math.atan(math.hypot(self.a, self.b))


def floor_by_altitude(xyz_m: np.ndarray, altitude_m: float, ground_margin_m: float,
                      height_sigma_m: np.ndarray | float = 0.0) -> np.ndarray:
    """(n,) bool: the points at most ``ground_margin_m`` (plus FLOOR_SIGMAS of each point's own
    height error, ``height_sigma_m``) above the ground at ``altitude_m`` below the vehicle."""
    return altitude_m - xyz_m[:, 2] <= ground_margin_m + FLOOR_SIGMAS * height_sigma_m


def fit_floor(xyz_m: np.ndarray, ground_margin_m: float, min_points: int = 50,
              max_tilt_rad: float = math.radians(10.0)) -> FloorPlane | None:
    """The floor's plane among the level points (n, 3), or None (too few points below the
    vehicle, or the best plane too tilted to be the floor)."""
    below = xyz_m[xyz_m[:, 2] >= MIN_BELOW_M]
    if len(below) < min_points:
        return None
    z = below[:, 2]
    edges = np.arange(MIN_BELOW_M, float(z.max()) + 2.0 * HISTOGRAM_BIN_M, HISTOGRAM_BIN_M)
    counts, edges = np.histogram(z, edges)
    peak = int(np.argmax(counts))
    c = 0.5 * (edges[peak] + edges[peak + 1])
    a = b = 0.0
    used = 0
    for band in (max(1.0, 2.0 * ground_margin_m), max(0.5 * ground_margin_m, 0.1)):
        near = np.abs(a * below[:, 0] + b * below[:, 1] + c - z) <= band
        used = int(near.sum())
        if used < min_points:
            return None
        xy = below[near, :2]
        spread = np.linalg.eigvalsh(np.cov(xy.T)) if used > 2 else np.zeros(2)
        if math.sqrt(max(float(spread[0]), 0.0)) < MIN_SPREAD_M:
            return None         # a line of points (a wall's stripe, a kerb) holds no plane
        design = np.column_stack((xy, np.ones(used)))
        a, b, c = (float(v) for v in np.linalg.lstsq(design, z[near], rcond=None)[0])
    plane = FloorPlane(a, b, c, used)
    return plane if plane.tilt_rad <= max_tilt_rad else None


def floor_by_plane(xyz_m: np.ndarray, plane: FloorPlane, ground_margin_m: float,
                   height_sigma_m: np.ndarray | float = 0.0) -> np.ndarray:
    """(n,) bool: the points at most ``ground_margin_m`` (plus FLOOR_SIGMAS of their height
    error) above the fitted floor."""
    return plane.height_above_m(xyz_m) <= ground_margin_m + FLOOR_SIGMAS * height_sigma_m


def height_sigma_m(xyz_m: np.ndarray, depth_m: np.ndarray, sigma_z_m: np.ndarray,
                   attitude_sigma_rad: float) -> np.ndarray:
    """(n,): each point's height error. A depth error moves a point along its pixel's ray, whose
    vertical part per metre of depth is the point's depth below the camera over its depth
    (z_down / z); a level error (ATTITUDE's roll and pitch) tilts it by its horizontal
    distance. A floor seen far and at a grazing angle is noisy in height: without this, its
    noise above the margin is a phantom wall across the view's bottom."""
    along = np.abs(xyz_m[:, 2]) / np.maximum(depth_m, 1e-6) * sigma_z_m
    tilt = np.hypot(xyz_m[:, 0], xyz_m[:, 1]) * attitude_sigma_rad
    return np.hypot(along, tilt)
