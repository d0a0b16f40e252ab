"""A scenario's world and the truth's vehicle, noise and camera (scenario files only).

Degrees live only in keys ending in ``_deg``; properties give radians.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from companion.config.checks import PLAUSIBLE_SPEED_MPS, require_positive, require_sigma, require_stereo_k
from companion.config.depth import CameraMountConfig, DepthConfig, check_cameras
from companion.config.loader import FieldError, require
from companion.core import shapes


def _vertical_extent(height_m: float | None, base_m: float) -> None:
    """An obstacle's vertical extent: the top at ``height_m`` above the ground (None: unbounded,
    the 2D world's infinite column), the bottom at ``base_m`` (an overhang, a bridge deck)."""
    require(math.isfinite(base_m), "base_m", base_m, "a finite height in metres")
    require(base_m >= 0.0, "base_m", base_m, "a height >= 0 m above the ground")
    if height_m is None:
        return
    require(math.isfinite(height_m), "height_m", height_m, "a finite height in metres")
    require(height_m > 0.0, "height_m", height_m, "a height > 0 m above the ground")
    require(height_m > base_m, "height_m", height_m,
            f"a top above the obstacle's base_m ({base_m:g} m)")


@dataclass(frozen=True)
class GeoOrigin:
    lat_deg: float = -35.363261
    lon_deg: float = 149.165230
    alt_m: float = 584.0

    def __post_init__(self) -> None:
        require(-90.0 <= self.lat_deg <= 90.0, "lat_deg", self.lat_deg, "a latitude in [-90, 90]")
        require(-180.0 <= self.lon_deg <= 180.0, "lon_deg", self.lon_deg,
                "a longitude in [-180, 180]")


@dataclass(frozen=True)
class StartPose:
    north_m: float
    east_m: float
    yaw_deg: float = 0.0
    alt_m: float = 10.0          # above the ground: the cruise altitude (vertical avoidance)

    def __post_init__(self) -> None:
        require(math.isfinite(self.alt_m) and self.alt_m > 0.0, "alt_m", self.alt_m,
                "an altitude > 0 m above the ground")

    @property
    def yaw_rad(self) -> float:
        return math.radians(self.yaw_deg)


@dataclass(frozen=True)
class Goal:
    north_m: float
    east_m: float
    radius_m: float = 2.0

    def __post_init__(self) -> None:
        require_positive("radius_m", self.radius_m)


@dataclass(frozen=True)
class Obstacle:
    id: int
    north_m: float
    east_m: float
    radius_m: float
    vel_north_mps: float = 0.0
    vel_east_mps: float = 0.0
    height_m: float | None = None    # top above the ground (None: unbounded, as in 2D)
    base_m: float = 0.0              # bottom above the ground (an overhang: a bridge deck)

    def __post_init__(self) -> None:
        require(0 <= self.id < 65535, "id", self.id, "an integer in [0, 65534] (65535 means 'no id')")
        require_positive("radius_m", self.radius_m)
        _vertical_extent(self.height_m, self.base_m)

    @property
    def moving(self) -> bool:
        return self.vel_north_mps != 0.0 or self.vel_east_mps != 0.0


@dataclass(frozen=True)
class Point:
    north_m: float
    east_m: float


def _shape_id(value: int) -> None:
    require(0 <= value < 65535, "id", value, "an integer in [0, 65534] (65535 means 'no id')")


@dataclass(frozen=True)
class Wall:
    """A wall, fence or hedge: the rectangle ``thickness_m`` thick around the segment from
    ``start`` to ``end`` (square ends). Static. Seen by a depth camera (sensor.form sectors or
    both) only: a camera reporting centres says nothing about it."""
    id: int
    start: Point
    end: Point
    thickness_m: float
    height_m: float | None = None    # as Obstacle's
    base_m: float = 0.0

    def __post_init__(self) -> None:
        _shape_id(self.id)
        require_positive("thickness_m", self.thickness_m)
        _vertical_extent(self.height_m, self.base_m)
        if math.hypot(self.end.north_m - self.start.north_m,
                      self.end.east_m - self.start.east_m) <= shapes.DEGENERATE_M:
            raise FieldError("end", "zero-length wall: end is the same point as start")

    def corners_ne(self) -> np.ndarray:
        """The wall's rectangle (4, 2), counter-clockwise (core/shapes.py)."""
        return shapes.wall_corners(np.array([self.start.north_m, self.start.east_m]),
                                   np.array([self.end.north_m, self.end.east_m]), self.thickness_m)


