"""Typed configuration: scenario files (the world) and the service's own settings.

``load_scenario(path)`` and ``load_config(path)`` are the only places YAML becomes config objects.
Degrees live only in keys ending in ``_deg``; properties give radians.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Literal

import numpy as np

from companion.config.loader import FieldError, build, read_yaml, require
from companion.core import shapes
from companion.core.estimation.consistency import MonitorParams
from companion.core.estimation.slam_types import AssociationGates, SlamNoise, VelocityNoise
from companion.core.avoidance.guidance import GuidanceParams
from companion.core.estimation.movers import MoverParams
from companion.core.estimator_options import EstimatorOptions
from companion.core.estimation.lifecycle import LifecycleParams
from companion.core.avoidance.arc import VehicleLimits
from companion.core.avoidance.look_at import GoalLookParams, LookAtParams
from companion.core.avoidance.union import UnionParams
from companion.errors import ConfigError
from companion.onboard.flight_phase import FlightPhaseParams


PLAUSIBLE_SPEED_MPS = 50.0
PLAUSIBLE_ACCEL_MPS2 = 20.0      # 2 g sideways: far beyond any multicopter's ANGLE_MAX
PLAUSIBLE_DELAY_S = 10.0
UNICYCLE_AS_COPTER_YAW_SIGMA_DEG = 0.5   # Scenario.estimator_config(flown_as='multicopter')       # faster is no multicopter (the pipeline refuses such odometry)


def _positive(key: str, value: float) -> None:
    require(value > 0.0, key, value, "a value > 0")


def _sigma(key: str, value: float) -> None:
    require(value > 0.0, key, value,
            "a standard deviation > 0 (the covariance must be positive definite)")


MAX_STEREO_K_PER_M = 1.0     # sigma_r = k r^2: at k = 1 /m the range is noise beyond 1 m


def _stereo_k(key: str, value: float) -> None:
    require(0.0 <= value <= MAX_STEREO_K_PER_M, key, value,
            f"a coefficient in [0, {MAX_STEREO_K_PER_M}] per metre (sigma_r = k r^2; a stereo "
            "camera's k = disparity sigma px / (focal length px x baseline m), about 0.0015)")


# ------------------------------------------------------------------ world
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

    @property
    def yaw_rad(self) -> float:
        return math.radians(self.yaw_deg)


@dataclass(frozen=True)
class Goal:
    north_m: float
    east_m: float
    radius_m: float = 2.0

    def __post_init__(self) -> None:
        _positive("radius_m", self.radius_m)


@dataclass(frozen=True)
class Obstacle:
    id: int
    north_m: float
    east_m: float
    radius_m: float
    vel_north_mps: float = 0.0
    vel_east_mps: float = 0.0

    def __post_init__(self) -> None:
        require(0 <= self.id < 65535, "id", self.id, "an integer in [0, 65534] (65535 means 'no id')")
        _positive("radius_m", self.radius_m)

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

    def __post_init__(self) -> None:
        _shape_id(self.id)
        _positive("thickness_m", self.thickness_m)
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

    def __post_init__(self) -> None:
        _shape_id(self.id)
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

    def __post_init__(self) -> None:
        for key in ("speed_mps", "max_turn_rate_deg_s", "max_accel_mps2", "dt_s"):
            _positive(key, getattr(self, key))
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

    def __post_init__(self) -> None:
        _sigma("speed_sigma_mps", self.speed_sigma_mps)
        _sigma("heading_change_sigma_deg", self.heading_change_sigma_deg)
        for key in ("velocity_sigma_mps", "yaw_rate_sigma_deg_s", "yaw_sigma_deg",
                    "yaw_bias_sigma_deg", "position_sigma_m", "position_bias_sigma_m"):
            require(getattr(self, key) >= 0.0, key, getattr(self, key), "a standard deviation >= 0")
        _positive("position_bias_tau_s", self.position_bias_tau_s)
        _positive("yaw_bias_tau_s", self.yaw_bias_tau_s)


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
    # sector_count bins over the view, turned into landmarks by core/perception/blobs.py), or both
    form: Literal["centres", "sectors", "both"] = "centres"
    sector_count: int = 72
    # A stereo camera's range error grows with the square of the range: sigma_r(r) =
    # range_sigma_m + range_sigma_k_per_m * r^2, k = disparity sigma / (focal px * baseline)
    # (config/scenarios/realistic.yaml gives a real camera's figures). 0: constant range_sigma_m.
    range_sigma_k_per_m: float = 0.0

    def __post_init__(self) -> None:
        require(0.0 < self.fov_deg <= 360.0, "fov_deg", self.fov_deg, "a field of view in (0, 360]")
        _positive("max_range_m", self.max_range_m)
        _positive("rate_hz", self.rate_hz)
        _sigma("range_sigma_m", self.range_sigma_m)
        _stereo_k("range_sigma_k_per_m", self.range_sigma_k_per_m)
        _sigma("bearing_sigma_deg", self.bearing_sigma_deg)
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
    def bearing_sigma_rad(self) -> float:
        return math.radians(self.bearing_sigma_deg)

    def range_sigma_at(self, range_m):
        """The truth camera's range sigma at ``range_m`` (a float or an array), metres."""
        return self.range_sigma_m + self.range_sigma_k_per_m * range_m ** 2


