"""The estimate-and-guide pipeline shared by ``simulate``, the live service and ``replay``.

Pure: odometry and observations go in with their times, guidance commands come out. Whoever feeds
it (the in-process truth world, MAVLink, a tlog) cannot be told apart from here.

A facade composing five parts, each in its own module:

- ``estimator`` (core/estimation/estimator.py): EKF-SLAM with its options, fed in time;
- ``landmarks`` (core/estimation/landmark_manager.py): each frame's observations into the map;
- ``probation`` (core/estimation/probation.py): new landmarks watched for motion, mover tracks;
- ``view`` (obstacle_view.py): what the decision sees of the estimate;
- ``decider`` (decider.py): the guidance law, where the nose looks, the urgency.
"""
from __future__ import annotations

import numpy as np

from companion.core.avoidance import vertical as vertical3d
from companion.core.avoidance.arc import VehicleLimits
from companion.core.avoidance.guidance import GuidanceCommand, GuidanceParams
from companion.core.avoidance.look_at import GoalLookParams, LookAtParams
from companion.core.avoidance.union import UnionParams
from companion.core.estimation.estimator import Estimator
from companion.core.estimation.landmark_manager import LandmarkManager
from companion.core.estimation.lifecycle import Lifecycle
from companion.core.estimation.movers import MoverParams
from companion.core.estimation.probation import MoverProbation
from companion.core.estimation.slam_types import (AssociationGates, Observation, SlamNoise,
                                                  UpdateReport)
from companion.core.estimator_options import EstimatorOptions
from companion.core.navigation.decider import STRATEGIES, Decider, UrgencyChange
from companion.core.navigation.obstacle_view import ObstacleView
from companion.core.perception.vertical_extent import ExtentParams


