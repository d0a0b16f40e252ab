"""The stereo camera: range and bearing to obstacle centres in the field of view, with noise R.

Pure: takes the TRUE pose, the obstacles at capture time and a numpy Generator; returns
detections. Body frame FRD (x forward, y right, z down); bearing theta is relative to the
heading, positive clockwise (to the right), wrapped to (-pi, pi].

In a 3D world (world.py: heights, bases or a floor-seeing camera) the camera is level at the
vehicle's true altitude and has a vertical field of view (sensor.vfov): at horizontal range r it
sees altitudes within altitude +- r tan(vfov / 2). An obstacle whose extent [base, top] does not
meet that band is not seen; a seen one is reported by its highest and lowest points in the band
(``Detection.top_down_m`` / ``bottom_down_m``, FRD depths below the camera, noisy), both at its
centre's x, y. With ``sees_ground`` the floor returns points too (``ground_points``). Heights
draw from their own random stream, so the horizontal detections are those of the 2D camera.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from . import shapes
from .world import UINT16_MAX, SensorConfig, wrap_pi

MIN_DISTANCE_M = 0.2
SECTOR_COUNT = 72


@dataclass(frozen=True)
class Detection:
    """One reported obstacle: noisy range (m) and bearing (rad) to its centre, in body FRD."""
    obstacle_id: int          # scenario id, or UINT16_MAX (ids off, or a false alarm)
    range_m: float
    bearing_rad: float
    radius_m: float           # true radius, used only for the 72-sector form; NaN for false alarms
    false_alarm: bool = False
    top_down_m: float | None = None     # 3D world: highest point seen, metres below the camera
    bottom_down_m: float | None = None  # ... and lowest (None: the 2D camera, no z)

    @property
    def x_m(self) -> float:
        return self.range_m * math.cos(self.bearing_rad)

    @property
    def y_m(self) -> float:
        return self.range_m * math.sin(self.bearing_rad)


def true_range_bearing(north_m: float, east_m: float, yaw_rad: float,
                       ob_north_m: float, ob_east_m: float) -> tuple[float, float]:
    """Range (m) to a point and its bearing relative to the heading (rad, (-pi, pi])."""
    dn = ob_north_m - north_m
    de = ob_east_m - east_m
    return math.hypot(dn, de), wrap_pi(math.atan2(de, dn) - yaw_rad)


def in_view(range_m: float, bearing_rad: float, cfg: SensorConfig) -> bool:
    """Within range and within half the view of the camera, or of any camera of a centres rig
    (sensor.cameras by yaw)."""
    if range_m > cfg.max_range_m:
        return False
    if cfg.form != "centres" or not cfg.cameras:
        return abs(bearing_rad) <= cfg.fov_rad / 2.0
    return any(abs(wrap_pi(bearing_rad - m.yaw_rad)) <= cfg.fov_rad / 2.0 for m in cfg.cameras)


@dataclass(frozen=True)
class Heights:
    """What a 3D world's camera needs besides the pose: the true altitude (m above the ground),
    each obstacle's (base_m, top_m) by id (absent: unbounded) and the heights' random stream."""
    altitude_m: float
    extents: dict
    rng: np.random.Generator


Z_SIGMA_FLOOR_M = 0.05        # a point's height error at no range (a choice)


def z_sigma_m(range_m: float, cfg: SensorConfig) -> float:
    """A point's z error: a floor plus the elevation's (sigma as the bearing's) times range."""
    return math.hypot(Z_SIGMA_FLOOR_M, range_m * cfg.bearing_sigma_rad)


def seen_band(range_m: float, base_m: float, top_m: float, altitude_m: float,
              cfg: SensorConfig) -> tuple[float, float] | None:
    """(lowest, highest) altitude of the extent [base_m, top_m] within the vertical view at
    horizontal ``range_m`` (the ground bounds it below), or None if none of it is."""
    reach = max(range_m, 0.0) * math.tan(0.5 * cfg.vfov_rad)
    high = min(top_m, altitude_m + reach)
    low = max(base_m, 0.0, altitude_m - reach)
    return None if high < low else (low, high)


def ground_points(heights: Heights, cfg: SensorConfig) -> list[tuple[float, float, float]]:
    """sensor.sees_ground: ground_points_per_frame returns from the floor, uniform over the area
    where the view meets it (horizontal range from altitude / tan(vfov / 2) to max_range_m,
    bearing within the view), as body FRD points (x_m, y_m, z_m), z the altitude (noisy)."""
    alt = heights.altitude_m
    if not cfg.sees_ground or alt <= 0.0:
        return []
    near = alt / math.tan(0.5 * cfg.vfov_rad)
    if near >= cfg.max_range_m:
        return []
    out = []
    half = min(cfg.fov_rad / 2.0, math.pi)
    for _ in range(cfg.ground_points_per_frame):
        r = math.sqrt(heights.rng.uniform(near * near, cfg.max_range_m ** 2))
        theta = heights.rng.uniform(-half, half)
        z = alt + float(heights.rng.normal(0.0, z_sigma_m(r, cfg)))
        out.append((r * math.cos(theta), r * math.sin(theta), z))
    return out


def observe(north_m: float, east_m: float, yaw_rad: float,
            obstacles: list[tuple[int, float, float, float]], cfg: SensorConfig,
            rng: np.random.Generator, heights: Heights | None = None) -> list[Detection]:
    """One camera frame from the true pose.

    obstacles: [(id, north_m, east_m, radius_m)] at capture time. Visible = true range to the
    centre <= max_range_m and |true bearing| <= fov/2. Each visible obstacle is missed with
    miss_probability; otherwise reported with range + N(0, sigma_r(r)^2), sigma_r(r) =
    range_sigma_m + range_sigma_k_per_m r^2 (a stereo camera), and bearing + N(0, bearing_sigma^2). False alarms: Poisson(false_alarm_rate_hz / rate_hz) per frame, at
    positions uniform over the area of the field-of-view sector.

    ``heights`` (a 3D world): also the vertical view; each detection carries its top and
    bottom points' depths (module docstring); false alarms are at the camera's height (z 0).
    """
    out: list[Detection] = []
    for oid, on, oe, radius in obstacles:
        r, theta = true_range_bearing(north_m, east_m, yaw_rad, on, oe)
        if not in_view(r, theta, cfg):
            continue
        depths: tuple[float | None, float | None] = (None, None)
        if heights is not None:
            base, top = heights.extents.get(oid, (0.0, math.inf))
            band = seen_band(r, base, top, heights.altitude_m, cfg)
            if band is None:
                continue                          # wholly above or below the vertical view
            sigma_z = z_sigma_m(r, cfg)
            noise = heights.rng.normal(0.0, sigma_z, 2)
            depths = (heights.altitude_m - band[1] + float(noise[0]),
                      heights.altitude_m - band[0] + float(noise[1]))
        if cfg.miss_probability > 0.0 and rng.random() < cfg.miss_probability:
            continue
        sigma_r = cfg.range_sigma_at(r)                  # stereo: grows with the range squared
        r_meas = r + rng.normal(0.0, sigma_r) if sigma_r > 0 else r
        th_meas = theta + rng.normal(0.0, cfg.bearing_sigma_rad) if cfg.bearing_sigma_rad > 0 else theta
        out.append(Detection(obstacle_id=oid if cfg.report_ids else UINT16_MAX,
                             range_m=max(0.0, r_meas), bearing_rad=wrap_pi(th_meas),
                             radius_m=radius, top_down_m=depths[0], bottom_down_m=depths[1]))
    if cfg.false_alarm_rate_hz > 0.0:
        count = int(rng.poisson(cfg.false_alarm_rate_hz / cfg.rate_hz))
        half = min(cfg.fov_rad / 2.0, math.pi)
        for _ in range(count):
            r = max(MIN_DISTANCE_M, cfg.max_range_m * math.sqrt(rng.random()))
            theta = rng.uniform(-half, half)
            out.append(Detection(obstacle_id=UINT16_MAX, range_m=r, bearing_rad=theta,
                                 radius_m=float("nan"), false_alarm=True,
                                 top_down_m=0.0 if heights is not None else None,
                                 bottom_down_m=0.0 if heights is not None else None))
    return out


def sector_distances_cm(detections: list[Detection], cfg: SensorConfig) -> tuple[list[int], float, float]:
    """The 72-sector OBSTACLE_DISTANCE form of one frame.

    Sectors of width fov/72 from -fov/2 (clockwise); the offset returned is sector 0's centre. Each holds the distance (cm) to the
    nearest obstacle surface (range to centre minus radius) over the obstacle's angular extent;
    max_distance + 1 where nothing is seen (the message's "no obstacle" value).
    Returns (distances_cm, increment_deg, angle_offset_deg).
    """
    increment_rad = cfg.fov_rad / SECTOR_COUNT
    max_cm = int(round(cfg.max_range_m * 100))
    none_cm = min(max_cm + 1, UINT16_MAX - 1)
    dist = [none_cm] * SECTOR_COUNT
    start = -cfg.fov_rad / 2.0
    for det in detections:
        radius = 0.0 if math.isnan(det.radius_m) else det.radius_m
        surface_m = max(MIN_DISTANCE_M, det.range_m - radius)
        half_width = math.asin(min(1.0, radius / det.range_m)) if det.range_m > 0 else math.pi
        lo = int(math.floor((det.bearing_rad - half_width - start) / increment_rad))
        hi = int(math.floor((det.bearing_rad + half_width - start) / increment_rad))
        for i in range(max(0, lo), min(SECTOR_COUNT - 1, hi) + 1):
            dist[i] = min(dist[i], int(round(surface_m * 100)))
    # angle_offset is the angle of element 0 itself, its centre: ArduPilot's AP_Proximity_MAV reads
    # element j at angle_offset + j * increment ("mid_angle"). The left edge here would put every
    # sector half an increment (0.625 deg at 90/72) to the left of where it was measured.
    return dist, math.degrees(increment_rad), math.degrees(start + 0.5 * increment_rad)


def ray_cast_sectors_cm(north_m: float, east_m: float, yaw_rad: float,
                        obstacles: list[tuple[int, float, float, float]], cfg: SensorConfig,
                        rng: np.random.Generator,
                        outlines: tuple = (), heights: Heights | None = None,
                        outline_extents: tuple = ()) -> tuple[list[int], float, float]:
    """The depth camera's own OBSTACLE_DISTANCE (sensor.form sectors or both): sector_count bins
    over the field of view, each the distance (cm) along the ray through the bin's centre to the
    nearest surface of a circle or of a wall's or building's outline (``outlines``, shapes.py),
    from the TRUE pose. Per bin: range + N(0, sigma_r(range)^2), missed
    with miss_probability; false alarms, Poisson(false_alarm_rate_hz / rate_hz) a frame, each in
    a random bin at a range uniform over the view's area, kept if nearer. Bins past sector_count
    are UINT16_MAX (unused). Returns (distances_cm (72), increment_deg, angle_offset_deg), the
    offset at bin 0's centre as ArduPilot reads it.

    ``heights`` (a 3D world): a surface counts only where the obstacle's extent meets the
    vertical view at that distance (circles' extents by id, outlines' in ``outline_extents``),
    the nearest obstacle within the view as a depth camera's sector holds it.
    """
    count = cfg.sector_count
    increment = cfg.fov_rad / count
    max_cm = int(round(cfg.max_range_m * 100))
    none_cm = min(max_cm + 1, UINT16_MAX - 1)
    dist = [none_cm] * count + [UINT16_MAX] * (SECTOR_COUNT - count)
    first = -cfg.fov_rad / 2.0 + increment / 2.0
    for i in range(count):
        heading = yaw_rad + first + i * increment
        ux, uy = math.cos(heading), math.sin(heading)
        nearest = math.inf
        for oid, on, oe, radius in obstacles:
            dn, de = on - north_m, oe - east_m
            along = dn * ux + de * uy
            miss_sq = dn * dn + de * de - along * along
            if along <= 0.0 or miss_sq > radius * radius:
                continue
            hit = along - math.sqrt(radius * radius - miss_sq)
            if heights is not None and seen_band(hit, *heights.extents.get(oid, (0.0, math.inf)),
                                                 heights.altitude_m, cfg) is None:
                continue
            nearest = min(nearest, hit)
        for j, outline in enumerate(outlines):
            hit = shapes.ray_distance_m(north_m, east_m, ux, uy, outline)
            if heights is not None and math.isfinite(hit) and j < len(outline_extents) and \
                    seen_band(hit, *outline_extents[j], heights.altitude_m, cfg) is None:
                continue
            nearest = min(nearest, hit)
        if nearest > cfg.max_range_m:
            continue
        if cfg.miss_probability > 0.0 and rng.random() < cfg.miss_probability:
            continue
        sigma_r = cfg.range_sigma_at(nearest)
        noisy = nearest + rng.normal(0.0, sigma_r) if sigma_r > 0 else nearest
        dist[i] = int(round(max(MIN_DISTANCE_M, noisy) * 100))
    if cfg.false_alarm_rate_hz > 0.0:
        for _ in range(int(rng.poisson(cfg.false_alarm_rate_hz / cfg.rate_hz))):
            i = int(rng.integers(count))
            r_cm = int(round(max(MIN_DISTANCE_M, cfg.max_range_m * math.sqrt(rng.random())) * 100))
            dist[i] = min(dist[i], r_cm)
    return dist, math.degrees(increment), math.degrees(first)