# ------------------------------------------------------------- companion
@dataclass(frozen=True)
class AvoidanceConfig:
    safety_distance_m: float
    horizon_s: float
    eta: float
    strategy: Literal["cone", "union", "apf"] = "union"
    mission_time_s: float | None = None
    inflation_sigmas: float = 0.0
    approach_decel_mps2: float = 1.0
    apf_attraction_gain: float = 1.0
    apf_repulsion_gain: float = 3e5
    apf_influence_m: float = 20.0
    lookahead_s: float = 6.0              # union: cones count within speed * lookahead
    hysteresis: float = 0.5               # union: weight of turning away from the last choice
    camera_fov_deg: float | None = None   # union: turn in place beyond it (None: the sensor's, or 90)
    gap_margin_m: float | None = None     # union in simulate: fly gaps whose circles leave this (None: never)
    look_at_threats: bool = False         # a multicopter's nose toward a tracked mover out of view
                                          # (core/avoidance/look_at.py); the velocity stays the choice's
    flank_scan_deg: float | None = None   # union with limits: swing the heading to look this far
                                          # beyond the view's edges (core/avoidance/flank_scan.py; None: off)
    flank_scan_period_s: float = 4.0      # ... each flank once within this
    goal_look_deg: float | None = None    # a multicopter's nose turns toward the goal's direction
                                          # when the velocity swerves, at most this far from the
                                          # flight direction (< half the camera's view;
                                          # core/avoidance/look_at.py goal_look_yaw; None: off)
    goal_look_gain: float = 1.0           # ... by this times the swerve

    def __post_init__(self) -> None:
        _positive("safety_distance_m", self.safety_distance_m)
        _positive("lookahead_s", self.lookahead_s)
        require(self.hysteresis >= 0.0, "hysteresis", self.hysteresis, "a weight >= 0")
        if self.gap_margin_m is not None:
            require(self.gap_margin_m >= 0.0, "gap_margin_m", self.gap_margin_m, "a margin >= 0 m")
        if self.flank_scan_deg is not None:
            require(0.0 < self.flank_scan_deg < 90.0, "flank_scan_deg", self.flank_scan_deg,
                    "an angle in (0, 90) degrees")
        _positive("flank_scan_period_s", self.flank_scan_period_s)
        if self.goal_look_deg is not None:
            require(0.0 < self.goal_look_deg < 180.0, "goal_look_deg", self.goal_look_deg,
                    "an angle in (0, 180) degrees, less than half the camera's field of view")
        require(0.0 < self.goal_look_gain <= 10.0, "goal_look_gain", self.goal_look_gain,
                "a gain in (0, 10]")
        if self.camera_fov_deg is not None:
            require(0.0 < self.camera_fov_deg <= 360.0, "camera_fov_deg", self.camera_fov_deg,
                    "a field of view in (0, 360]")
        _positive("horizon_s", self.horizon_s)
        require(self.eta >= 1.0, "eta", self.eta, "a safety factor >= 1")
        if self.mission_time_s is not None:
            _positive("mission_time_s", self.mission_time_s)
        require(self.inflation_sigmas >= 0.0, "inflation_sigmas", self.inflation_sigmas, "a value >= 0")
        for key in ("approach_decel_mps2", "apf_attraction_gain", "apf_repulsion_gain",
                    "apf_influence_m"):
            _positive(key, getattr(self, key))

    def union_params(self, sensor_fov_rad: float = math.radians(90.0)) -> UnionParams:
        fov = math.radians(self.camera_fov_deg) if self.camera_fov_deg is not None else sensor_fov_rad
        return UnionParams(lookahead_s=self.lookahead_s, hysteresis=self.hysteresis, fov_rad=fov,
                           gap_margin_m=self.gap_margin_m,
                           flank_scan_rad=None if self.flank_scan_deg is None
                           else math.radians(self.flank_scan_deg),
                           flank_scan_period_s=self.flank_scan_period_s)

    def goal_look_params(self, fov_rad: float) -> GoalLookParams | None:
        """avoidance.goal_look_deg with the camera's field of view (None: off). The nose stays
        within half the view of the flight direction, so the flight direction stays in view."""
        if self.goal_look_deg is None:
            return None
        half_deg = 0.5 * math.degrees(fov_rad)
        if not self.goal_look_deg < half_deg:
            raise FieldError("avoidance.goal_look_deg", f"expected less than half the camera's "
                             f"field of view ({half_deg:g} degrees) so the flight direction stays "
                             f"in view, got {self.goal_look_deg!r}")
        return GoalLookParams(math.radians(self.goal_look_deg), self.goal_look_gain)

    def guidance_params(self, cruise_speed_mps: float, goal_radius_m: float) -> GuidanceParams:
        return GuidanceParams(
            cruise_speed_mps=cruise_speed_mps, safety_distance_m=self.safety_distance_m,
            horizon_s=self.horizon_s, eta=self.eta, goal_radius_m=goal_radius_m,
            mission_time_s=self.mission_time_s, inflation_sigmas=self.inflation_sigmas,
            approach_decel_mps2=self.approach_decel_mps2,
            apf_attraction_gain=self.apf_attraction_gain,
            apf_repulsion_gain=self.apf_repulsion_gain, apf_influence_m=self.apf_influence_m)