class Navigator:
    """EKF-SLAM plus guidance. ``strategy``: 'cone' (the paper), 'union' or 'apf' (Khatib)."""

    def __init__(self, start_pose: np.ndarray, start_pose_cov: np.ndarray, noise: SlamNoise,
                 gates: AssociationGates, params: GuidanceParams, goal: np.ndarray,
                 strategy: str = "cone", union: UnionParams = UnionParams(),
                 mover_params: MoverParams = MoverParams(),
                 options: EstimatorOptions = EstimatorOptions(),
                 limits: VehicleLimits | None = None,
                 look_at: LookAtParams | None = None,
                 goal_look: GoalLookParams | None = None,
                 extent: ExtentParams | None = None,
                 vertical: vertical3d.VerticalParams | None = None) -> None:
        """``limits``: the union law chooses velocities the vehicle can fly (arc.py). ``look_at``
        (a multicopter's only): its nose may turn toward a tracked mover it cannot see
        (core/avoidance/look_at.py); the command then carries ``yaw_rad``. ``goal_look`` (a
        multicopter's only): while it watches nothing, its nose turns toward the goal's
        direction when the velocity swerves (core/avoidance/look_at.py goal_look_yaw).
        ``extent``: observations with a z are judged against the altitude (``on_altitude``): the
        floor and bad points dropped and counted (``points``), each landmark's vertical extent
        kept (``extents``). ``vertical``: avoidance in 3D (core/avoidance/vertical.py);
        ``vertical_choice`` holds the last decision's plan and climb rate."""
        if strategy not in STRATEGIES:
            raise ValueError(f"unknown strategy {strategy!r}")
        self.estimator = Estimator(start_pose, start_pose_cov, noise, gates, options)
        lifecycle = Lifecycle(options.lifecycle)
        self.probation = MoverProbation(self.estimator, lifecycle, mover_params)
        self.landmarks = LandmarkManager(self.estimator, self.probation, lifecycle, extent)
        self.view = ObstacleView(self.estimator, self.landmarks, self.probation, union)
        self.decider = Decider(self.estimator, self.view, params, goal, strategy, union, limits,
                               look_at, goal_look, vertical)

    # ------------------------------------------------------ timed inputs (Estimator)
    def on_odometry(self, t_s: float, speed_mps: float, yaw_rad: float,
                    course_rad: float | None = None) -> list[UpdateReport]:
        """One odometry sample (Estimator.on_odometry); the frames it covers are observed."""
        return self.estimator.on_odometry(t_s, speed_mps, yaw_rad, course_rad, self.observe)

    def on_velocity(self, t_s: float, vel_north_mps: float, vel_east_mps: float, yaw_rad: float,
                    yaw_rate_rad_s: float) -> list[UpdateReport]:
        """A multicopter's odometry sample (Estimator.on_velocity); likewise."""
        return self.estimator.on_velocity(t_s, vel_north_mps, vel_east_mps, yaw_rad,
                                          yaw_rate_rad_s, self.observe)

    def on_observations(self, t_s: float, observations: list[Observation]) -> list[UpdateReport]:
        """One camera frame captured at ``t_s`` (Estimator.on_observations): observed now, or
        once the odometry reaches ``t_s``."""
        return self.estimator.on_observations(t_s, observations, self.observe)

    def on_altitude(self, altitude_m: float) -> None:
        self.estimator.on_altitude(altitude_m)

    def predict(self, speed_mps: float, heading_change_rad: float, dt_s: float,
                speed_var_scale: float = 1.0, heading_var_extra: float = 0.0) -> None:
        self.estimator.predict(speed_mps, heading_change_rad, dt_s, speed_var_scale,
                               heading_var_extra)

    def predict_velocity(self, vel_north_mps: float, vel_east_mps: float, yaw_rate_rad_s: float,
                         dt_s: float, var_scale: float = 1.0, yaw_var_extra: float = 0.0) -> None:
        self.estimator.predict_velocity(vel_north_mps, vel_east_mps, yaw_rate_rad_s, dt_s,
                                        var_scale, yaw_var_extra)

    def correct_yaw(self, yaw_rad: float, dt_s: float | None = None) -> UpdateReport:
        return self.estimator.correct_yaw(yaw_rad, dt_s)

    def correct_position(self, north_m: float, east_m: float, sigma_m: float) -> UpdateReport | None:
        return self.estimator.correct_position(north_m, east_m, sigma_m)

    def assess(self):
        return self.estimator.assess()

    # ------------------------------------------------------ a frame, and the decision
    def observe(self, observations: list[Observation]) -> list[UpdateReport]:
        """One camera frame (LandmarkManager.observe): the camera's view marked first, the
        tracks the camera could not have seen kept when they coast out of it."""
        self.decider.mark_view()
        reports = self.landmarks.observe(observations)
        self.probation.movers.prune(self.estimator.clock_s, self.decider.track_keeper())
        return reports

    def obstacles(self, young_movers: bool = False):
        """Everything guidance must avoid (ObstacleView.obstacles)."""
        return self.decider.obstacles(young_movers)

    def decide(self, t_s: float) -> tuple[GuidanceCommand, UrgencyChange | None]:
        """Guidance on the current estimate, and the urgency change it implies, if any."""
        return self.decider.decide(t_s)

    def on_setpoint(self, shaped) -> None:
        """The setpoint just sent (Decider.on_setpoint)."""
        self.decider.on_setpoint(shaped)

    # ------------------------------------------------------ what callers read
    slam = property(lambda self: self.estimator.slam)
    options = property(lambda self: self.estimator.options)
    clock_s = property(lambda self: self.estimator.clock_s)
    t_s = property(lambda self: self.estimator.t_s)
    altitude_m = property(lambda self: self.estimator.altitude_m)
    health = property(lambda self: self.estimator.health)
    health_changes = property(lambda self: self.estimator.health_changes)
    position_fixes = property(lambda self: self.estimator.position_fixes)
    rejected = property(lambda self: self.estimator.rejected)
    lifecycle = property(lambda self: self.landmarks.lifecycle)
    archive = property(lambda self: self.landmarks.archive)
    extents = property(lambda self: self.landmarks.extents)
    points = property(lambda self: self.landmarks.points)
    movers = property(lambda self: self.probation.movers)
    movers_detected = property(lambda self: self.probation.movers_detected)
    union = property(lambda self: self.decider.union)
    limits = property(lambda self: self.decider.limits)
    look_at = property(lambda self: self.decider.look_at)
    goal_look = property(lambda self: self.decider.goal_look)
    watching = property(lambda self: self.decider.watching)
    vertical_choice = property(lambda self: self.decider.vertical_choice)

    @property
    def goal(self) -> np.ndarray:
        return self.decider.goal

    @goal.setter
    def goal(self, goal: np.ndarray) -> None:
        self.decider.goal = goal

    @property
    def vertical(self) -> vertical3d.VerticalParams | None:
        """Avoidance in 3D (None: 2D); the service sets it when the cruise altitude changes."""
        return self.decider.vertical

    @vertical.setter
    def vertical(self, vertical: vertical3d.VerticalParams | None) -> None:
        self.decider.vertical = vertical

    @property
    def params(self) -> GuidanceParams:
        return self.decider.params

    @params.setter
    def params(self, params: GuidanceParams) -> None:
        self.decider.params = params
