"""The service's own settings (config/companion.yaml: `companion run` / `demo` / `replay`).

``load_config(path)`` is the only place the service's YAML becomes config objects; the
estimator and avoidance sections are the scenario's (sections.py).
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Literal


from companion.config.checks import (PLAUSIBLE_ACCEL_MPS2, PLAUSIBLE_DELAY_S, PLAUSIBLE_JERK_MPS3,
                                     PLAUSIBLE_SPEED_MPS, require_positive)
from companion.config.loader import FieldError, build, layered, read_yaml, require
from companion.config.paths import resolve_config
from companion.config.link import LinkConfig  # noqa: F401  (a section of CompanionConfig)
from companion.config.sections import AvoidanceConfig, EstimatorConfig
from companion.config.scenario import PerceptionConfig
from companion.core.avoidance.arc import VehicleLimits
from companion.core.avoidance.guidance import GuidanceParams
from companion.core.avoidance.look_at import GoalLookParams, LookAtParams
from companion.core.avoidance.union import UnionParams
from companion.onboard.flight_phase import FlightPhaseParams
from companion.config.px4 import Px4Config
from companion.config.restart import RestartConfig


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
            require_positive(key, getattr(self, key))
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
    # ... and how fast that acceleration itself may change (core/avoidance/jerk_shaping.py):
    # ArduCopter's PSC_JERK_XY (default 5 m/s/s/s; AC_PosControl shapes a GUIDED velocity setpoint
    # with it, a 0.5 s lag at WPNAV_ACCEL 250). None: the velocity changes within max_accel at once.
    max_jerk_mps3: float | None = None
    # Each setpoint's yaw turns on from the last one's, at most this far (at max_turn_rate) ahead of
    # the nose now (core/avoidance/guidance.py shape_setpoint): ArduCopter's yaw lags its target
    # about 0.3 s, and turned from the nose now a 30 deg/s turn flew at 9 deg/s. None: from the nose.
    yaw_lead_s: float | None = None
    # How long a new obstacle may stay out of the decision (tentative until confirmed: the
    # lifecycle's confirm_window frames of the camera, 5 at 5 Hz): flown before braking starts.
    perception_delay_s: float = 1.0

    def __post_init__(self) -> None:
        for key in ("cruise_speed_mps", "max_speed_mps", "max_turn_rate_deg_s", "setpoint_rate_hz",
                    "odometry_rate_hz", "max_attitude_age_s", "max_accel_mps2"):
            require_positive(key, getattr(self, key))
        require(self.max_accel_mps2 <= PLAUSIBLE_ACCEL_MPS2, "max_accel_mps2", self.max_accel_mps2,
                f"a multicopter's horizontal acceleration <= {PLAUSIBLE_ACCEL_MPS2:g} m/s/s")
        if self.max_jerk_mps3 is not None:
            require(isinstance(self.max_jerk_mps3, (int, float)) and not isinstance(
                self.max_jerk_mps3, bool) and 0.0 < self.max_jerk_mps3 <= PLAUSIBLE_JERK_MPS3,
                "max_jerk_mps3", self.max_jerk_mps3,
                f"null or a jerk in (0, {PLAUSIBLE_JERK_MPS3:g}] m/s/s/s (ArduCopter PSC_JERK_XY)")
        if self.yaw_lead_s is not None:
            require(isinstance(self.yaw_lead_s, (int, float)) and not isinstance(
                self.yaw_lead_s, bool) and 0.0 <= self.yaw_lead_s <= 2.0, "yaw_lead_s",
                self.yaw_lead_s, "null or a time in [0, 2] s")
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
        require_positive("obstacle_timeout_s", self.obstacle_timeout_s)


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
            require_positive(key, getattr(self, key))
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
    # with mission: download it again this often (s) to catch a re-upload of the same length
    # that nothing announced (no mission_id, no MISSION_ACK heard); null: never
    mission_recheck_s: float | None = None

    def __post_init__(self) -> None:
        require_positive("radius_m", self.radius_m)
        if self.mission_recheck_s is not None:
            if not self.mission:
                raise FieldError("mission_recheck_s", "only with mission: true")
            require_positive("mission_recheck_s", self.mission_recheck_s)
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

    def describe(self) -> str:
        """The goal as the service's start-up log says it."""
        if self.mission:
            return f"the autopilot's mission (default acceptance radius {self.radius_m:.1f} m)"
        if self.is_geographic:
            return f"lat {self.lat_deg:.7f}, lon {self.lon_deg:.7f} (waits for the EKF origin)"
        return f"north {self.north_m:.1f} m, east {self.east_m:.1f} m"


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
            require_positive(key, getattr(self, key))
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
        require_positive("min_distance_m", self.min_distance_m)
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
            require_positive(key, getattr(self, key))


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
    restart: RestartConfig = field(default_factory=RestartConfig)
    px4: Px4Config = field(default_factory=Px4Config)     # OFFBOARD: who switches, when
    # points' z (with avoidance.vertical: the floor dropped, landmarks' heights; onboard/heights.py)
    perception: PerceptionConfig = field(default_factory=PerceptionConfig)

    def __post_init__(self) -> None:
        self.goal_look_params()         # avoidance.goal_look_deg against the camera's view

    def guidance_params(self, goal_radius_m: float) -> GuidanceParams:
        return self.avoidance.guidance_params(self.commanding.cruise_speed_mps, goal_radius_m)

    @property
    def safety_distance_m(self) -> float:
        """d at the service's cruise speed (avoidance.safety_distance_at)."""
        return self.avoidance.safety_distance_at(self.commanding.cruise_speed_mps)

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
        return replace(self.avoidance.union_params(self.camera_fov_rad), perception_delay_s=delay_s,
                       sensor_range_m=self.estimator.sensor_max_range_m,
                       control_period_s=self.commanding.setpoint_period_s)

    def vehicle_limits(self) -> VehicleLimits:
        """What the velocity choice assumes the vehicle can fly: ArduCopter in GUIDED, a
        multicopter whose velocity turns within its acceleration limit."""
        return VehicleLimits(self.commanding.max_turn_rate_rad_s, self.commanding.max_accel_mps2,
                             lateral_accel_limited=True,
                             max_jerk_mps3=self.commanding.max_jerk_mps3)

    def goal_look_params(self) -> GoalLookParams | None:
        """avoidance.goal_look_deg (core/avoidance/look_at.py) with the service's camera; None: off."""
        return self.avoidance.goal_look_params(self.camera_fov_rad)

    def look_at_params(self) -> LookAtParams | None:
        """avoidance.look_at_threats: a mover counts when its closest approach comes within the
        look-ahead and nearer than twice the safety distance."""
        if not self.avoidance.look_at_threats:
            return None
        return LookAtParams(self.camera_fov_rad, self.avoidance.lookahead_s,
                            2.0 * self.safety_distance_m)


def load_config(path: str | Path, over: str | Path | None = None) -> CompanionConfig:
    """Read and validate a companion config; a mistake raises ConfigError naming file and key.
    With ``over``, ``path`` is a layer over it (loader.layered): it holds only the keys that
    differ, and errors name ``path``. A relative ``link.signing_key_file`` is from its folder."""
    data = read_yaml(path)
    if over is not None and Path(over).resolve() != Path(path).resolve():
        data = layered(read_yaml(over), data)
    config = build(CompanionConfig, data, path)
    key_file = config.link.signing_key_file
    if key_file is not None and not Path(key_file).is_absolute():
        config = replace(config, link=replace(
            config.link, signing_key_file=str(Path(path).resolve().parent / key_file)))
    return config


SHIPPED_CONFIG = "config/companion.yaml"


def load_user_config(path: str | Path) -> CompanionConfig:
    """A user's ``--config``: layered over the shipped config/companion.yaml (found as
    resolve_config finds it), so it need hold only the keys that differ."""
    return load_config(resolve_config(path), over=resolve_config(SHIPPED_CONFIG))


def config_to_dict(config) -> dict:
    """A config dataclass as plain YAML-able data (the inverse of load_config)."""
    return asdict(config)