@dataclass(frozen=True)
class EstimatorConfig:
    """Q, R and association gates of the EKF-SLAM (what the filter assumes, not the truth),
    its motion model, position fusion, consistency monitor, arrival rule and mover test.

    motion_model 'paper': speed_sigma_mps and heading_change_sigma_deg are Q. 'velocity_ned'
    (the multicopter): vel_north/east_sigma_mps, yaw_rate_sigma_deg_s per odometry sample, and
    the autopilot's yaw measured with yaw_sigma_deg.
    position_fusion 'auto': fuse LOCAL_POSITION_NED x, y while the autopilot reports a healthy
    horizontal position (EKF_STATUS_REPORT, GPS_RAW_INT fix_type >= min_fix_type, HDOP <=
    max_hdop); 'on': always; 'off': GPS-denied SLAM (the paper). Sigma: position_sigma_m if set,
    else GPS_RAW_INT h_acc, else HDOP x position_sigma_per_hdop_m.
    """
    range_sigma_m: float
    bearing_sigma_deg: float
    # The filter's range model: sigma_r = range_sigma_m + range_sigma_k_per_m * r^2 (the floor and
    # the stereo k, core/estimation/range_noise.py), apart from the truth's sensor keys. 0: constant.
    range_sigma_k_per_m: float = 0.0
    speed_sigma_mps: float = 0.3
    heading_change_sigma_deg: float = 0.02
    reference_dt_s: float = 0.1
    accept_nis: float = AssociationGates().accept_nis
    new_landmark_nis: float = AssociationGates().new_landmark_nis
    outlier_nis: float = AssociationGates().outlier_nis
    initial_position_sigma_m: float = 0.001
    initial_yaw_sigma_deg: float = 0.001
    motion_model: Literal["paper", "velocity_ned"] = "velocity_ned"
    vel_north_sigma_mps: float = 0.1
    vel_east_sigma_mps: float = 0.1
    yaw_rate_sigma_deg_s: float = 0.86             # EKF3 EK3_GYRO_P_NSE = 0.015 rad/s
    yaw_sigma_deg: float = 2.0
    # The autopilot's yaw error beyond the white yaw_sigma_deg: a bias correlated over
    # yaw_bias_tau_s (a compass's), so its samples are fused as far from independent
    # (EstimatorOptions.yaw_fix_sigma_rad). 0: white noise only.
    yaw_bias_sigma_deg: float = 0.0
    yaw_bias_tau_s: float = 600.0
    position_fusion: Literal["auto", "on", "off"] = "auto"
    position_sigma_m: float | None = 4.4          # null: from GPS_RAW_INT h_acc or HDOP
    position_sigma_per_hdop_m: float = 1.0
    position_period_s: float = 1.0
    max_hdop: float = 2.0
    min_fix_type: int = 3
    position_timeout_s: float = 2.0        # GPS_RAW_INT / EKF_STATUS_REPORT older: not healthy
    established_sightings: int = 5
    arrival_tolerance_m: float = 2.0        # pose 2-sigma radius allowed at arrival
    monitor_window_s: float = 10.0
    monitor_nis_probability: float = 0.9999
    monitor_lost_after_s: float = 10.0
    degraded_radius_m: float = 5.0          # pose 2-sigma radius
    lost_radius_m: float = 20.0
    degraded_reaction: Literal["none", "slow", "hold"] = "slow"
    lost_reaction: Literal["none", "slow", "hold"] = "hold"
    slow_factor: float = 0.5
    mover_probation_s: float = MoverParams().probation_s
    mover_min_span_s: float = MoverParams().min_span_s
    mover_speed_threshold_mps: float = MoverParams().speed_threshold_mps
    mover_speed_sigmas: float = MoverParams().speed_sigmas
    mover_strikes: int = MoverParams().strikes_to_mover
    mover_young_min_sightings: int = MoverParams().young_min_sightings
    # Landmark lifecycle (core/estimation/lifecycle.py gives the reasons for the defaults): confirmed after
    # confirm_hits detections in its first confirm_window chances, deleted after delete_misses
    # chances in a row unseen. A chance needs the camera's view: sensor_fov_deg and
    # sensor_max_range_m (a scenario fills them from its sensor; null: no deletion).
    confirm_hits: int = LifecycleParams().confirm_hits
    confirm_window: int = LifecycleParams().confirm_window
    delete_misses: int = LifecycleParams().delete_misses
    tentative_timeout_s: float = LifecycleParams().tentative_timeout_s
    tentative_in_guidance: bool = LifecycleParams().tentative_in_guidance
    sensor_fov_deg: float | None = None
    sensor_max_range_m: float | None = None

    def __post_init__(self) -> None:
        for key in ("speed_sigma_mps", "heading_change_sigma_deg", "range_sigma_m",
                    "bearing_sigma_deg", "initial_position_sigma_m", "initial_yaw_sigma_deg",
                    "vel_north_sigma_mps", "vel_east_sigma_mps", "yaw_rate_sigma_deg_s",
                    "yaw_sigma_deg", "position_sigma_per_hdop_m"):
            _sigma(key, getattr(self, key))
        require(self.yaw_bias_sigma_deg >= 0.0, "yaw_bias_sigma_deg", self.yaw_bias_sigma_deg,
                "a standard deviation >= 0 (0: no bias)")
        if self.position_sigma_m is not None:
            _sigma("position_sigma_m", self.position_sigma_m)
        for key in ("reference_dt_s", "position_period_s", "max_hdop", "position_timeout_s",
                    "yaw_bias_tau_s",
                    "arrival_tolerance_m", "monitor_window_s", "monitor_lost_after_s",
                    "degraded_radius_m", "mover_min_span_s", "mover_speed_sigmas"):
            _positive(key, getattr(self, key))
        _positive("accept_nis", self.accept_nis)
        require(self.new_landmark_nis >= self.accept_nis, "new_landmark_nis", self.new_landmark_nis,
                f"a gate >= accept_nis ({self.accept_nis})")
        _positive("outlier_nis", self.outlier_nis)
        require(0 <= self.min_fix_type <= 8, "min_fix_type", self.min_fix_type,
                "a GPS_FIX_TYPE in [0, 8] (3: 3D fix)")
        require(self.established_sightings >= 1, "established_sightings",
                self.established_sightings, "an integer >= 1")
        require(0.0 < self.monitor_nis_probability < 1.0, "monitor_nis_probability",
                self.monitor_nis_probability, "a probability in (0, 1)")
        require(self.lost_radius_m >= self.degraded_radius_m, "lost_radius_m", self.lost_radius_m,
                f"a radius >= degraded_radius_m ({self.degraded_radius_m})")
        require(0.0 < self.slow_factor <= 1.0, "slow_factor", self.slow_factor,
                "a factor in (0, 1]")
        require(self.mover_probation_s >= 0.0, "mover_probation_s", self.mover_probation_s,
                "a duration >= 0")
        require(self.mover_speed_threshold_mps >= 0.0, "mover_speed_threshold_mps",
                self.mover_speed_threshold_mps, "a speed >= 0")
        require(self.mover_strikes >= 1, "mover_strikes", self.mover_strikes, "an integer >= 1")
        require(self.mover_young_min_sightings >= 2, "mover_young_min_sightings",
                self.mover_young_min_sightings, "an integer >= 2 (a velocity needs two points)")
        require(self.confirm_hits >= 1, "confirm_hits", self.confirm_hits, "an integer >= 1")
        require(self.confirm_window >= self.confirm_hits, "confirm_window", self.confirm_window,
                f"an integer >= confirm_hits ({self.confirm_hits})")
        require(self.delete_misses >= 1, "delete_misses", self.delete_misses, "an integer >= 1")
        _positive("tentative_timeout_s", self.tentative_timeout_s)
        if self.sensor_fov_deg is not None:
            require(0.0 < self.sensor_fov_deg <= 360.0, "sensor_fov_deg", self.sensor_fov_deg,
                    "a field of view in (0, 360] or null")
        if self.sensor_max_range_m is not None:
            _positive("sensor_max_range_m", self.sensor_max_range_m)
        _stereo_k("range_sigma_k_per_m", self.range_sigma_k_per_m)

    def lifecycle_params(self) -> LifecycleParams:
        fov = None if self.sensor_fov_deg is None else math.radians(self.sensor_fov_deg)
        return LifecycleParams(confirm_hits=self.confirm_hits, confirm_window=self.confirm_window,
                               delete_misses=self.delete_misses,
                               tentative_timeout_s=self.tentative_timeout_s, fov_rad=fov,
                               max_range_m=self.sensor_max_range_m,
                               tentative_in_guidance=self.tentative_in_guidance)

    def velocity_noise(self) -> VelocityNoise:
        return VelocityNoise(self.vel_north_sigma_mps, self.vel_east_sigma_mps,
                             math.radians(self.yaw_rate_sigma_deg_s))

    def options(self) -> EstimatorOptions:
        return EstimatorOptions(
            motion_model=self.motion_model, velocity_noise=self.velocity_noise(),
            yaw_sigma_rad=math.radians(self.yaw_sigma_deg), position_period_s=self.position_period_s,
            established_sightings=self.established_sightings,
            arrival_tolerance_m=self.arrival_tolerance_m,
            monitor=MonitorParams(window_s=self.monitor_window_s,
                                  nis_probability=self.monitor_nis_probability,
                                  lost_after_s=self.monitor_lost_after_s,
                                  degraded_radius_m=self.degraded_radius_m,
                                  lost_radius_m=self.lost_radius_m),
            degraded_reaction=self.degraded_reaction, lost_reaction=self.lost_reaction,
            slow_factor=self.slow_factor, lifecycle=self.lifecycle_params(),
            range_sigma_k_per_m=self.range_sigma_k_per_m,
            yaw_bias_sigma_rad=math.radians(self.yaw_bias_sigma_deg),
            yaw_bias_tau_s=self.yaw_bias_tau_s)

    def mover_params(self) -> MoverParams:
        return MoverParams(strikes_to_mover=self.mover_strikes, probation_s=self.mover_probation_s,
                           min_span_s=self.mover_min_span_s,
                           speed_threshold_mps=self.mover_speed_threshold_mps,
                           speed_sigmas=self.mover_speed_sigmas,
                           young_min_sightings=self.mover_young_min_sightings)

    def slam_noise(self) -> SlamNoise:
        return SlamNoise(self.speed_sigma_mps, math.radians(self.heading_change_sigma_deg),
                         self.reference_dt_s, self.range_sigma_m,
                         math.radians(self.bearing_sigma_deg))

    def gates(self) -> AssociationGates:
        return AssociationGates(self.accept_nis, self.new_landmark_nis, self.outlier_nis)


