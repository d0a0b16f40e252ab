"""``companion simulate``: the closed loop in-process, without MAVLink.

A truth world with its own random source, an estimator that sees only noisy odometry and noisy
observations, and guidance acting on the estimate. One run per seed; aggregates over runs.
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg

from companion.config.checks import view_yaws_rad
from companion.config.scenario import Scenario
from companion.core.perception.blobs import BlobParams, blob_observations
from companion.core.estimation.consistency import STATES, radius_2sigma_m
from companion.core.avoidance.arc import VehicleLimits
from companion.core.geometry import wrap_angle
from companion.core.avoidance.guidance import limit_turn, shape_setpoint
from companion.core.avoidance.look_at import LookAtParams
from companion.core.navigation.navigator import Navigator
from companion.core.avoidance.vertical import VerticalParams
from companion.core.perception.vertical_extent import ExtentParams
from companion.sim.aggregate import aggregate_summaries
from companion.sim.truth import TruthWorld
from companion.core.estimation.position_reset import PositionResetWatch, UnaidedDrift

# A run reaches the goal when the vehicle declares arrival (estimate within goal.radius_m) and the
# true position is then within goal.radius_m plus this allowance for the estimate's own error
# (the paper's "error less than 2 m").
ARRIVAL_ALLOWANCE_M = 2.0
VERTICAL_STREAM = 0xA17         # the truth's heights' own random source: [seed, this]
DEPTH_STREAM = 0xDE9            # the depth cameras' noise (sensor.form depth): [seed, this]


@dataclass
class Trace:
    """Per-step arrays of one run, for plots and NEES."""
    t_s: list = field(default_factory=list)
    true_pose: list = field(default_factory=list)
    est_pose: list = field(default_factory=list)
    pose_nees: list = field(default_factory=list)


@dataclass
class RunOutcome:
    summary: dict
    trace: Trace
    landmarks: np.ndarray
    landmark_covs: np.ndarray
    obstacles: np.ndarray


def make_navigator(scenario: Scenario, strategy: str | None = None,
                   start_pose: np.ndarray | None = None) -> Navigator:
    """``start_pose`` (north, east, yaw): where the estimate starts, else the world's start."""
    est = scenario.estimator_config()
    if est.sensor_fov_deg is None and est.sensor_max_range_m is None:    # the camera's own view
        est = dataclasses.replace(est, sensor_fov_deg=scenario.sensor.fov_deg,
                                  sensor_max_range_m=scenario.sensor.max_range_m)
    if est.sensor_view_yaws_deg == (0.0,):                  # the rig's cameras (centres form)
        est = dataclasses.replace(est, sensor_view_yaws_deg=scenario.sensor.view_yaws_deg)
    start = scenario.world.start
    pose = np.array([start.north_m, start.east_m, wrap_angle(start.yaw_rad)]) \
        if start_pose is None else np.array([start_pose[0], start_pose[1],
                                             wrap_angle(start_pose[2])])
    pose_cov = np.diag([est.initial_position_sigma_m ** 2, est.initial_position_sigma_m ** 2,
                        math.radians(est.initial_yaw_sigma_deg) ** 2])
    goal = np.array([scenario.world.goal.north_m, scenario.world.goal.east_m])
    return Navigator(pose, pose_cov, est.slam_noise(), est.gates(), scenario.guidance_params(),
                     goal, strategy or scenario.avoidance.strategy,
                     dataclasses.replace(scenario.avoidance.union_params(scenario.sensor.fov_rad),
                                         sensor_range_m=scenario.sensor.max_range_m,
                                         perception_delay_s=perception_delay_s(est, scenario),
                                         control_period_s=scenario.vehicle.dt_s,
                                         view_yaws_rad=view_yaws_rad(
                                             scenario.sensor.view_yaws_deg)),
                     mover_params=est.mover_params(), options=est.options(),
                     limits=vehicle_limits(scenario), look_at=look_at_params(scenario),
                     goal_look=scenario.goal_look_params(), extent=extent_params(scenario),
                     vertical=vertical_params(scenario))