@dataclass(frozen=True)
class Building:
    """A building (or any convex footprint): its corners in order, either way round. Static.
    Seen by a depth camera only, as a wall is."""
    id: int
    corners: tuple[Point, ...]
    height_m: float | None = None    # as Obstacle's
    base_m: float = 0.0

    def __post_init__(self) -> None:
        _shape_id(self.id)
        _vertical_extent(self.height_m, self.base_m)
        problem = shapes.convexity_problem(self._raw())
        if problem is not None:
            raise FieldError("corners", problem)

    def _raw(self) -> np.ndarray:
        return np.array([[c.north_m, c.east_m] for c in self.corners], dtype=float).reshape(-1, 2)

    def corners_ne(self) -> np.ndarray:
        """The corners (m, 2), counter-clockwise."""
        return shapes.as_counter_clockwise(self._raw())


@dataclass(frozen=True)
class World:
    start: StartPose
    goal: Goal
    obstacles: tuple[Obstacle, ...] = ()
    origin: GeoOrigin = field(default_factory=GeoOrigin)
    walls: tuple[Wall, ...] = ()
    buildings: tuple[Building, ...] = ()

    def __post_init__(self) -> None:
        seen = set()
        for key, items in (("obstacles", self.obstacles), ("walls", self.walls),
                           ("buildings", self.buildings)):
            for i, item in enumerate(items):
                if item.id in seen:
                    raise FieldError(f"{key}[{i}].id", f"duplicate obstacle id {item.id} (ids "
                                     "are shared by obstacles, walls and buildings)")
                seen.add(item.id)
        for key, point in (("start", self.start), ("goal", self.goal)):
            for shape_key, shape in self.shapes():
                if shapes.polygon_distance_m(np.array([point.north_m, point.east_m]),
                                             shape.corners_ne())[0] <= 0.0:
                    raise FieldError(key, f"the {key} lies inside {shape_key} {shape.id}")
        for obs in self.obstacles:
            if obs.moving:
                continue
            if math.hypot(self.goal.north_m - obs.north_m, self.goal.east_m - obs.east_m) <= obs.radius_m:
                raise FieldError("goal", f"the goal lies inside obstacle {obs.id}")
            if math.hypot(self.start.north_m - obs.north_m, self.start.east_m - obs.east_m) <= obs.radius_m:
                raise FieldError("start", f"the start lies inside obstacle {obs.id}")

    def shapes(self) -> list[tuple[str, "Wall | Building"]]:
        """Every wall and building, as ('wall' | 'building', shape)."""
        return [("wall", w) for w in self.walls] + [("building", b) for b in self.buildings]


@dataclass(frozen=True)
class VehicleConfig:
    """``kind``: 'unicycle' (the paper's model: flies along its yaw) or 'multicopter' (flies the
    commanded NED velocity, turns toward the commanded yaw at max_turn_rate_deg_s on its own)."""
    speed_mps: float
    max_turn_rate_deg_s: float = 30.0
    max_accel_mps2: float = 2.5
    dt_s: float = 0.1
    kind: Literal["unicycle", "multicopter"] = "unicycle"
    # the truth vehicle's climb and sink limit; simulate's vertical avoidance is bounded by it
    # (the service's would be by safety.max_vertical_speed_mps, of the same default)
    max_vertical_speed_mps: float = 2.5
    # simulate: the truth starts at rest (hovering after take-off, as a real flight begins);
    # false: already cruising along its yaw, as the paper's runs start
    start_at_rest: bool = False

    def __post_init__(self) -> None:
        for key in ("speed_mps", "max_turn_rate_deg_s", "max_accel_mps2", "dt_s",
                    "max_vertical_speed_mps"):
            require_positive(key, getattr(self, key))
        require(self.speed_mps <= PLAUSIBLE_SPEED_MPS, "speed_mps", self.speed_mps,
                f"a multicopter speed <= {PLAUSIBLE_SPEED_MPS:g} m/s")

    @property
    def max_turn_rate_rad_s(self) -> float:
        return math.radians(self.max_turn_rate_deg_s)