@dataclass(frozen=True)
class MissionConfig:
    max_time_s: float = 300.0

    def __post_init__(self) -> None:
        _positive("max_time_s", self.max_time_s)


@dataclass(frozen=True)
class Scenario:
    name: str
    world: World
    vehicle: VehicleConfig
    noise: NoiseConfig
    sensor: SensorConfig
    avoidance: AvoidanceConfig
    mission: MissionConfig = field(default_factory=MissionConfig)
    estimator: EstimatorConfig | None = None

    def __post_init__(self) -> None:
        goal = self.world.goal
        for i, obs in enumerate(self.world.obstacles):
            if obs.moving:
                continue
            gap = math.hypot(goal.north_m - obs.north_m, goal.east_m - obs.east_m)
            if gap <= self.avoidance.safety_distance_m:
                raise FieldError("world.goal", f"the goal lies within the safety distance "
                                 f"({self.avoidance.safety_distance_m} m) of obstacle {obs.id}: "
                                 "no safe path can end there")
        goal_ne = np.array([goal.north_m, goal.east_m])
        for kind, shape in self.world.shapes():
            if shapes.polygon_distance_m(goal_ne, shape.corners_ne())[0] <= \
                    self.avoidance.safety_distance_m:
                raise FieldError("world.goal", f"the goal lies within the safety distance "
                                 f"({self.avoidance.safety_distance_m} m) of {kind} {shape.id}'s "
                                 "surface: no safe path can end there")
        if self.avoidance.goal_look_deg is not None:
            if self.vehicle.kind != "multicopter":
                raise FieldError("avoidance.goal_look_deg", "a multicopter's only (a unicycle's "
                                 "camera looks where it flies: see flank_scan_deg)")
            self.goal_look_params()
        if self.world.shapes() and self.sensor.form == "centres":
            raise FieldError("sensor.form", "centres cannot see walls or buildings (a camera "
                             "reporting centres says nothing about them): use sectors or both")

    def estimator_config(self, flown_as: str | None = None) -> EstimatorConfig:
        """The filter's settings: the scenario's own, else matched to its vehicle, noise and
        sensor (the unicycle gets the paper's model, the multicopter the velocity model).

        ``flown_as='multicopter'``: the vehicle that flies the scenario is a multicopter whatever
        ``vehicle.kind`` says (sitl-stub and ArduCopter fly GUIDED's velocity with their own
        yaw, take off and hover): the velocity model, its per-axis sigma covering a unicycle
        scenario's speed noise (the stub puts it along the heading, forward when hovering)."""
        if self.estimator is not None:
            return self.estimator
        noise = self.noise
        copter = self.vehicle.kind == "multicopter" or flown_as == "multicopter"
        if self.vehicle.kind == "multicopter":
            velocity_sigma_mps, yaw_sigma_deg = noise.velocity_sigma_mps, noise.yaw_sigma_deg
        else:
            # The stub's unicycle odometry: speed noise along the heading, and a gyro-integrated
            # yaw with no compass noise, drifting 0.02 deg a sample (paper.yaml): 0.5 deg covers
            # about 600 samples of that drift (a choice).
            velocity_sigma_mps = math.hypot(noise.velocity_sigma_mps, noise.speed_sigma_mps)
            yaw_sigma_deg = UNICYCLE_AS_COPTER_YAW_SIGMA_DEG
        return EstimatorConfig(
            speed_sigma_mps=noise.speed_sigma_mps,
            heading_change_sigma_deg=noise.heading_change_sigma_deg,
            reference_dt_s=self.vehicle.dt_s, range_sigma_m=self.sensor.range_sigma_m,
            bearing_sigma_deg=self.sensor.bearing_sigma_deg,
            range_sigma_k_per_m=self.sensor.range_sigma_k_per_m,
            motion_model="velocity_ned" if copter else "paper",
            vel_north_sigma_mps=max(velocity_sigma_mps, 1e-6),
            vel_east_sigma_mps=max(velocity_sigma_mps, 1e-6),
            yaw_rate_sigma_deg_s=max(noise.yaw_rate_sigma_deg_s, 1e-6),
            yaw_sigma_deg=max(yaw_sigma_deg, 1e-6),
            yaw_bias_sigma_deg=noise.yaw_bias_sigma_deg if copter else 0.0,
            yaw_bias_tau_s=noise.yaw_bias_tau_s,
            position_fusion="auto" if copter else "off",
            sensor_fov_deg=self.sensor.fov_deg, sensor_max_range_m=self.sensor.max_range_m,
            # The unicycle's 2-sigma radius reaches 2.4 m at the end of 300 m legs (dense and
            # moving worlds, measured): 3 m keeps the paper's figures; the multicopter's 2 m.
            arrival_tolerance_m=2.0 if copter else 3.0,
            # A fix carries about period/tau of the bias's information (copter.yaml says more).
            position_sigma_m=max(math.sqrt(noise.position_sigma_m ** 2 + noise.position_bias_sigma_m
                                           ** 2 * max(1.0, noise.position_bias_tau_s
                                           / EstimatorConfig.position_period_s)),
                                 1e-3))

    def guidance_params(self) -> GuidanceParams:
        return self.avoidance.guidance_params(self.vehicle.speed_mps, self.world.goal.radius_m)

    def goal_look_params(self) -> GoalLookParams | None:
        """avoidance.goal_look_deg with the scenario's camera (the velocity choice's view)."""
        fov_rad = self.avoidance.union_params(self.sensor.fov_rad).fov_rad
        return self.avoidance.goal_look_params(fov_rad)