def extent_params(scenario: Scenario) -> ExtentParams:
    """How the companion judges points' heights (core/perception/vertical_extent.py): the camera's vertical
    view, the floor's margin, the altitude's and a point's elevation's sigmas (floored)."""
    return ExtentParams(scenario.perception.vfov_rad(scenario.sensor.vfov_deg),
                        scenario.perception.ground_margin_m,
                        altitude_sigma_m=max(scenario.noise.altitude_sigma_m, 0.05),
                        elevation_sigma_rad=max(scenario.sensor.bearing_sigma_rad, 1e-3))


def vertical_params(scenario: Scenario) -> VerticalParams | None:
    """avoidance.vertical (core/avoidance/vertical.py), None when off; the climb rate is the vehicle's
    vertical speed limit (the service's: safety.max_vertical_speed_mps)."""
    avoidance = scenario.avoidance
    if not avoidance.vertical:
        return None
    return VerticalParams(
        safety_distance_m=scenario.safety_distance_m,
        cruise_altitude_m=scenario.world.start.alt_m,
        max_vertical_speed_mps=scenario.vehicle.max_vertical_speed_mps,
        min_altitude_m=avoidance.min_altitude_m, max_altitude_m=avoidance.max_altitude_m,
        cruise_speed_mps=scenario.vehicle.speed_mps, reach_m=scenario.sensor.max_range_m,
        max_accel_mps2=scenario.vehicle.max_accel_mps2, barrier_cost=True)


def is_3d(scenario: Scenario) -> bool:
    """Vertical avoidance on, an obstacle with a height, or a camera that sees the floor: the
    run's summary then carries the 3D figures (a 2D run's stays as it was)."""
    world = scenario.world
    return bool(scenario.avoidance.vertical) or scenario.sensor.sees_ground \
        or scenario.sensor.form == "depth" or any(
        item.height_m is not None or item.base_m > 0.0
        for item in world.obstacles + world.walls + world.buildings)


def with_vertical(scenario: Scenario, vertical: bool | None) -> Scenario:
    """The scenario with avoidance.vertical replaced (None: as it is)."""
    if vertical is None:
        return scenario
    return dataclasses.replace(scenario, avoidance=dataclasses.replace(scenario.avoidance,
                                                                       vertical=vertical))


def look_at_params(scenario: Scenario) -> LookAtParams | None:
    """avoidance.look_at_threats, for a multicopter only (a unicycle flies where it points)."""
    avoidance = scenario.avoidance
    if not avoidance.look_at_threats or scenario.vehicle.kind != "multicopter":
        return None
    return LookAtParams(avoidance.union_params(scenario.sensor.fov_rad).fov_rad,
                        avoidance.lookahead_s, 2.0 * scenario.safety_distance_m)


def perception_delay_s(est, scenario: Scenario) -> float:
    """How long a new obstacle may stay out of the guidance: while tentative (until confirmed,
    at worst the confirmation window's frames), unless tentatives count (estimator config)."""
    if est.tentative_in_guidance:
        return 0.0
    return est.confirm_window / scenario.sensor.rate_hz


def vehicle_limits(scenario: Scenario) -> VehicleLimits:
    """The truth vehicle's limits, for the guidance's velocity choice."""
    vehicle = scenario.vehicle
    return VehicleLimits(vehicle.max_turn_rate_rad_s, vehicle.max_accel_mps2,
                         lateral_accel_limited=vehicle.kind == "multicopter")


def pose_nees(true_pose: np.ndarray, est_pose: np.ndarray, cov: np.ndarray) -> float:
    """Pose NEES, e^T P^-1 e with the yaw error wrapped (offline only): filterpy's NEES for one
    estimate written out, ``np.dot(x.T, inv(P)).dot(x)`` with scipy's inverse, the same bits
    (tests/test_simulate_nees.py), without its batch's list and arrays; a non-finite
    covariance is refused here as scipy would, more cheaply than its wrapper checks."""
    error = true_pose - est_pose
    error[2] = wrap_angle(error[2])
    if not np.isfinite(cov).all():
        raise ValueError("array must not contain infs or NaNs")
    return float(np.dot(error, scipy.linalg.inv(cov, check_finite=False)).dot(error))


