"""``companion simulate`` with ``sensor.form: depth``: the rendered frames (companion/sim/depth_camera.py)
through the companion's own perception (core/perception/depth_perception.py).

The frames come from the truth (TruthWorld.capture_depth, rendered from the true pose with the
tilt). Per frame: the vehicle's roll and pitch as ATTITUDE would report them (the true tilt the frame was
rendered with, plus ``perception.depth.attitude_sigma_deg`` of noise), the altitude the autopilot
reports, and the motion since the capture (a frame is due at the camera's own clock, up to one
step before the estimate's time: the estimator's velocity and yaw rate over that delay). Each
camera's frame is perceived on its own and a frame time's observations go to the navigator
together. Its own random sources, so the truth's stream stays as it is.
"""
from __future__ import annotations

import math
from collections import Counter

import numpy as np

from companion.config.scenario import Scenario
from companion.core.estimation.slam_types import Observation
from companion.core.perception.depth_perception import MotionSince, perceive

ATTITUDE_STREAM = 0xA77        # ATTITUDE's roll and pitch errors: [seed, this]


class SimDepthPerception:
    """The depth camera rig and the perception of its frames, for one simulated run."""

    def __init__(self, scenario: Scenario, seed: int) -> None:
        sensor, perception = scenario.sensor, scenario.perception
        self.mounts = sensor.camera_mounts()
        self.params = perception.depth.params(perception.ground_margin_m, sensor.depth.baseline_m,
                                              sensor.depth.subpixel)
        self.attitude_sigma_rad = math.radians(perception.depth.attitude_sigma_deg)
        self.rng = np.random.default_rng([seed, ATTITUDE_STREAM])
        self.counts: Counter = Counter()

    def observations(self, frames, pose, t_s: float, altitude_m: float | None, vel_ne_mps,
                     yaw_rad: float, yaw_rate_rad_s: float) -> list[list[Observation]]:
        """The frames rendered since the last call (TruthWorld.capture_depth; ``pose``: the true
        pose of the last, its tilt ATTITUDE's), one list of observations per frame time, as of
        ``t_s``. ``vel_ne_mps``, ``yaw_rad``, ``yaw_rate_rad_s``: the autopilot's, for the motion
        since the capture."""
        out: dict[int, list[Observation]] = {}
        for frame in frames:
            delay_s = max(t_s - frame.time_boot_ms / 1000.0, 0.0)
            tilt = np.array([pose.roll_rad, pose.pitch_rad])
            if self.attitude_sigma_rad > 0.0:
                tilt = tilt + self.rng.normal(0.0, self.attitude_sigma_rad, 2)
            percept = perceive(frame, self.mounts[frame.camera_id], float(tilt[0]),
                               float(tilt[1]), altitude_m, self.params,
                               _motion(vel_ne_mps, yaw_rad, yaw_rate_rad_s, delay_s))
            self.counts.update(frames=1, points=percept.points, floor_points=percept.floor_points,
                               obstacle_points=percept.obstacle_points, holes=percept.holes,
                               observations=len(percept.observations), posts=len(percept.posts))
            out.setdefault(frame.frame_number, []).extend(percept.observations)
        return [out[k] for k in sorted(out)]

    def summary(self) -> dict:
        """The run's perception counts (the camera itself is the aggregate's ``sensor``)."""
        return {"decimation": self.params.decimation, **dict(self.counts)}


def _motion(vel_ne_mps, yaw_rad: float, yaw_rate_rad_s: float, delay_s: float) -> MotionSince:
    """The motion over ``delay_s`` before now, in the level frame at capture (the heading then:
    now's less the yaw rate's turn)."""
    turn = yaw_rate_rad_s * delay_s
    heading = yaw_rad - turn
    c, s = math.cos(heading), math.sin(heading)
    north, east = float(vel_ne_mps[0]) * delay_s, float(vel_ne_mps[1]) * delay_s
    return MotionSince(c * north + s * east, -s * north + c * east, 0.0, turn)