def load_scenario(path: str | Path) -> Scenario:
    """Read and validate a scenario file; a mistake raises ConfigError naming file and key."""
    from companion.config.paths import resolve_config
    return build(Scenario, read_yaml(resolve_config(path)), path)


__all__ = ["ConfigError", "Scenario", "load_scenario", "AvoidanceConfig", "EstimatorConfig"]


# ------------------------------------------------------ companion service
# Settings of `companion run` / `demo` / `replay` (config/companion.yaml). The estimator and
# avoidance sections reuse the dataclasses above, so a scenario's values can be dropped in.
@dataclass(frozen=True)
class LinkConfig:
    """Identities and link timing. ``None`` ids are discovered from the vehicle's heartbeat."""
    component_id: int = 191                   # MAV_COMP_ID_ONBOARD_COMPUTER
    system_id: int | None = None              # ours; None: the vehicle's
    vehicle_system_id: int | None = None      # pin the vehicle; None: first autopilot heartbeat
    vehicle_component_id: int | None = None   # None: the component of that heartbeat
    camera_component_id: int = 100            # MAV_COMP_ID_CAMERA: obstacle reports come from here
    guided_custom_mode: int = 4               # ArduCopter GUIDED
    heartbeat_rate_hz: float = 1.0
    heartbeat_timeout_s: float = 3.0          # vehicle heartbeat older than this: stop commanding
    reconnect_interval_s: float = 1.0
    inbox_size: int = 1000
    signing_key_file: str | None = None       # MAVLink 2 signing: file with the key, 64 hex chars

    def __post_init__(self) -> None:
        for key in ("component_id", "camera_component_id"):
            require(1 <= getattr(self, key) <= 255, key, getattr(self, key), "an id in [1, 255]")
        for key in ("system_id", "vehicle_system_id", "vehicle_component_id"):
            value = getattr(self, key)
            require(value is None or 1 <= value <= 255, key, value, "an id in [1, 255] or null")
        require(self.guided_custom_mode >= 0, "guided_custom_mode", self.guided_custom_mode,
                "a custom mode number >= 0")
        for key in ("heartbeat_rate_hz", "heartbeat_timeout_s", "reconnect_interval_s"):
            _positive(key, getattr(self, key))
        require(self.inbox_size >= 10, "inbox_size", self.inbox_size, "an integer >= 10")
        require(self.signing_key_file is None or self.signing_key_file.strip() != "",
                "signing_key_file", self.signing_key_file, "a file name or null")