@dataclass(frozen=True)
class NoiseConfig:
    """The truth's odometry noise. The unicycle: speed and heading change per sample. The
    multicopter: NED velocity per axis, yaw rate and AHRS yaw per sample, and a position with a
    GPS's error (white noise plus a first-order Gauss-Markov bias of ``position_bias_tau_s``)."""
    speed_sigma_mps: float
    heading_change_sigma_deg: float
    velocity_sigma_mps: float = 0.1           # multicopter: per NED axis, per sample
    yaw_rate_sigma_deg_s: float = 0.5
    yaw_sigma_deg: float = 2.0
    yaw_bias_sigma_deg: float = 0.0           # multicopter: the AHRS yaw's slow bias
    yaw_bias_tau_s: float = 600.0             # (Gauss-Markov), off by default
    position_sigma_m: float = 0.3             # the GPS-like position: white noise per fix ...
    position_bias_sigma_m: float = 0.5        # ... plus a slow Gauss-Markov bias
    position_bias_tau_s: float = 120.0
    # GPS outages, [start_s, duration_s] each (multicopter): no fix is fused meanwhile, and the
    # autopilot's velocity, no longer GPS-aided, carries a constant error of
    # outage_velocity_bias_mps in a random direction drawn per outage (its dead reckoning drifts).
    gps_outages_s: tuple[tuple[float, ...], ...] = ()
    outage_velocity_bias_mps: float = 0.0
    altitude_sigma_m: float = 0.1             # the reported altitude (barometer), per sample

    def gps_outage_at(self, t_s: float) -> int | None:
        """The index of the outage under way at t_s, or None (the GPS is there)."""
        for i, (start_s, duration_s) in enumerate(self.gps_outages_s):
            if start_s <= t_s < start_s + duration_s:
                return i
        return None

    def __post_init__(self) -> None:
        for i, outage in enumerate(self.gps_outages_s):
            require(len(outage) == 2 and outage[0] >= 0.0 and outage[1] > 0.0,
                    f"gps_outages_s[{i}]", list(outage), "[start_s >= 0, duration_s > 0]")
        require(self.outage_velocity_bias_mps >= 0.0, "outage_velocity_bias_mps",
                self.outage_velocity_bias_mps, "a speed >= 0")
        require_sigma("speed_sigma_mps", self.speed_sigma_mps)
        require_sigma("heading_change_sigma_deg", self.heading_change_sigma_deg)
        for key in ("velocity_sigma_mps", "yaw_rate_sigma_deg_s", "yaw_sigma_deg",
                    "yaw_bias_sigma_deg", "position_sigma_m", "position_bias_sigma_m",
                    "altitude_sigma_m"):
            require(getattr(self, key) >= 0.0, key, getattr(self, key), "a standard deviation >= 0")
        require_positive("position_bias_tau_s", self.position_bias_tau_s)
        require_positive("yaw_bias_tau_s", self.yaw_bias_tau_s)


