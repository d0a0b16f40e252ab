"""Each landmark's vertical extent (its top, and its bottom where seen), beside the EKF-SLAM.

Why a small filter per landmark and not two more states per landmark in the EKF: the EKF's state
is the horizontal pose and map; heights are measured against the autopilot's altitude, which is
not in that state and whose error does not depend on the horizontal estimate, and a point's
height barely depends on the landmark's horizontal error (the elevation is measured, the range
enters as range x elevation's sine). So the joint covariance is block-diagonal to first order and
a scalar Kalman filter per bound is the same estimate; the EKF, its Jacobians, association and
every 2D flight stay as they are. A static extent has no process noise.

What one observation of an obstacle gives (the centres form: the highest and lowest points the
camera has of it, as depths below the camera, FRD z down): a top at altitude - top_down, which
is the top if it lies below the view's upper edge at that range (else only a lower bound: the
obstacle goes on out of view), and a bottom likewise at the lower edge, or the ground.

Points: a point whose height above the ground is at most ``ground_margin_m`` is the floor, never
a landmark; a point with a non-finite z is refused. Both are counted by the caller.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

EDGE_SIGMAS = 3.0          # a bound this many sigmas inside the view's edge counts as seen
EDGE_FLOOR_M = 0.3


@dataclass(frozen=True)
class ExtentParams:
    vfov_rad: float
    ground_margin_m: float
    altitude_sigma_m: float = 0.2       # the autopilot's altitude (barometer) per frame
    elevation_sigma_rad: float = 0.002  # a point's elevation error (a depth camera's pixel)


@dataclass(frozen=True)
class PointHeights:
    """One observation's heights above the ground: highest and lowest point seen, their sigma,
    and whether each is the obstacle's own bound (not clipped by the view's edge)."""
    top_m: float
    bottom_m: float
    sigma_m: float
    top_seen: bool
    bottom_seen: bool


def classify(top_down_m: float | None, bottom_down_m: float | None, range_m: float,
             altitude_m: float, params: ExtentParams, top_clipped: bool = False,
             bottom_clipped: bool = False) -> str | PointHeights | None:
    """'bad' (a non-finite z), 'ground' (its highest point at or below the ground's margin),
    None (no z: a 2D observation), else the PointHeights. ``top_clipped`` / ``bottom_clipped``:
    the camera says that bound ran out of its image (a pitched or tilted camera's edge is not
    the level view's), so it is not seen whatever the level view's edge says."""
    if top_down_m is None and bottom_down_m is None:
        return None
    if top_down_m is None or bottom_down_m is None or not (
            math.isfinite(top_down_m) and math.isfinite(bottom_down_m)
            and math.isfinite(range_m) and math.isfinite(altitude_m)):
        return "bad"
    top = altitude_m - min(top_down_m, bottom_down_m)
    bottom = altitude_m - max(top_down_m, bottom_down_m)
    if top <= params.ground_margin_m:
        return "ground"
    sigma = math.hypot(params.altitude_sigma_m, max(range_m, 0.0) * params.elevation_sigma_rad)
    reach = max(range_m, 0.0) * math.tan(0.5 * params.vfov_rad)
    edge = max(EDGE_FLOOR_M, EDGE_SIGMAS * sigma)
    top_seen = top < altitude_m + reach - edge and not top_clipped
    bottom_seen = (bottom > altitude_m - reach + edge and not bottom_clipped) \
        or bottom <= params.ground_margin_m
    return PointHeights(top, max(bottom, 0.0), sigma, top_seen, bottom_seen)


class VerticalExtent:
    """One landmark's top and bottom (metres above the ground) with their variances. Until a top
    has been seen the landmark is unbounded above (``top_m`` None), whatever the lower bound."""

    def __init__(self) -> None:
        self.top_m: float | None = None
        self.top_var_m2: float | None = None
        self.top_at_least_m = 0.0          # the highest point ever seen of it
        self.bottom_m = 0.0                # until a bottom is seen, the ground (conservative)
        self.bottom_var_m2: float | None = None
        self.sightings = 0

    def update(self, heights: PointHeights) -> None:
        self.sightings += 1
        var = heights.sigma_m ** 2
        self.top_at_least_m = max(self.top_at_least_m, heights.top_m)
        if heights.top_seen and not (self.top_m is not None and heights.top_m > self.top_m
                                     + EDGE_FLOOR_M + 3.0 * math.sqrt(self.top_var_m2 + var)):
            self.top_m, self.top_var_m2 = _fuse(self.top_m, self.top_var_m2, heights.top_m, var)
            return self._update_bottom(heights, var)
        if self.top_m is not None and heights.top_m > self.top_m + EDGE_FLOOR_M + 3.0 * math.sqrt(
                self.top_var_m2 + var):
            # a point above the estimated top, beyond its noise: that was not the top (it was
            # seen clipped or wrongly before); unbounded until a top is seen again
            self.top_m, self.top_var_m2 = (heights.top_m, var) if heights.top_seen \
                else (None, None)
        self._update_bottom(heights, var)

    def _update_bottom(self, heights: PointHeights, var: float) -> None:
        if heights.bottom_seen:
            self.bottom_m, self.bottom_var_m2 = _fuse(
                self.bottom_m if self.bottom_var_m2 is not None else None, self.bottom_var_m2,
                heights.bottom_m, var)
        elif heights.bottom_m < self.bottom_m:
            self.bottom_m, self.bottom_var_m2 = heights.bottom_m, None

    @property
    def top_sigma_m(self) -> float | None:
        return None if self.top_var_m2 is None else math.sqrt(self.top_var_m2)


VIEW_OVERLAP_M = 0.5       # a landmark is expected in view if this much of its extent is


def in_vertical_view(extent: VerticalExtent, range_m: float, altitude_m: float,
                     params: ExtentParams) -> bool:
    """Whether the camera should see some of the landmark at ``range_m`` (horizontal): its
    known extent meets the vertical view by VIEW_OVERLAP_M (a top not yet seen: unbounded)."""
    reach = max(range_m, 0.0) * math.tan(0.5 * params.vfov_rad)
    top = math.inf if extent.top_m is None else extent.top_m
    return min(top, altitude_m + reach) - max(extent.bottom_m, altitude_m - reach) \
        >= VIEW_OVERLAP_M


def _fuse(mean: float | None, var: float | None, z: float, z_var: float) -> tuple[float, float]:
    """A scalar Kalman update of a static quantity (no prior: the measurement)."""
    if mean is None or var is None:
        return z, z_var
    gain = var / (var + z_var)
    return mean + gain * (z - mean), (1.0 - gain) * var