@dataclass(frozen=True)
class StreamsConfig:
    """Telemetry the companion asks the autopilot for, and how it asks."""
    attitude_rate_hz: float = 10.0
    local_position_rate_hz: float = 10.0
    landed_state_rate_hz: float = 2.0         # EXTENDED_SYS_STATE (flight phases)
    global_position_rate_hz: float = 2.0      # GLOBAL_POSITION_INT (altitude above home)
    gps_raw_rate_hz: float = 2.0              # GPS_RAW_INT and EKF_STATUS_REPORT: is the
    ekf_status_rate_hz: float = 2.0           # autopilot's position trusted (position_fusion auto)
    ack_timeout_s: float = 1.0                # SET_MESSAGE_INTERVAL unanswered: retry, then fall back
    attempts: int = 3
    rerequest_after_s: float = 3.0            # no odometry this long after a request: ask again
    rate_check_s: float = 5.0                 # measure each stream's rate over this (link time)
    min_rate_fraction: float = 0.5            # measured below this share of the asked rate: ask again
    max_reasserts: int = 5                    # at most this many in a row while the rate stays low

    def __post_init__(self) -> None:
        for key in ("attitude_rate_hz", "local_position_rate_hz", "landed_state_rate_hz",
                    "global_position_rate_hz", "gps_raw_rate_hz", "ekf_status_rate_hz",
                    "ack_timeout_s", "rerequest_after_s", "rate_check_s"):
            _positive(key, getattr(self, key))
        require(self.attempts >= 1, "attempts", self.attempts, "an integer >= 1")
        require(0.0 < self.min_rate_fraction <= 1.0, "min_rate_fraction", self.min_rate_fraction,
                "a fraction in (0, 1]")
        require(self.max_reasserts >= 0, "max_reasserts", self.max_reasserts, "an integer >= 0")


@dataclass(frozen=True)
class CommandingConfig:
    """What the companion sends and the limits it never exceeds."""
    cruise_speed_mps: float = 5.0
    max_speed_mps: float = 8.0
    max_turn_rate_deg_s: float = 30.0
    setpoint_rate_hz: float = 10.0
    odometry_rate_hz: float = 5.0             # ODOMETRY (the SLAM pose) out
    max_attitude_age_s: float = 0.5           # odometry pairs LOCAL_POSITION_NED with ATTITUDE this recent
    # What the velocity choice assumes the vehicle flies (core/avoidance/arc.py): ArduCopter's GUIDED
    # shapes a velocity setpoint with WPNAV_ACCEL (default 250 cm/s/s).
    max_accel_mps2: float = 2.5
    # How long a new obstacle may stay out of the decision (tentative until confirmed: the
    # lifecycle's confirm_window frames of the camera, 5 at 5 Hz): flown before braking starts.
    perception_delay_s: float = 1.0

    def __post_init__(self) -> None:
        for key in ("cruise_speed_mps", "max_speed_mps", "max_turn_rate_deg_s", "setpoint_rate_hz",
                    "odometry_rate_hz", "max_attitude_age_s", "max_accel_mps2"):
            _positive(key, getattr(self, key))
        require(self.max_accel_mps2 <= PLAUSIBLE_ACCEL_MPS2, "max_accel_mps2", self.max_accel_mps2,
                f"a multicopter's horizontal acceleration <= {PLAUSIBLE_ACCEL_MPS2:g} m/s/s")
        require(0.0 <= self.perception_delay_s <= PLAUSIBLE_DELAY_S, "perception_delay_s",
                self.perception_delay_s, f"a delay in [0, {PLAUSIBLE_DELAY_S:g}] s")
        require(self.max_speed_mps <= PLAUSIBLE_SPEED_MPS, "max_speed_mps", self.max_speed_mps,
                f"a multicopter speed <= {PLAUSIBLE_SPEED_MPS:g} m/s")
        require(self.cruise_speed_mps <= self.max_speed_mps, "cruise_speed_mps",
                self.cruise_speed_mps, f"a speed <= max_speed_mps ({self.max_speed_mps})")

    @property
    def max_turn_rate_rad_s(self) -> float:
        return math.radians(self.max_turn_rate_deg_s)

    @property
    def setpoint_period_s(self) -> float:
        return 1.0 / self.setpoint_rate_hz


@dataclass(frozen=True)
class FailsafeConfig:
    """Safe action on stale obstacle data or a diverged estimator.

    hold: velocity 0 at the current yaw; stop: send nothing (ArduCopter's GUID_TIMEOUT then stops).
    """
    safe_action: Literal["hold", "stop"] = "hold"
    obstacle_timeout_s: float = 3.5           # camera silent this long (message time): stale
    require_camera: bool = True               # no camera seen at all counts as stale

    def __post_init__(self) -> None:
        _positive("obstacle_timeout_s", self.obstacle_timeout_s)


