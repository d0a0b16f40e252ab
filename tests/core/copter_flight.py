"""The multicopter flown by hand in core tests: copter.yaml's vehicle (per-sample autopilot yaw
noise 2 deg) among given obstacles, its seeded truth, and a navigator fed the truth's odometry."""
import dataclasses

import numpy as np

from companion.config.scenario import load_scenario
from companion.sim.simulation import make_navigator
from companion.sim.truth import TruthWorld


def copter_among(obstacles: tuple, seed: int):
    """(truth, navigator) at t = 0, the navigator having taken the first odometry sample."""
    base = load_scenario("config/scenarios/copter.yaml")
    scenario = dataclasses.replace(base, world=dataclasses.replace(base.world, obstacles=obstacles))
    truth = TruthWorld(scenario, np.random.default_rng(seed))
    nav = make_navigator(scenario)
    first = truth.copter_odometry(0.0)
    nav.on_velocity(0.0, first.vel_north_mps, first.vel_east_mps, first.yaw_rad,
                    first.yaw_rate_rad_s)
    return truth, nav


def fly_north(truth: TruthWorld, nav, nose_rad: float = 0.0) -> None:
    """One step north at 5 m/s, the nose ``nose_rad`` off it; the navigator takes the odometry."""
    odo = truth.step_copter(np.array([5.0, 0.0]), nose_rad)
    nav.on_velocity(truth.t_s, odo.vel_north_mps, odo.vel_east_mps, odo.yaw_rad,
                    odo.yaw_rate_rad_s)
