"""The simulation state: truth, odometry, obstacles and the seeded noise streams. No I/O.

Simulated time is step_index * dt_s; everything that depends on time reads `t_s` from here.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import camera
from .vehicle import (Control, Demand, Limits, Odometry, TruthState, initial_odometry, steer,
                      step_odometry, step_truth)
from .world import Scenario, obstacles_at

# Separate, independent random streams derived from the one --seed.
STREAM_PHYSICS = 1
STREAM_CAMERA = 2
STREAM_LINK_DROP = 3


def make_rng(seed: int, stream: int) -> np.random.Generator:
    return np.random.default_rng([int(seed), stream])


@dataclass(frozen=True)
class StepRecord:
    """What one step did, for diagnostics and tests."""
    control: Control
    speed_noise_mps: float
    heading_noise_rad: float


class Simulation:
    """Steps the paper's model on simulated time and keeps the reported odometry."""

    def __init__(self, scenario: Scenario, seed: int = 0) -> None:
        self.scenario = scenario
        self.dt_s = scenario.vehicle.dt_s
        self.limits = Limits(max_turn_rate_rad_s=scenario.vehicle.max_turn_rate_rad_s,
                             max_accel_mps2=scenario.vehicle.max_accel_mps2)
        start = scenario.world.start
        self.truth = TruthState(north_m=start.north_m, east_m=start.east_m,
                                yaw_rad=start.yaw_rad, speed_mps=0.0)
        self.odometry: Odometry = initial_odometry(self.truth)
        self.step_index = 0
        self._rng_physics = make_rng(seed, STREAM_PHYSICS)
        self._rng_camera = make_rng(seed, STREAM_CAMERA)

    @property
    def t_s(self) -> float:
        return self.step_index * self.dt_s

    def step(self, demand: Demand, armed: bool) -> StepRecord:
        """One physics step. A disarmed vehicle cannot move; a resting one reports no noise."""
        if not armed:
            demand = Demand(speed_mps=0.0)
        control = steer(demand, self.odometry.yaw_rad, self.truth.speed_mps, self.limits,
                        self.dt_s)
        if not armed:
            # Disarmed (including a forced disarm in flight): the 2D vehicle is on the ground.
            control = Control(speed_mps=0.0, yaw_change_rad=0.0)
        noise = self.scenario.noise
        # Draw every step, even at rest, so the stream does not depend on arming history.
        speed_noise = float(self._rng_physics.normal(0.0, 1.0)) * noise.speed_sigma_mps
        heading_noise = float(self._rng_physics.normal(0.0, 1.0)) * noise.heading_change_sigma_rad
        at_rest = (not armed) and control.speed_mps == 0.0 and control.yaw_change_rad == 0.0
        if at_rest:
            speed_noise = heading_noise = 0.0
        self.truth = step_truth(self.truth, control, self.dt_s)
        self.odometry = step_odometry(self.odometry, control.yaw_change_rad, control.speed_mps,
                                      speed_noise, heading_noise, self.dt_s)
        self.step_index += 1
        return StepRecord(control=control, speed_noise_mps=speed_noise,
                          heading_noise_rad=heading_noise)

    def obstacles_now(self) -> list[tuple[int, float, float, float]]:
        """[(id, north_m, east_m, radius_m)] at the current simulated time."""
        return obstacles_at(self.scenario.world.obstacles, self.t_s)

    def observe(self) -> list[camera.Detection]:
        """One camera frame captured now, from the true pose."""
        return camera.observe(self.truth.north_m, self.truth.east_m, self.truth.yaw_rad,
                              self.obstacles_now(), self.scenario.sensor, self._rng_camera)