@dataclass(frozen=True)
class SafetyConfig:
    """Clock evidence, the setpoint gate's limits beyond commanding.max_speed_mps, the start
    pose's bounds and the STATUSTEXT limiter (docs/robustness.md)."""
    clock_behind_tolerance_s: float = 1.0     # vehicle time back by less: reordering, accepted
    clock_ahead_window_s: float = 1.0         # ahead by more: refused until confirmed
    clock_evidence_messages: int = 5          # consecutive autopilot messages for a new clock
    max_vertical_speed_mps: float = 2.5       # no setpoint climbs or sinks faster
    max_yaw_rate_deg_s: float = 90.0          # no setpoint turns faster
    max_position_m: float = 100_000.0         # start pose and position setpoints within this
    statustext_repeat_s: float = 5.0          # the same text at most once per this
    statustext_per_s: int = 2                 # and at most this many STATUSTEXT per second

    def __post_init__(self) -> None:
        for key in ("clock_behind_tolerance_s", "clock_ahead_window_s", "max_vertical_speed_mps",
                    "max_yaw_rate_deg_s", "max_position_m", "statustext_repeat_s"):
            _positive(key, getattr(self, key))
        require(self.clock_evidence_messages >= 2, "clock_evidence_messages",
                self.clock_evidence_messages, "an integer >= 2 (one message is never evidence)")
        require(self.statustext_per_s >= 1, "statustext_per_s", self.statustext_per_s,
                "an integer >= 1")

    @property
    def max_yaw_rate_rad_s(self) -> float:
        return math.radians(self.max_yaw_rate_deg_s)


@dataclass(frozen=True)
class GoalConfig:
    """The service's goal: north/east metres in LOCAL_NED (from the EKF origin), or a latitude
    and longitude, converted with the EKF origin (or HOME) that the service asks the vehicle for."""
    north_m: float | None = None
    east_m: float | None = None
    radius_m: float = 2.0
    lat_deg: float | None = None
    lon_deg: float | None = None
    mission: bool = False                     # fly the autopilot's mission (companion/onboard/mission.py)

    def __post_init__(self) -> None:
        _positive("radius_m", self.radius_m)
        if self.mission:
            given = [k for k in ("north_m", "east_m", "lat_deg", "lon_deg")
                     if getattr(self, k) is not None]
            if given:
                raise FieldError(given[0], "not with mission: true (the mission gives the goals)")
            return
        local = (self.north_m, self.east_m)
        geo = (self.lat_deg, self.lon_deg)
        if any(v is not None for v in local) and any(v is not None for v in geo):
            raise FieldError("lat_deg", "give north_m and east_m, or lat_deg and lon_deg, not both")
        if self.is_geographic:
            if None in geo:
                raise FieldError("lon_deg" if self.lon_deg is None else "lat_deg",
                                 "missing (a geographic goal needs lat_deg and lon_deg)")
            require(-90.0 <= self.lat_deg <= 90.0, "lat_deg", self.lat_deg,
                    "a latitude in [-90, 90]")
            require(-180.0 <= self.lon_deg <= 180.0, "lon_deg", self.lon_deg,
                    "a longitude in [-180, 180]")
        elif None in local:
            raise FieldError("east_m" if self.east_m is None else "north_m",
                             "missing (give north_m and east_m, or lat_deg and lon_deg)")

    @property
    def is_geographic(self) -> bool:
        return not self.mission and (self.lat_deg is not None or self.lon_deg is not None)


@dataclass(frozen=True)
class FlightConfig:
    """Flight phases and the vertical hold (companion/onboard/flight_phase.py): no setpoint while the
    vehicle is landed, taking off or landing; setpoints hold an altitude."""
    landed_state_timeout_s: float = 3.0       # EXTENDED_SYS_STATE older than this: use altitude
    airborne_alt_m: float = 2.0               # fallback: above this over the takeoff point...
    takeoff_alt_m: float | None = None        # ...and at this takeoff altitude (null: climb stopped)
    climb_stopped_mps: float = 0.3
    climb_stopped_s: float = 1.0
    hold_alt_m: float | None = None           # null: hold the altitude commanding began at
    vertical_gain_per_s: float = 0.5          # vz = gain x altitude error...
    max_vertical_speed_mps: float = 1.0       # ...within +-this

    def __post_init__(self) -> None:
        for key in ("landed_state_timeout_s", "airborne_alt_m", "climb_stopped_mps",
                    "climb_stopped_s", "vertical_gain_per_s", "max_vertical_speed_mps"):
            _positive(key, getattr(self, key))
        for key in ("takeoff_alt_m", "hold_alt_m"):
            value = getattr(self, key)
            require(value is None or value > 0.0, key, value, "an altitude > 0 m or null")

    def params(self) -> FlightPhaseParams:
        return FlightPhaseParams(
            landed_state_timeout_s=self.landed_state_timeout_s, airborne_alt_m=self.airborne_alt_m,
            takeoff_alt_m=self.takeoff_alt_m, climb_stopped_mps=self.climb_stopped_mps,
            climb_stopped_s=self.climb_stopped_s, hold_alt_m=self.hold_alt_m,
            vertical_gain_per_s=self.vertical_gain_per_s,
            max_vertical_speed_mps=self.max_vertical_speed_mps)


@dataclass(frozen=True)
class MapOutputConfig:
    """The map published as OBSTACLE_DISTANCE (72 sectors, body FRD) for ArduPilot's proximity
    library (PRX1_TYPE = 2) and the ground station's proximity view. rate_hz 0: not published.
    AP_Proximity_MAV calls the sensor lost 500 ms after the last message: keep rate_hz above 2."""
    rate_hz: float = 5.0                      # vehicle time
    obstacle_radius_m: float = 2.0            # a mapped obstacle's centre +- this is its surface
    min_distance_m: float = 0.2
    max_distance_m: float = 100.0             # surfaces beyond: "nothing there"

    def __post_init__(self) -> None:
        require(self.rate_hz >= 0.0, "rate_hz", self.rate_hz, "a rate >= 0 (0: off)")
        require(self.obstacle_radius_m >= 0.0, "obstacle_radius_m", self.obstacle_radius_m,
                "a radius >= 0")
        _positive("min_distance_m", self.min_distance_m)
        require(self.min_distance_m < self.max_distance_m <= 655.0, "max_distance_m",
                self.max_distance_m, "a distance above min_distance_m and <= 655 m (uint16 cm)")