def with_position_fusion(scenario: Scenario, position_fusion: str | None) -> Scenario:
    """The scenario with its estimator's position_fusion replaced (None: as it is)."""
    if position_fusion is None:
        return scenario
    est = dataclasses.replace(scenario.estimator_config(), position_fusion=position_fusion)
    return dataclasses.replace(scenario, estimator=est)


def camera_frame(truth: TruthWorld, blobs: BlobParams) -> list:
    """What the companion sees of one frame in the scenario's sensor form: centres, the landmarks
    of the sectors' blobs (core/perception/blobs.py, the companion's side of a depth camera), or both.
    The depth form's frames go through ``_observe_depth`` instead."""
    form = truth.scenario.sensor.form
    frame = truth.observe() if form in ("centres", "both") else []
    if form in ("sectors", "both"):
        frame += blob_observations(*truth.observe_sectors(), blobs)
    return frame


def _depth_perception(scenario: Scenario, seed: int):
    """sensor.form depth: the rendered camera and the companion's perception of it (imported
    only then: the renderer is needed by no other form)."""
    if scenario.sensor.form != "depth":
        return None
    from companion.sim.depth_perceiver import SimDepthPerception
    return SimDepthPerception(scenario, seed)


def _observe_depth(nav: Navigator, depth, truth: TruthWorld, motion: tuple) -> None:
    """The depth frames due now through the companion's perception, one update per frame time."""
    frames = truth.capture_depth()
    if frames:
        for observations in depth.observations(frames, truth.depth_camera.last_pose, truth.t_s,
                                               nav.altitude_m, *motion):
            nav.observe(observations)


def with_speed(scenario: Scenario, speed_mps: float | None) -> Scenario:
    """The scenario with its vehicle's cruise speed replaced (None: as it is)."""
    if speed_mps is None:
        return scenario
    vehicle = dataclasses.replace(scenario.vehicle, speed_mps=float(speed_mps))
    return dataclasses.replace(scenario, vehicle=vehicle)


