"""The sections a scenario and the service share: ``avoidance`` and ``estimator``.

The service's config (service.py) reuses these dataclasses, so a scenario's values can be dropped in.
It runs over 400 lines: two sections of many keys, each with its reason beside it; split, the
keys of one YAML section would be spread over two files.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal


from companion.config.checks import (require_positive, require_sigma, require_stereo_k,
                                     view_yaws_rad)
from companion.config.loader import FieldError, require
from companion.core.avoidance.guidance import GuidanceParams
from companion.core.avoidance.look_at import GoalLookParams
from companion.core.avoidance.path_search import STEADY_PATH, PathParams
from companion.core.avoidance.union import UnionParams
from companion.core.estimation.consistency import MonitorParams
from companion.core.estimation.lifecycle import LifecycleParams
from companion.core.estimation.map_archive import ArchiveParams
from companion.core.estimation.movers import MoverParams
from companion.core.estimation.position_reset import PositionResetParams
from companion.core.estimation.slam_types import AssociationGates, SlamNoise, VelocityNoise
from companion.core.estimator_options import EstimatorOptions


@dataclass(frozen=True)
class AvoidanceConfig:
    safety_distance_m: float              # d: at every cruise speed, or with the two keys below at
                                          # safety_full_speed_mps and faster
    horizon_s: float
    eta: float
    # d that grows with the cruise speed (forests): d(v) = rest + (safety_distance_m - rest) x
    # v / full for a cruise v below full (safety_distance_at). Both or neither; None: d fixed.
    safety_distance_rest_m: float | None = None
    safety_full_speed_mps: float | None = None
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
    headway_first: bool = False           # velocity choice: a slower heading within 90 deg of the
                                          # goal before a faster one away from it (forests;
                                          # core/avoidance/velocity_choice.py)
    path_search: bool = False             # velocity choice in a static field: fly the first leg
                                          # of a grid path over the mapped obstacles (forests;
                                          # core/avoidance/path_follow.py, path_search.py)
    path_steady: bool = False             # the path search keeps to the way it followed last
                                          # (a new way costs half as much again a metre off it)
                                          # and its grid takes in the mapped trees beside it,
                                          # up to 40 m either side, its cells free if a point
                                          # within 0.25 m keeps the need (path_search.STEADY_PATH;
                                          # forest-dense: the way in flipped side to side),
                                          # and the follower crawls a tight gap (0.5 m/s)
    evade_movers: bool = False            # a multicopter's evasion of near movers: side-step,
                                          # back off or stop with the nose held
                                          # (core/avoidance/evade.py; docs/copter-headon-failures.md)
    keep_near_tracks: bool = False        # a multicopter's coasting mover track, predicted within
                                          # the camera's range but out of its view, is kept until
                                          # the camera could have seen it there (movers.prune; on
                                          # with evade_movers; docs/copter-headon-failures.md)
    # a multicopter's coasting mover track is also kept, whatever the camera's range, while its
    # closest approach to the vehicle (flying on, or stopped) comes within d inside this many
    # seconds (movers.approaching; docs/movers-speed.md). None: off
    keep_tracks_horizon_s: float | None = None
    # the velocity choice's cruise no faster than a mover of this speed, met head-on and first
    # seen at the camera's range, can be dodged by d (core/avoidance/blind_side.py). None: off
    mover_max_speed_mps: float | None = None
    # Never faster than the vehicle can stop in the space its camera has seen free, the loop's
    # latency (perception delay + a control period, + a/2j where jerk-shaped) counted, and a last
    # resort that may brake sideways (core/avoidance/speed_limit.py). None: off (every flight as
    # before); "seen": on (forest.yaml).
    speed_limit: Literal["seen"] | None = None
    # Avoidance in 3D (core/avoidance/vertical.py): climb over what costs less to climb than to
    # fly round. None: off, except on the random worlds of heights (lowwalls, mixed): on.
    vertical: bool | None = None
    max_altitude_m: float = 30.0          # no climb above (an altitude fence)
    min_altitude_m: float = 2.0           # below it, nothing is flown over

    def __post_init__(self) -> None:
        require_positive("safety_distance_m", self.safety_distance_m)
        given, missing = (("safety_distance_rest_m", "safety_full_speed_mps")
                          if self.safety_full_speed_mps is None else
                          ("safety_full_speed_mps", "safety_distance_rest_m"))
        require((self.safety_distance_rest_m is None) == (self.safety_full_speed_mps is None),
                given, getattr(self, given), f"null, or a value together with {missing} "
                                             "(the speed law of d takes both)")
        if self.safety_distance_rest_m is not None:
            require(0.0 < self.safety_distance_rest_m <= self.safety_distance_m,
                    "safety_distance_rest_m", self.safety_distance_rest_m,
                    f"a distance in (0, safety_distance_m = {self.safety_distance_m:g}] m")
            require_positive("safety_full_speed_mps", self.safety_full_speed_mps)
        require_positive("min_altitude_m", self.min_altitude_m)
        require(self.max_altitude_m > self.min_altitude_m, "max_altitude_m", self.max_altitude_m,
                f"an altitude above min_altitude_m ({self.min_altitude_m:g} m)")
        require_positive("lookahead_s", self.lookahead_s)
        if self.mover_max_speed_mps is not None:
            require(0.0 < self.mover_max_speed_mps <= 50.0, "mover_max_speed_mps",
                    self.mover_max_speed_mps, "a speed in (0, 50] m/s or null (off)")
        if self.keep_tracks_horizon_s is not None:
            require(0.0 < self.keep_tracks_horizon_s <= 60.0, "keep_tracks_horizon_s",
                    self.keep_tracks_horizon_s, "a time in (0, 60] s or null (off)")
        require(self.speed_limit in (None, "seen"), "speed_limit", self.speed_limit,
                "null (off) or 'seen'")
        require(self.hysteresis >= 0.0, "hysteresis", self.hysteresis, "a weight >= 0")
        if self.gap_margin_m is not None:
            require(self.gap_margin_m >= 0.0, "gap_margin_m", self.gap_margin_m, "a margin >= 0 m")
        if self.flank_scan_deg is not None:
            require(0.0 < self.flank_scan_deg < 90.0, "flank_scan_deg", self.flank_scan_deg,
                    "an angle in (0, 90) degrees")
        require_positive("flank_scan_period_s", self.flank_scan_period_s)
        if self.goal_look_deg is not None:
            require(0.0 < self.goal_look_deg < 180.0, "goal_look_deg", self.goal_look_deg,
                    "an angle in (0, 180) degrees, less than half the camera's field of view")
        require(0.0 < self.goal_look_gain <= 10.0, "goal_look_gain", self.goal_look_gain,
                "a gain in (0, 10]")
        if self.camera_fov_deg is not None:
            require(0.0 < self.camera_fov_deg <= 360.0, "camera_fov_deg", self.camera_fov_deg,
                    "a field of view in (0, 360]")
        require_positive("horizon_s", self.horizon_s)
        require(self.eta >= 1.0, "eta", self.eta, "a safety factor >= 1")
        if self.mission_time_s is not None:
            require_positive("mission_time_s", self.mission_time_s)
        require(self.inflation_sigmas >= 0.0, "inflation_sigmas", self.inflation_sigmas, "a value >= 0")
        for key in ("approach_decel_mps2", "apf_attraction_gain", "apf_repulsion_gain",
                    "apf_influence_m"):
            require_positive(key, getattr(self, key))

    def safety_distance_at(self, cruise_speed_mps: float) -> float:
        """d for a flight at this cruise speed: safety_distance_m, or with the speed law (both
        keys set) rest + (safety_distance_m - rest) x cruise / full, up to safety_distance_m.

        Why a law: the distance inside d that a flight loses to its perception delay and its
        tracking error grows with its speed, while the gaps a slow flight must pass stay as
        narrow (docs/forest.md: 800 trees per ha leave 1.61-1.76 m from the centres)."""
        rest = self.safety_distance_rest_m
        if rest is None or self.safety_full_speed_mps is None:
            return self.safety_distance_m
        fraction = min(max(cruise_speed_mps, 0.0) / self.safety_full_speed_mps, 1.0)
        return rest + (self.safety_distance_m - rest) * fraction

    def union_params(self, sensor_fov_rad: float = math.radians(90.0)) -> UnionParams:
        fov = math.radians(self.camera_fov_deg) if self.camera_fov_deg is not None else sensor_fov_rad
        return UnionParams(lookahead_s=self.lookahead_s, hysteresis=self.hysteresis, fov_rad=fov,
                           gap_margin_m=self.gap_margin_m, headway_first=self.headway_first,
                           evade_movers=self.evade_movers,
                           keep_near_tracks=self.keep_near_tracks,
                           keep_tracks_horizon_s=self.keep_tracks_horizon_s,
                           mover_max_speed_mps=self.mover_max_speed_mps,
                           seen_speed_limit=self.speed_limit == "seen",
                           path=None if not self.path_search
                           else STEADY_PATH if self.path_steady else PathParams(),
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
            cruise_speed_mps=cruise_speed_mps,
            safety_distance_m=self.safety_distance_at(cruise_speed_mps),
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
    # Where an update evaluates that model: 'measured' (the sighting's own range, as the gates do)
    # or 'predicted' (the landmark's predicted range: R at the measured range weights short
    # sightings more and maps trunks short, range_noise.py). Only with range_sigma_k_per_m > 0.
    range_sigma_at: Literal["measured", "predicted"] = "measured"
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
    # velocity_ned: 'ned', the autopilot's NED velocity is independent of its yaw (GPS-aided);
    # 'yaw', it is a body velocity turned by the autopilot's own yaw (a flow sensor's, or the
    # stub's unicycle odometry), so it shares the yaw's error (EkfSlam.predict_velocity).
    velocity_frame: Literal["ned", "yaw"] = "ned"
    position_fusion: Literal["auto", "on", "off"] = "auto"
    position_sigma_m: float | None = 4.4          # null: from GPS_RAW_INT h_acc or HDOP
    position_sigma_per_hdop_m: float = 1.0
    position_period_s: float = 1.0
    max_hdop: float = 2.0
    min_fix_type: int = 3
    position_timeout_s: float = 2.0        # GPS_RAW_INT / EKF_STATUS_REPORT older: not healthy
    # Fixes refused in a row for this long (a GPS back after an outage the dead reckoning could
    # not bridge): the estimate restarts from the fix, map dropped
    # (core/estimation/position_reset.py; 7 s is EKF3's own gpsRetryTimeNoTAS_ms). null: never.
    position_reset_after_s: float | None = 7.0
    # While the autopilot's position is untrusted after having been trusted (a GPS outage), its
    # velocity is not GPS-aided either: modelled as a constant error of this sigma per axis over
    # the outage (core/estimation/position_reset.py UnaidedDrift; a choice). 0: the white Q only.
    unaided_velocity_sigma_mps: float = 0.1
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
    # a rig of cameras of sensor_fov_deg each: each one's yaw on the body (degrees, right
    # positive; a scenario fills it from sensor.cameras). [0]: one camera looking forward.
    sensor_view_yaws_deg: tuple[float, ...] = (0.0,)
    # The bounded map (core/estimation/map_archive.py): a landmark (not tentative) behind the vehicle,
    # farther than archive_behind_m and undetected for archive_unseen_s, is marginalised out of
    # the filter into a read-only archive. null: off (every landmark stays in the filter).
    archive_behind_m: float | None = None
    archive_unseen_s: float = 10.0
    # An id-less observation ambiguous only against a tentative landmark that no other observation
    # of the frame took starts a new landmark (the tentative one is a guess; forests: one 2 m off
    # swallowed its neighbour's every sighting, docs/forest.md). false: dropped, as before.
    new_beside_tentative: bool = False
    # A young landmark is taken to have moved to an id-less sighting (a mover's next point) only
    # if the jump is at most this fraction of the distance from the landmark to its nearest
    # other one in the map: a sighting that far off could be that neighbour's, or one beside it
    # (forests 2.5 m apart, docs/forest.md item 15). null: off, the mover's speed reach alone.
    moved_spacing_gate: float | None = None
    # A young landmark is taken to have moved only to a sighting beyond its own association
    # gate: one that came near it (the gate's grey zone, or refused by the frame's joint test)
    # is dropped, never a relocation that throws the landmark's sightings away for one noisy
    # point (forests: 22 a flight, the map's error 0.36 -> 0.73 m; docs/forest.md). false: as before.
    moved_beyond_own_gate: bool = False

    def __post_init__(self) -> None:
        if self.moved_spacing_gate is not None:
            require(math.isfinite(self.moved_spacing_gate) and 0.0 < self.moved_spacing_gate <= 1.0,
                    "moved_spacing_gate", self.moved_spacing_gate,
                    "a fraction in (0, 1] of the nearest neighbour's distance, or null (off)")
        if self.archive_behind_m is not None:
            require(math.isfinite(self.archive_behind_m) and self.archive_behind_m > 0.0,
                    "archive_behind_m", self.archive_behind_m, "a distance > 0 m, or null (off)")
        require(math.isfinite(self.archive_unseen_s) and self.archive_unseen_s > 0.0,
                "archive_unseen_s", self.archive_unseen_s, "a duration > 0 s")
        for key in ("speed_sigma_mps", "heading_change_sigma_deg", "range_sigma_m",
                    "bearing_sigma_deg", "initial_position_sigma_m", "initial_yaw_sigma_deg",
                    "vel_north_sigma_mps", "vel_east_sigma_mps", "yaw_rate_sigma_deg_s",
                    "yaw_sigma_deg", "position_sigma_per_hdop_m"):
            require_sigma(key, getattr(self, key))
        require(self.yaw_bias_sigma_deg >= 0.0, "yaw_bias_sigma_deg", self.yaw_bias_sigma_deg,
                "a standard deviation >= 0 (0: no bias)")
        if self.position_sigma_m is not None:
            require_sigma("position_sigma_m", self.position_sigma_m)
        for key in ("reference_dt_s", "position_period_s", "max_hdop", "position_timeout_s",
                    "yaw_bias_tau_s",
                    "arrival_tolerance_m", "monitor_window_s", "monitor_lost_after_s",
                    "degraded_radius_m", "mover_min_span_s", "mover_speed_sigmas"):
            require_positive(key, getattr(self, key))
        require(self.unaided_velocity_sigma_mps >= 0.0, "unaided_velocity_sigma_mps",
                self.unaided_velocity_sigma_mps, "a standard deviation >= 0 (0: off)")
        if self.position_reset_after_s is not None:
            require_positive("position_reset_after_s", self.position_reset_after_s)
        require_positive("accept_nis", self.accept_nis)
        require(self.new_landmark_nis >= self.accept_nis, "new_landmark_nis", self.new_landmark_nis,
                f"a gate >= accept_nis ({self.accept_nis})")
        require_positive("outlier_nis", self.outlier_nis)
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
        require_positive("tentative_timeout_s", self.tentative_timeout_s)
        if self.sensor_fov_deg is not None:
            require(0.0 < self.sensor_fov_deg <= 360.0, "sensor_fov_deg", self.sensor_fov_deg,
                    "a field of view in (0, 360] or null")
        if self.sensor_max_range_m is not None:
            require_positive("sensor_max_range_m", self.sensor_max_range_m)
        require(1 <= len(self.sensor_view_yaws_deg) <= 8
                and all(-180.0 <= v <= 180.0 for v in self.sensor_view_yaws_deg),
                "sensor_view_yaws_deg", list(self.sensor_view_yaws_deg),
                "1 to 8 camera yaws on the body, each in [-180, 180] degrees")
        require_stereo_k("range_sigma_k_per_m", self.range_sigma_k_per_m)

    def lifecycle_params(self) -> LifecycleParams:
        fov = None if self.sensor_fov_deg is None else math.radians(self.sensor_fov_deg)
        return LifecycleParams(confirm_hits=self.confirm_hits, confirm_window=self.confirm_window,
                               delete_misses=self.delete_misses,
                               tentative_timeout_s=self.tentative_timeout_s, fov_rad=fov,
                               max_range_m=self.sensor_max_range_m,
                               tentative_in_guidance=self.tentative_in_guidance,
                               view_yaws_rad=view_yaws_rad(self.sensor_view_yaws_deg))

    def position_reset_params(self) -> PositionResetParams:
        return PositionResetParams(after_s=self.position_reset_after_s)

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
            range_sigma_at_predicted=self.range_sigma_at == "predicted",
            yaw_bias_sigma_rad=math.radians(self.yaw_bias_sigma_deg),
            yaw_bias_tau_s=self.yaw_bias_tau_s,
            velocity_in_yaw_frame=self.velocity_frame == "yaw",
            archive=None if self.archive_behind_m is None
            else ArchiveParams(self.archive_behind_m, self.archive_unseen_s),
            new_beside_tentative=self.new_beside_tentative,
            moved_spacing_gate=self.moved_spacing_gate,
            moved_beyond_own_gate=self.moved_beyond_own_gate)

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