@dataclass(frozen=True)
class FlyToConfig:
    """A ground station's "fly to here" in GUIDED becomes the goal (companion/onboard/fly_to.py)."""
    enabled: bool = True
    max_distance_from_origin_m: float = 1000.0   # goals beyond this from the EKF origin: refused
    max_distance_from_vehicle_m: float = 500.0   # and beyond this from the vehicle
    radius_m: float = 2.0                        # the new goal's radius

    def __post_init__(self) -> None:
        for key in ("max_distance_from_origin_m", "max_distance_from_vehicle_m", "radius_m"):
            _positive(key, getattr(self, key))


@dataclass(frozen=True)
class CompanionConfig:
    estimator: EstimatorConfig
    avoidance: AvoidanceConfig
    link: LinkConfig = field(default_factory=LinkConfig)
    streams: StreamsConfig = field(default_factory=StreamsConfig)
    commanding: CommandingConfig = field(default_factory=CommandingConfig)
    failsafe: FailsafeConfig = field(default_factory=FailsafeConfig)
    safety: SafetyConfig = field(default_factory=SafetyConfig)
    goal: GoalConfig | None = None            # or --goal NORTH,EAST on the command line
    flight: FlightConfig = field(default_factory=FlightConfig)
    map_out: MapOutputConfig = field(default_factory=MapOutputConfig)
    fly_to: FlyToConfig = field(default_factory=FlyToConfig)

    def __post_init__(self) -> None:
        self.goal_look_params()         # avoidance.goal_look_deg against the camera's view

    def guidance_params(self, goal_radius_m: float) -> GuidanceParams:
        return self.avoidance.guidance_params(self.commanding.cruise_speed_mps, goal_radius_m)

    @property
    def camera_fov_rad(self) -> float:
        """The camera's field of view: avoidance.camera_fov_deg, else estimator.sensor_fov_deg,
        else 90 degrees."""
        fov_deg = self.avoidance.camera_fov_deg or self.estimator.sensor_fov_deg or 90.0
        return math.radians(fov_deg)

    def union_params(self) -> UnionParams:
        """The union law's settings with the camera the service has: its field of view, its
        range (never outrun it: estimator.sensor_max_range_m, null: no such limit) and the time a
        new obstacle stays out of the decision."""
        delay_s = 0.0 if self.estimator.tentative_in_guidance else self.commanding.perception_delay_s
        return replace(self.avoidance.union_params(self.camera_fov_rad),
                       sensor_range_m=self.estimator.sensor_max_range_m,
                       perception_delay_s=delay_s)

    def vehicle_limits(self) -> VehicleLimits:
        """What the velocity choice assumes the vehicle can fly: ArduCopter in GUIDED, a
        multicopter whose velocity turns within its acceleration limit."""
        return VehicleLimits(self.commanding.max_turn_rate_rad_s, self.commanding.max_accel_mps2,
                             lateral_accel_limited=True)

    def goal_look_params(self) -> GoalLookParams | None:
        """avoidance.goal_look_deg (core/avoidance/look_at.py) with the service's camera; None: off."""
        return self.avoidance.goal_look_params(self.camera_fov_rad)

    def look_at_params(self) -> LookAtParams | None:
        """avoidance.look_at_threats: a mover counts when its closest approach comes within the
        look-ahead and nearer than twice the safety distance."""
        if not self.avoidance.look_at_threats:
            return None
        return LookAtParams(self.camera_fov_rad, self.avoidance.lookahead_s,
                            2.0 * self.avoidance.safety_distance_m)


def load_config(path: str | Path) -> CompanionConfig:
    """Read and validate a companion config; a mistake raises ConfigError naming file and key.

    A relative ``link.signing_key_file`` is taken from the config file's folder.
    """
    config = build(CompanionConfig, read_yaml(path), path)
    key_file = config.link.signing_key_file
    if key_file is not None and not Path(key_file).is_absolute():
        config = replace(config, link=replace(
            config.link, signing_key_file=str(Path(path).resolve().parent / key_file)))
    return config


SIGNING_KEY_BYTES = 32


def read_signing_key(link: LinkConfig) -> bytes | None:
    """The MAVLink 2 signing key named by ``link.signing_key_file`` (None: signing off).

    The file holds 64 hex characters (whitespace ignored). Errors name the file and the problem,
    never the content: it is a secret.
    """
    if link.signing_key_file is None:
        return None
    where = f"link.signing_key_file: {link.signing_key_file}"
    try:
        text = Path(link.signing_key_file).read_text()
    except (OSError, UnicodeDecodeError) as exc:
        raise ConfigError(f"{where}: cannot read: {getattr(exc, 'strerror', None) or exc}") \
            from None
    hex_text = "".join(text.split())
    if len(hex_text) != 2 * SIGNING_KEY_BYTES:
        raise ConfigError(f"{where}: expected {2 * SIGNING_KEY_BYTES} hex characters, "
                          f"got {len(hex_text)}")
    try:
        return bytes.fromhex(hex_text)
    except ValueError:
        raise ConfigError(f"{where}: not hexadecimal") from None


def config_to_dict(config) -> dict:
    """A config dataclass as plain YAML-able data (the inverse of load_config)."""
    import dataclasses
    return dataclasses.asdict(config)