def run_once(scenario: Scenario, seed: int, strategy: str | None = None,
             depth_sink=None, plan_sink=None) -> RunOutcome:
    """Fly one seeded run of the scenario in-process. ``depth_sink(frames)``: sees every depth
    frame rendered (sensor.form depth); ``plan_sink(t_s, choice, truth)``: every decision's
    vertical choice (avoidance.vertical; None in 2D) and the truth after it."""
    truth = TruthWorld(scenario, np.random.default_rng(seed),
                       np.random.default_rng([seed, VERTICAL_STREAM]),
                       np.random.default_rng([seed, DEPTH_STREAM]), depth_sink)
    nav = make_navigator(scenario, strategy)
    three_d = is_3d(scenario)
    path_3d_m = climb_m = 0.0
    alt_range_m = [truth.altitude_m, truth.altitude_m]
    nav.on_altitude(truth.reported_altitude_m())
    est = scenario.estimator_config()
    copter = scenario.vehicle.kind == "multicopter"
    # The truth always reports a healthy fix: 'auto' fuses it.
    fuse = est.position_fusion != "off"
    fix_sigma_m = est.position_sigma_m or est.position_sigma_per_hdop_m
    watch = PositionResetWatch(est.position_reset_params())
    position_resets = []               # [t_s, offset_m]: the estimate restarted from a fix
    drift = UnaidedDrift(est.unaided_velocity_sigma_mps if est.position_fusion == "auto" else 0.0)
    reported_yaw = float(nav.slam.mean[2])
    health_s = {state: 0.0 for state in STATES}
    uncertain_arrival_s: float | None = None
    vehicle = scenario.vehicle
    dt = vehicle.dt_s
    obs_every = max(1, round(1.0 / (scenario.sensor.rate_hz * dt)))
    max_steps = int(math.ceil(scenario.mission.max_time_s / dt))
    trace = Trace()
    min_clearance = min_surface = math.inf
    collided = False
    urgent_events = 0
    path_m = 0.0
    max_err = 0.0
    arrived = False
    if copter:                         # the autopilot's first report starts the filter's clock
        first = truth.copter_odometry(0.0)
        nav.on_velocity(0.0, first.vel_north_mps, first.vel_east_mps, first.yaw_rad,
                        first.yaw_rate_rad_s)
    shaped = None                      # the last setpoint (copter): velocity and nose
    blobs = BlobParams(range_sigma_m=scenario.sensor.range_sigma_m,
                       bearing_sigma_rad=scenario.sensor.bearing_sigma_rad,
                       range_sigma_k_per_m=scenario.estimator_config().range_sigma_k_per_m)
    depth = _depth_perception(scenario, seed)
    motion = (truth.vel_ne_mps, float(nav.slam.mean[2]), 0.0)    # for the depth frames' delay
    if depth is None:
        nav.observe(camera_frame(truth, blobs))
    else:
        _observe_depth(nav, depth, truth, motion)
    for step in range(1, max_steps + 1):
        command, change = nav.decide(truth.t_s)
        if plan_sink is not None:
            plan_sink(truth.t_s, nav.vertical_choice, truth)
        if change is not None and change.landmark_index is not None:
            urgent_events += 1
        health_s[nav.health.state] += dt
        if command.mode == "arrived":
            arrived = True
            break
        if command.mode == "arrival_uncertain" and uncertain_arrival_s is None:
            uncertain_arrival_s = truth.t_s
        est_heading = nav.slam.mean[2]
        gamma = limit_turn(est_heading, command.heading_rad, vehicle.max_turn_rate_rad_s, dt)
        before = truth.pose[:2].copy()
        if copter:
            # As the service does (commander.setpoint): the turn-limited velocity direction and
            # nose (the nose apart only when looking at a mover) in the autopilot's yaw frame.
            shaped = shape_setpoint(est_heading, shaped, command, vehicle.max_turn_rate_rad_s,
                                    dt, math.inf)
            nav.on_setpoint(shaped)
            course = wrap_angle(shaped.course_rad + reported_yaw - est_heading)
            nose = wrap_angle(shaped.yaw_rad + reported_yaw - est_heading)
            odo = truth.step_copter(shaped.speed_mps * np.array([math.cos(course),
                                                                 math.sin(course)]), nose)
            nav.on_velocity(truth.t_s, odo.vel_north_mps, odo.vel_east_mps, odo.yaw_rad,
                            odo.yaw_rate_rad_s)
            reported_yaw = odo.yaw_rad
            motion = ((odo.vel_north_mps, odo.vel_east_mps), odo.yaw_rad, odo.yaw_rate_rad_s)
            if fuse:
                nav.slam.inflate_position(drift.step(truth.t_s, truth.gps_available()))
            if fuse and truth.gps_available():
                report = nav.correct_position(*odo.position_ne_m, fix_sigma_m)
                verdict = None if report is None else \
                    watch.on_fix(truth.t_s, report.action, report.innovation)
                if verdict is not None and verdict.reset:
                    # as the service does (pipeline._reset_position): restarted from the fix,
                    # the map dropped
                    position_resets.append([round(truth.t_s, 6), verdict.offset_m])
                    nav = make_navigator(scenario, strategy,
                                         np.array([*odo.position_ne_m, odo.yaw_rad]))
                    nav.on_velocity(truth.t_s, odo.vel_north_mps, odo.vel_east_mps, odo.yaw_rad,
                                    odo.yaw_rate_rad_s)
        else:
            odo = truth.step(command.speed_mps, gamma)
            nav.predict(odo.speed_mps, odo.heading_change_rad, dt)
            heading = float(nav.slam.mean[2])
            motion = (odo.speed_mps * np.array([math.cos(heading), math.sin(heading)]), heading,
                      odo.heading_change_rad / dt)
        step_m = float(np.hypot(*(truth.pose[:2] - before)))
        path_m += step_m
        alt_before = truth.altitude_m
        choice = nav.vertical_choice
        nav.on_altitude(truth.step_vertical(choice.climb_mps if choice is not None else 0.0))
        rise = truth.altitude_m - alt_before
        path_3d_m += math.hypot(step_m, rise)
        climb_m += max(rise, 0.0)
        alt_range_m = [min(alt_range_m[0], truth.altitude_m), max(alt_range_m[1], truth.altitude_m)]
        if depth is not None:
            _observe_depth(nav, depth, truth, motion)
        elif step % obs_every == 0:
            nav.observe(camera_frame(truth, blobs))
        clear = truth.clearance()
        min_clearance = min(min_clearance, clear.clearance_m)
        min_surface = min(min_surface, clear.surface_m)
        collided = collided or clear.surface_m < 0.0
        est = nav.slam.pose
        max_err = max(max_err, float(np.hypot(*(est[:2] - truth.pose[:2]))))
        trace.t_s.append(truth.t_s)
        trace.true_pose.append(truth.pose.copy())
        trace.est_pose.append(est)
        trace.pose_nees.append(pose_nees(truth.pose, est, nav.slam.pose_cov))
    goal = np.array([scenario.world.goal.north_m, scenario.world.goal.east_m])
    final_goal_distance = float(np.hypot(*(truth.pose[:2] - goal)))
    reached = arrived and final_goal_distance <= scenario.world.goal.radius_m + ARRIVAL_ALLOWANCE_M
    est = nav.slam.pose
    summary = {
        "seed": seed,
        "reached_goal": bool(reached),
        "time_s": round(truth.t_s, 6),
        "min_clearance_m": min_clearance if math.isfinite(min_clearance) else None,
        "min_surface_clearance_m": min_surface if math.isfinite(min_surface) else None,
        "collided": collided,
        "final_goal_distance_m": final_goal_distance,
        "final_position_error_m": float(np.hypot(*(est[:2] - truth.pose[:2]))),
        "max_position_error_m": max_err,
        "landmark_errors_m": landmark_errors(nav, truth),
        "urgent_events": urgent_events,
        "path_length_m": path_m,
        "arrived": arrived,
        "arrival_uncertain_t_s": uncertain_arrival_s,
        "final_pose_2sigma_m": radius_2sigma_m(nav.slam.pose_cov),
        "estimator_state_s": health_s,
        "estimator_state_changes": [[round(h.t_s, 3), h.state, h.reason]
                                    for h in nav.health_changes],
        "position_fixes": dict(nav.position_fixes),
        "position_resets": position_resets,
        "landmarks": {"final": nav.slam.landmark_count,
                      "final_confirmed": sum(nav.lifecycle.state(k) == "confirmed"
                                             for k in nav.slam.landmark_ids()),
                      "obstacles_seen": len(truth.seen_ids),
                      **nav.lifecycle.counts},
    }
    if depth is not None:
        summary["depth"] = depth.summary()
    if nav.archive is not None:                     # the bounded map, when configured
        summary["landmarks"].update(in_archive=len(nav.archive), **nav.archive.counts)
    if three_d:
        summary["vertical"] = {
            "path_3d_m": path_3d_m, "climb_m": climb_m, "min_altitude_m": alt_range_m[0],
            "max_altitude_m": alt_range_m[1], "final_altitude_m": truth.altitude_m,
            "points": dict(nav.points), "landmarks_with_top": sum(
                1 for k in nav.slam.landmark_ids() if k in nav.extents
                and nav.extents[k].top_m is not None)}
    return RunOutcome(summary, trace, nav.slam.landmarks(), nav.slam.landmark_covs(),
                      truth.obstacle_positions())


def landmark_errors(nav: Navigator, truth: TruthWorld) -> list[float]:
    """Error of each mapped obstacle: by id when ids are known, else the nearest landmark."""
    landmarks = nav.slam.landmarks()
    ids = nav.slam.landmark_ids()
    errors = []
    for oid, centre in zip(truth.obstacle_ids, truth.obstacle_positions()):
        if oid in ids:
            errors.append(float(np.hypot(*(landmarks[ids.index(oid)] - centre))))
        elif len(landmarks) and any(i is None or i < 0 for i in ids):
            gaps = np.hypot(*(landmarks - centre).T)
            if gaps.min() < 5.0:
                errors.append(float(gaps.min()))
    return errors


def aggregate(outcomes: list[RunOutcome], safety_distance_m: float) -> dict:
    """The aggregate block of the JSON report."""
    return aggregate_summaries([o.summary for o in outcomes],
                               [o.trace.pose_nees for o in outcomes], safety_distance_m)