@dataclass(frozen=True)
class SensorConfig:
    fov_deg: float
    max_range_m: float
    rate_hz: float
    range_sigma_m: float
    bearing_sigma_deg: float
    report_ids: bool = True
    miss_probability: float = 0.0
    false_alarm_rate_hz: float = 0.0
    sector_message: bool = False          # read by the stub only
    # companion simulate's camera: obstacle centres, depth sectors (nearest surface per bin,
    # sector_count bins over the view, turned into landmarks by core/perception/blobs.py), both,
    # or depth: rendered depth images (sensor.depth, one per mount of sensor.cameras)
    form: Literal["centres", "sectors", "both", "depth"] = "centres"
    sector_count: int = 72
    # A stereo camera's range error grows with the square of the range: sigma_r(r) =
    # range_sigma_m + range_sigma_k_per_m * r^2, k = disparity sigma / (focal px * baseline)
    # (config/scenarios/realistic.yaml gives a real camera's figures). 0: constant range_sigma_m.
    range_sigma_k_per_m: float = 0.0
    # The vertical field of view (Intel's D455: 58 deg): an obstacle wholly above or below it is
    # not seen; its points carry their z (the centres form: the highest and lowest seen).
    vfov_deg: float = 58.0
    sees_ground: bool = False            # returns from the floor within range (a pitched camera)
    ground_points_per_frame: int = 4     # ... this many per frame, where the view meets the floor
    # form depth: the image (config/depth.py: a D455 by default) and the cameras' mounts (none
    # given: one camera at the vehicle's centre, level, looking forward); form centres: a rig of
    # cameras of fov_deg each by yaw_deg alone (forward and both sides: copter-3cam.yaml)
    depth: DepthConfig = field(default_factory=DepthConfig)
    cameras: tuple[CameraMountConfig, ...] = ()

    def __post_init__(self) -> None:
        check_cameras(self.form, self.cameras)
        if self.form != "depth" and self.depth != DepthConfig():
            raise FieldError("depth", f"the rendered image's settings are the depth form's "
                             f"(sensor.form: depth), got form {self.form!r}")
        if self.form == "depth":
            require(self.rate_hz == self.depth.rate_hz, "rate_hz", self.rate_hz,
                    f"the depth camera's rate (sensor.depth.rate_hz = {self.depth.rate_hz:g})")
        require(0.0 < self.fov_deg <= 360.0, "fov_deg", self.fov_deg, "a field of view in (0, 360]")
        require(0.0 < self.vfov_deg < 180.0, "vfov_deg", self.vfov_deg,
                "a vertical field of view in (0, 180)")
        require(0 <= self.ground_points_per_frame <= 1000, "ground_points_per_frame",
                self.ground_points_per_frame, "an integer in [0, 1000]")
        require_positive("max_range_m", self.max_range_m)
        require_positive("rate_hz", self.rate_hz)
        require_sigma("range_sigma_m", self.range_sigma_m)
        require_stereo_k("range_sigma_k_per_m", self.range_sigma_k_per_m)
        require_sigma("bearing_sigma_deg", self.bearing_sigma_deg)
        require(0.0 <= self.miss_probability < 1.0, "miss_probability", self.miss_probability,
                "a probability in [0, 1)")
        require(self.false_alarm_rate_hz >= 0.0, "false_alarm_rate_hz", self.false_alarm_rate_hz,
                "a rate >= 0")
        require(2 <= self.sector_count <= 1000, "sector_count", self.sector_count,
                "an integer in [2, 1000]")

    @property
    def fov_rad(self) -> float:
        return math.radians(self.fov_deg)

    @property
    def vfov_rad(self) -> float:
        return math.radians(self.vfov_deg)

    @property
    def bearing_sigma_rad(self) -> float:
        return math.radians(self.bearing_sigma_deg)

    @property
    def view_yaws_deg(self) -> tuple[float, ...]:
        """The centres form's rig: each camera's yaw on the body (degrees); (0.0,) for the one
        forward camera (no sensor.cameras) and for the other forms."""
        if self.form != "centres" or not self.cameras:
            return (0.0,)
        return tuple(float(c.yaw_deg) for c in self.cameras)

    def camera_mounts(self) -> tuple:
        """form depth: each camera's CameraMount (core/perception/depth_frame.py), camera id =
        index; one level forward camera at the centre when sensor.cameras is not given."""
        return tuple(c.mount() for c in (self.cameras or (CameraMountConfig(),)))

    def range_sigma_at(self, range_m):
        """The truth camera's range sigma at ``range_m`` (a float or an array), metres."""
        return self.range_sigma_m + self.range_sigma_k_per_m * range_m ** 2
