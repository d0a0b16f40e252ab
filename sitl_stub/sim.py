"""The simulation state: truth, odometry, obstacles and the seeded noise streams. No I/O.

Simulated time is step_index * dt_s; everything that depends on time reads `t_s` from here.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from . import camera
from .vehicle import (Demand, Limits, Odometry, TruthState, desired_climb_mps, initial_odometry,
                      step_odometry, step_truth, thrust_tilt_rad)
from .world import Scenario, extents_of, obstacles_at, wrap_pi

# Separate, independent random streams derived from the one --seed.
STREAM_PHYSICS = 1
STREAM_CAMERA = 2
STREAM_LINK_DROP = 3
STREAM_POSITION = 4
STREAM_YAW_BIAS = 5
STREAM_OUTAGE = 6
STREAM_HEIGHTS = 7            # the camera's z noise and floor returns (3D worlds only)
STREAM_DEPTH = 8              # the depth camera's errors (sensor.form depth only)


def make_rng(seed: int, stream: int) -> np.random.Generator:
    return np.random.default_rng([int(seed), stream])


@dataclass(frozen=True)
class ClimbLimits:
    """Vertical limits in force (from WPNAV_SPEED_UP/DN, or LAND_SPEED in LAND)."""
    max_up_mps: float = 2.5
    max_down_mps: float = 1.5


@dataclass(frozen=True)
class StepRecord:
    """What one step did, for diagnostics and tests."""
    speed_noise_mps: float
    heading_noise_rad: float


def gauss_markov_step(value: float, sigma: float, tau_s: float, dt_s: float,
                      unit_draw: float) -> float:
    """One ``dt_s`` step of a first-order Gauss-Markov process of stationary ``sigma`` and
    correlation time ``tau_s``, driven by one standard normal draw."""
    phi = math.exp(-dt_s / tau_s)
    return phi * value + sigma * math.sqrt(1.0 - phi * phi) * unit_draw


class PositionError:
    """GPS-like error of the reported position: white noise plus a slow Gauss-Markov bias."""

    def __init__(self, sigma_m: float, bias_sigma_m: float, tau_s: float,
                 rng: np.random.Generator) -> None:
        self.sigma_m, self.bias_sigma_m, self.tau_s = sigma_m, bias_sigma_m, tau_s
        self._rng = rng
        self.bias_ne_m = (rng.normal(0.0, 1.0, 2) * bias_sigma_m).tolist()
        self.white_ne_m = [0.0, 0.0]

    def step(self, dt_s: float) -> None:
        draws = self._rng.normal(0.0, 1.0, 4)      # always four, whatever the sigmas
        self.bias_ne_m = [gauss_markov_step(b, self.bias_sigma_m, self.tau_s, dt_s, float(d))
                          for b, d in zip(self.bias_ne_m, draws[:2])]
        self.white_ne_m = [self.sigma_m * float(d) for d in draws[2:]]

    @property
    def total_sigma_m(self) -> float:
        return math.hypot(self.sigma_m, self.bias_sigma_m)


class YawBias:
    """An AHRS's slow yaw error (compass declination, soft iron, misalignment): a first-order
    Gauss-Markov process, drawn from its stationary sigma at the start and stepped every physics
    step (one draw a step, whatever the sigma, so the stream does not depend on it)."""

    def __init__(self, sigma_rad: float, tau_s: float, rng: np.random.Generator) -> None:
        self.sigma_rad, self.tau_s = sigma_rad, tau_s
        self._rng = rng
        self.bias_rad = float(rng.normal()) * sigma_rad

    def step(self, dt_s: float) -> None:
        self.bias_rad = gauss_markov_step(self.bias_rad, self.sigma_rad, self.tau_s, dt_s,
                                          float(self._rng.normal()))


class Simulation:
    """Steps the multicopter model on simulated time and keeps the reported odometry."""

    def __init__(self, scenario: Scenario, seed: int = 0) -> None:
        self.scenario = scenario
        self.dt_s = scenario.vehicle.dt_s
        self.limits = Limits(max_turn_rate_rad_s=scenario.vehicle.max_turn_rate_rad_s,
                             max_accel_mps2=scenario.vehicle.max_accel_mps2)
        start = scenario.world.start
        self.truth = TruthState(north_m=start.north_m, east_m=start.east_m, yaw_rad=start.yaw_rad)
        self.odometry: Odometry = initial_odometry(self.truth)
        self.step_index = 0
        self._rng_physics = make_rng(seed, STREAM_PHYSICS)
        self._rng_camera = make_rng(seed, STREAM_CAMERA)
        self._rng_heights = make_rng(seed, STREAM_HEIGHTS)
        self.rng_depth = make_rng(seed, STREAM_DEPTH)
        self._extents = extents_of(scenario.world)
        noise = scenario.noise
        self.position_error = PositionError(noise.position_sigma_m or 0.0,
                                            noise.position_bias_sigma_m,
                                            noise.position_bias_tau_s,
                                            make_rng(seed, STREAM_POSITION))
        self.yaw_bias = YawBias(noise.yaw_bias_sigma_rad, noise.yaw_bias_tau_s,
                                make_rng(seed, STREAM_YAW_BIAS))
        self.yaw_noise_rad = self.yaw_rate_noise_rad_s = 0.0
        # GPS outages: each one's velocity error (drawn from its own stream), and the
        # autopilot's dead-reckoned position during one (None: the GPS is there)
        angles = make_rng(seed, STREAM_OUTAGE).uniform(-math.pi, math.pi,
                                                       len(noise.gps_outages_s))
        self._outage_vel_ne_mps = [(noise.outage_velocity_bias_mps * math.cos(a),
                                    noise.outage_velocity_bias_mps * math.sin(a)) for a in angles]
        self._outage_ne_m: list[float] | None = None
        # the true tilt (roll, pitch) of the last step, from its acceleration; and the state
        # before it (the depth camera interpolates its frames between the two)
        self.tilt_rad = (0.0, 0.0)
        self.previous_truth = self.truth

    def gps_fix(self) -> bool:
        """Whether the autopilot has a GPS fix now (a GPS, and no outage under way)."""
        noise = self.scenario.noise
        return noise.has_gps and noise.gps_outage_at(self.t_s) is None

    def reported_velocity_ne_mps(self) -> tuple[float, float]:
        """LOCAL_POSITION_NED vx, vy: the odometry's, plus an outage's error during one."""
        vel = (self.odometry.vel_north_mps, self.odometry.vel_east_mps)
        outage = self.scenario.noise.gps_outage_at(self.t_s) if self.scenario.noise.has_gps \
            else None
        if outage is None:
            return vel
        bias = self._outage_vel_ne_mps[outage]
        return vel[0] + bias[0], vel[1] + bias[1]

    @property
    def t_s(self) -> float:
        return self.step_index * self.dt_s

    def step(self, demand: Demand, armed: bool, climb: ClimbLimits = ClimbLimits()) -> StepRecord:
        """One physics step. A disarmed vehicle cannot move; a resting one reports no noise."""
        if not armed:
            demand = Demand(grounded=True)
        climb_mps = desired_climb_mps(demand, self.truth.up_m, climb.max_up_mps,
                                      climb.max_down_mps, self.limits.accel_up_mps2)
        noise = self.scenario.noise
        # Draw every step, even at rest, so the streams do not depend on arming history.
        draws = self._rng_physics.normal(0.0, 1.0, 6)
        speed_noise = float(draws[0]) * noise.speed_sigma_mps
        if self.scenario.vehicle.kind == "multicopter":
            speed_noise = 0.0         # its odometry noise is per NED axis (velocity_sigma_mps)
        heading_noise = float(draws[1]) * noise.heading_change_sigma_rad
        vel_noise = (float(draws[2]) * noise.velocity_sigma_mps,
                     float(draws[3]) * noise.velocity_sigma_mps)
        self.position_error.step(self.dt_s)
        # The autopilot steers by its AHRS yaw: the true heading settles off by the yaw bias.
        ahrs_yaw = self.odometry.yaw_rad + self.yaw_bias.bias_rad
        self.yaw_bias.step(self.dt_s)
        before = self.truth
        self.truth = step_truth(before, demand, self.limits, self.dt_s, ahrs_yaw, climb_mps)
        self.previous_truth = before
        self.tilt_rad = (0.0, 0.0) if demand.grounded else \
            thrust_tilt_rad(before, self.truth, self.dt_s)
        if demand.grounded:
            speed_noise = heading_noise = 0.0
            vel_noise = (0.0, 0.0)
            self.yaw_noise_rad = self.yaw_rate_noise_rad_s = 0.0
        else:
            self.yaw_noise_rad = float(draws[4]) * noise.yaw_sigma_rad
            self.yaw_rate_noise_rad_s = float(draws[5]) * noise.yaw_rate_sigma_rad_s
        self.odometry = step_odometry(self.odometry, before, self.truth, speed_noise,
                                      heading_noise, vel_noise, self.dt_s)
        self._dead_reckon_outage()
        self.step_index += 1
        return StepRecord(speed_noise_mps=speed_noise, heading_noise_rad=heading_noise)

    def _dead_reckon_outage(self) -> None:
        """During an outage the autopilot's position follows its (erring) velocity from the
        last fix; when the fix returns it resets to it."""
        noise = self.scenario.noise
        if not noise.gps_outages_s or not noise.has_gps:
            return
        if noise.gps_outage_at(self.t_s) is None:
            self._outage_ne_m = None
            return
        if self._outage_ne_m is None:
            self._outage_ne_m = list(self._gps_position_ne_m())
        vel = self.reported_velocity_ne_mps()
        self._outage_ne_m[0] += vel[0] * self.dt_s
        self._outage_ne_m[1] += vel[1] * self.dt_s

    def reported_position_ne_m(self) -> tuple[float, float]:
        """LOCAL_POSITION_NED x, y: GPS-like (truth + error) with a GPS, else dead reckoning
        (and during an outage the autopilot's own, from the last fix)."""
        if not self.scenario.noise.has_gps:
            return self.odometry.north_m, self.odometry.east_m
        if self._outage_ne_m is not None:
            return self._outage_ne_m[0], self._outage_ne_m[1]
        return self._gps_position_ne_m()

    def _gps_position_ne_m(self) -> tuple[float, float]:
        err = self.position_error
        return (self.truth.north_m + err.bias_ne_m[0] + err.white_ne_m[0],
                self.truth.east_m + err.bias_ne_m[1] + err.white_ne_m[1])

    def reported_yaw_rate_rad_s(self) -> float:
        """ATTITUDE yawspeed: the odometry's yaw rate plus gyro-like white noise."""
        return self.odometry.yaw_rate_rad_s + self.yaw_rate_noise_rad_s

    def reported_yaw_rad(self) -> float:
        """ATTITUDE yaw: the integrated heading plus the AHRS's slow bias (on the ground too)
        and the compass-like white noise (in flight)."""
        return wrap_pi(self.odometry.yaw_rad + self.yaw_bias.bias_rad + self.yaw_noise_rad)

    def obstacles_now(self) -> list[tuple[int, float, float, float]]:
        """[(id, north_m, east_m, radius_m)] at the current simulated time."""
        return obstacles_at(self.scenario.world.obstacles, self.t_s)

    def heights(self) -> camera.Heights | None:
        """A 3D world's camera inputs now (true altitude, extents), None in a 2D world."""
        if not self.scenario.reports_z:
            return None
        return camera.Heights(self.truth.up_m, self._extents, self._rng_heights)

    def scan_sectors(self) -> tuple[list[int], float, float]:
        """One depth frame captured now, from the true pose (camera.ray_cast_sectors_cm)."""
        world = self.scenario.world
        return camera.ray_cast_sectors_cm(self.truth.north_m, self.truth.east_m,
                                          self.truth.yaw_rad, self.obstacles_now(),
                                          self.scenario.sensor, self._rng_camera,
                                          [list(shape.outline) for shape in world.shapes],
                                          self.heights(),
                                          tuple(self._extents[shape.obstacle_id]
                                                for shape in world.shapes))

    def observe(self) -> list[camera.Detection]:
        """One camera frame captured now, from the true pose."""
        return camera.observe(self.truth.north_m, self.truth.east_m, self.truth.yaw_rad,
                              self.obstacles_now(), self.scenario.sensor, self._rng_camera,
                              self.heights())

    def ground_points(self) -> list[tuple[float, float, float]]:
        """sensor.sees_ground: this frame's floor returns (body FRD x, y, z), else []."""
        heights = self.heights()
        return camera.ground_points(heights, self.scenario.sensor) if heights is not None else []
