"""The decider: guidance on the obstacle view, where the nose looks, and the urgency it implies.

One of three horizontal laws (``STRATEGIES``: the paper's cone, the union of cones or its
flyable velocity choice, Khatib's APF), in 3D the altitude plans scored over it
(core/avoidance/vertical.py); the command moderated by the estimator's health
(estimator_options.moderate); the nose turned toward a mover to watch (look_at) or the goal.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from companion.core.avoidance import vertical as vertical3d
from companion.core.avoidance.arc import Motion, VehicleLimits
from companion.core.avoidance.barrier import barrier_detour_m
from companion.core.avoidance.commitment import Commitment
from companion.core.avoidance.flank_scan import FlankScan, FlankScanParams
from companion.core.avoidance.guidance import (GuidanceCommand, GuidanceInputs, GuidanceParams,
                                               ShapedSetpoint, guide_apf, guide_cone)
from companion.core.avoidance.look_at import (GoalLookParams, LookAtParams, goal_look_yaw,
                                              threat_to_watch)
from companion.core.avoidance.path_follow import guide_with_plan
from companion.core.avoidance.seen_space import SeenSpace
from companion.core.avoidance.union import MAX_SPREAD_M, UnionParams, guide_union
from companion.core.avoidance.velocity_choice import guide_flyable
from companion.core.estimation.estimator import Estimator
from companion.core.estimation.movers import approaching, mover_growth
from companion.core.estimator_options import moderate
from companion.core.geometry import is_visible, wrap_angle
from companion.core.navigation.obstacle_view import ObstacleView

STRATEGIES = ("cone", "union", "apf")
LOOK_COURSE_MIN_SPEED_MPS = 0.5   # slower, the velocity's direction is noise: the last choice's
NO_LOOK_MODES = ("arrived", "arrival_uncertain")
GOAL_LOOK_STEADY_RAD = math.radians(15.0)  # the goal look only while the choice is this near
                                           # the course flown (not turning)
GOAL_LOOK_BACK_RAD = math.radians(3.0)     # its nose is back along the course within this


@dataclass(frozen=True)
class UrgencyChange:
    """Emitted when the most urgent obstacle changes: became urgent (index) or cleared (None)."""
    t_s: float
    landmark_index: int | None
    obstacle_id: int | None
    time_to_go_s: float | None


class Decider:
    """The decision on the obstacle view; ``goal`` and ``params`` may be replaced in flight."""

    def __init__(self, estimator: Estimator, view: ObstacleView, params: GuidanceParams,
                 goal: np.ndarray, strategy: str, union: UnionParams,
                 limits: VehicleLimits | None, look_at: LookAtParams | None,
                 goal_look: GoalLookParams | None,
                 vertical: vertical3d.VerticalParams | None) -> None:
        if strategy not in STRATEGIES:
            raise ValueError(f"unknown strategy {strategy!r}")
        self.estimator = estimator
        self.view = view
        self.params = params
        self.goal = np.asarray(goal, dtype=float)
        self.strategy = strategy
        self.union = union
        self.limits = limits            # union: choose velocities the vehicle can fly (arc.py)
        self.look_at = look_at
        # what the nose points at, if anything: a mover's track id, or ("landmark", key) for a
        # landmark on probation already flown around as a mover (ObstacleView.young_motion)
        self.watching: int | tuple | None = None
        self._last_heading: float | None = None
        self._side = 0
        self._kept_path: np.ndarray | None = None   # the path followed last (path_search keep)
        self.commitment = Commitment()  # the velocity choice's side, kept by progress
        # what the camera has looked at (velocity choice with a camera range only)
        archive = estimator.options.archive
        self.seen = SeenSpace(union.fov_rad, union.sensor_range_m,
                              keep_m=None if archive is None     # the bounded map's
                              else 2.0 * (archive.behind_m + union.sensor_range_m),
                              # seen, not yet mapped (speed_limit.unseen_margins)
                              recent_s=union.perception_delay_s
                              if union.seen_speed_limit and union.perception_delay_s > 0.0
                              else None) \
            if limits is not None and union.sensor_range_m is not None else None
        # a fixed camera's look beyond the view's edges (velocity choice; off unless configured)
        self.scan = FlankScan(FlankScanParams(union.fov_rad, union.flank_scan_rad,
                                              union.flank_scan_period_s)) \
            if limits is not None and union.flank_scan_rad is not None else None
        self._looked: list = []         # (base heading, look heading) of this decision
        self.goal_look = goal_look
        self._goal_apart = False        # the nose looked toward the goal (or still comes back)
        self._setpoint_from: float | None = None    # on_setpoint
        self._urgent: tuple | None = None
        self.vertical = vertical
        self.vertical_choice: vertical3d.VerticalChoice | None = None

    def mark_view(self) -> None:
        """A camera frame: what the camera has in view now is seen (SeenSpace, FlankScan)."""
        slam = self.estimator.slam
        if self.seen is not None:
            for yaw in self.union.view_yaws_rad:    # each camera's view (one: yaw 0)
                self.seen.mark(np.array([slam.pose[0], slam.pose[1], slam.pose[2] + yaw]),
                               self.estimator.clock_s)
        if self.scan is not None:
            self.scan.mark(self.estimator.clock_s, float(slam.pose[2]))

    def track_keeper(self):
        """For movers.prune: the predicate on a coasting track's MoverState that keeps it: the
        camera cannot see it near (``_unseeable_near``), or with ``keep_tracks_horizon_s`` it
        may still meet the vehicle (``_approaching``); a multicopter's only (a unicycle's
        flights stay as they were; the same reason holds); None: none kept."""
        copter = self.limits is not None and self.limits.lateral_accel_limited
        near = (self.union.keep_near_tracks or self.union.evade_movers) and copter \
            and self.union.sensor_range_m is not None
        meets = copter and self.union.keep_tracks_horizon_s is not None
        if near and meets:
            return lambda track: self._unseeable_near(track.position_ne_m) \
                or self._approaching(track)
        if near:
            return lambda track: self._unseeable_near(track.position_ne_m)
        return self._approaching if meets else None

    def _approaching(self, track) -> bool:
        """A coasting track whose closest approach, the vehicle flying on or stopped, comes
        within d inside ``keep_tracks_horizon_s`` (movers.approaching), whatever the range."""
        pose = self.estimator.slam.pose
        speed, course = self.estimator.velocity_now or (0.0, float(pose[2]))
        velocity = speed * np.array([math.cos(course), math.sin(course)])
        return approaching(track, pose[:2], velocity, self.union.keep_tracks_horizon_s,
                           self.params.safety_distance_m, MAX_SPREAD_M)

    def _unseeable_near(self, position: np.ndarray) -> bool:
        """A coasting track predicted within the camera's range of the vehicle but outside its
        view: kept (movers.prune) until the camera could have seen it there (a multicopter's
        velocity choice with a camera range only)."""
        pose = self.estimator.slam.pose
        gap = np.asarray(position, dtype=float) - pose[:2]
        range_m = float(np.hypot(*gap))
        bearing = wrap_angle(math.atan2(gap[1], gap[0]) - float(pose[2]))
        return range_m <= self.union.sensor_range_m \
            and not is_visible(range_m, bearing, self.union.fov_rad, self.union.sensor_range_m,
                               self.union.view_yaws_rad)

    def obstacles(self, young_movers: bool = False):
        """The obstacle view's rows (ObstacleView.obstacles), inflated as ``params`` says."""
        return self.view.obstacles(self.params.inflation_sigmas > 0, young_movers)

    def _moderate(self, command: GuidanceCommand) -> GuidanceCommand:
        est = self.estimator
        return moderate(command, est.assess(), est.options, float(est.slam.mean[2]))

    def _motion(self, pose: np.ndarray) -> Motion | None:
        """The vehicle's limits and its velocity now (cruising along the yaw before any odometry)."""
        if self.limits is None:
            return None
        speed, course = self.estimator.velocity_now or (self.params.cruise_speed_mps,
                                                        float(pose[2]))
        return self.limits.motion(speed, course, float(pose[2]), self._setpoint_from)

    def on_setpoint(self, shaped: ShapedSetpoint) -> None:
        """The setpoint just sent (guidance.ShapedSetpoint): while its nose is apart from its
        velocity's direction, the next one turns from that direction, not from the nose, and the
        next decision's roll-outs start their setpoint there too (Motion.setpoint_rad). Read from
        the nose or the velocity instead, a stop's direction turned on with the commands to stop
        and turn while the vehicle braked along its old velocity, and the next command was flown
        from there, not as rolled out (forest-dense 7 m/s seed 12: a trunk passed at 0.95 m)."""
        self._setpoint_from = float(shaped.course_rad) if shaped.apart else None

    def _flight_pose(self, pose: np.ndarray) -> np.ndarray:
        """The pose guidance sees: while the nose looks at a mover, its yaw is the direction the
        vehicle flies (the velocity's, or the last choice's when nearly still), since the choice
        reads the yaw as where the vehicle goes and what its camera has in view. The same while
        the goal look's nose is apart, if the vehicle flies (slower: the nose's own yaw)."""
        speed, course = self.estimator.velocity_now or (0.0, float(pose[2]))
        if self.watching is None and self._goal_apart:
            if speed < LOOK_COURSE_MIN_SPEED_MPS:
                return pose
            return np.array([pose[0], pose[1], wrap_angle(course)])
        if self.watching is None:
            return pose
        if speed < LOOK_COURSE_MIN_SPEED_MPS and self._last_heading is not None:
            course = self._last_heading
        return np.array([pose[0], pose[1], wrap_angle(course)])

    def _watch(self, command: GuidanceCommand, movers: list) -> GuidanceCommand:
        """The command with the nose toward the mover to watch, if any (look_at)."""
        self.watching = None
        # the tracks, and the landmarks on probation the velocity choice flies round as movers (a
        # crossing mover seen for a second before it left the view is one of those, not a track)
        candidates = [(m.track_id, m.position_ne_m, m.velocity_ne_mps) for m in movers] + \
            [(("landmark", key), position, velocity)
             for key, position, velocity in self.view.young_movers]
        if self.look_at is None or not candidates or command.mode in NO_LOOK_MODES \
                or command.mode.startswith("hold: "):
            return command
        watch = threat_to_watch(self.estimator.slam.pose[:2], command.heading_rad,
                                command.speed_mps, np.array([c[1] for c in candidates]),
                                np.array([c[2] for c in candidates]), self.look_at)
        if watch is None:
            return command
        self.watching = candidates[watch.index][0]
        return replace(command, yaw_rad=watch.bearing_rad)

    def _look_toward_goal(self, command: GuidanceCommand) -> GuidanceCommand:
        """The command with the nose toward the goal's direction (look_at.goal_look_yaw) while
        nothing is watched and the vehicle flies on steadily: moving, and the choice within
        GOAL_LOOK_STEADY_RAD of the course it flies (a turn, a turn in place or a hold brings the
        nose back along the way). Only ``yaw_rad`` changes."""
        pose = self.estimator.slam.pose
        speed, course = self.estimator.velocity_now or (0.0, float(pose[2]))
        steady = (self.watching is None and command.yaw_rad is None
                  and command.mode not in NO_LOOK_MODES and not command.mode.startswith("hold")
                  and speed >= LOOK_COURSE_MIN_SPEED_MPS
                  and command.speed_mps >= LOOK_COURSE_MIN_SPEED_MPS
                  and abs(wrap_angle(command.heading_rad - course)) <= GOAL_LOOK_STEADY_RAD)
        yaw = goal_look_yaw(command.heading_rad, math.atan2(self.goal[1] - pose[1],
                                                            self.goal[0] - pose[0]),
                            self.goal_look) if steady else None
        if yaw is None:
            # apart until the nose is back along the course (or the vehicle slows: its own yaw)
            self._goal_apart = self._goal_apart and speed >= LOOK_COURSE_MIN_SPEED_MPS and \
                abs(wrap_angle(float(pose[2]) - course)) > GOAL_LOOK_BACK_RAD
            return command
        self._goal_apart = True
        return replace(command, yaw_rad=yaw)

    def _look_for(self, heading: float) -> float | None:
        """The flank scan's heading instead of the chosen ``heading`` (flank_scan.py), if any."""
        swing = self.scan.look(self.estimator.clock_s, heading)
        if swing is not None:
            self._looked.append((heading, swing))
        return swing

    def _decide_2d(self, pose: np.ndarray, t_s: float, skip: frozenset = frozenset()):
        """The horizontal law's command with the landmark rows ``skip`` (flown over or under)
        left out, its movers, and what to commit if it is flown (the union law's side and
        commitment). Without ``skip``: the 2D decision as it always was."""
        view = self.view
        young_movers = self.strategy == "union" and self.limits is not None
        obstacles, velocities, rel_covs, movers = self.obstacles(young_movers)
        view.young_movers = []
        if self.strategy == "apf":
            obstacles, _, _, _ = view.drop_rows(skip, obstacles)
            return guide_apf(pose, self.goal, obstacles, self.params), movers, lambda c: None
        if self.strategy == "union":
            growth = mover_growth(movers, len(obstacles), self.union.mover_sigmas)
            motion = self._motion(pose)
            if motion is not None:
                obstacles, velocities, growth = view.young_motion(obstacles, velocities, growth)
            spread = view.spread(movers, len(obstacles), motion)
            if skip:
                obstacles, velocities, rel_covs, (growth, spread) = view.drop_rows(
                    skip, obstacles, velocities, rel_covs, growth, spread)
            goal_distance = float(np.hypot(*(self.goal - pose[:2])))
            reach = None if motion is None else self.commitment.goal_reach_m(
                goal_distance, self.params.safety_distance_m, self.union.sensor_range_m or 0.0)
            inputs = GuidanceInputs(
                pose=pose, goal=self.goal, obstacles=obstacles, rel_covs=rel_covs,
                previous_heading_rad=self._last_heading,
                side=self.commitment.side if motion is not None else self._side,
                velocities=velocities, motion=motion, growth_mps=growth,
                clear_reach_m=reach or None, seen=self.seen, spread_m=spread,
                look=self._look_for if self.scan is not None else None,
                kept_path_ne_m=self._kept_path)
            plan = None
            if motion is None:
                command = guide_union(inputs, self.params, self.union)
            elif self.union.path is None:
                command = guide_flyable(inputs, self.params, self.union)
            else:
                command, plan = guide_with_plan(inputs, self.params, self.union)

            def commit(chosen: GuidanceCommand) -> None:
                self._side = chosen.side
                if self.union.path is not None and self.union.path.keep_weight > 0.0:
                    # the path and its straight line from the grid's edge to the goal
                    self._kept_path = None if plan is None or not plan.found else \
                        np.vstack([plan.points_ne_m, self.goal])
                if motion is not None and chosen.mode != "arrived":
                    self.commitment = self.commitment.after(chosen.side, goal_distance)
            return command, movers, commit
        obstacles, velocities, rel_covs, _ = view.drop_rows(skip, obstacles, velocities, rel_covs)
        return (guide_cone(pose, self.goal, obstacles, rel_covs, self.params, t_s, velocities),
                movers, lambda c: None)

    def _decide_3d(self, pose: np.ndarray, t_s: float):
        """Each altitude plan's horizontal command, scored (core/avoidance/vertical.py); the
        least costly one's command, with ``vertical_choice`` set."""
        params, view = self.vertical, self.view
        obstacles, _, _, _ = self.obstacles(self.strategy == "union" and self.limits is not None)
        extents = [view.extent_of(key) for key in view.guidance_keys]
        extents += [vertical3d.UNBOUNDED] * (len(obstacles) - len(extents))
        alt = float(self.estimator.altitude_m)
        to_goal = self.goal - pose[:2]
        ahead = to_goal / max(float(np.hypot(*to_goal)), 1e-9)
        speed_now, course = self.estimator.velocity_now or (params.cruise_speed_mps,
                                                             float(pose[2]))
        if speed_now < LOOK_COURSE_MIN_SPEED_MPS:
            course = float(pose[2])
        scored, results = [], []
        for plan in vertical3d.plans(pose[:2], alt, obstacles, extents, params, ahead, speed_now):
            command, movers, commit = self._decide_2d(pose, t_s, plan.skip)
            if plan.speed_mps is not None and command.speed_mps > plan.speed_mps:
                command = replace(command, speed_mps=plan.speed_mps)
            rows = [i for i in range(len(obstacles)) if i not in plan.skip
                    and float(np.hypot(*(obstacles[i] - pose[:2]))) <= params.reach_m]
            hold = command.mode in ("hold", "stop", "escape") or command.mode.startswith("hold")
            detour = vertical3d.detour_m(pose[:2], self.goal, command.heading_rad, obstacles,
                                         rows) + (0.0 if command.mode != "slow" else 20.0)
            if params.barrier_cost:     # round the side the vehicle flies toward now
                unskipped = [i for i in range(len(obstacles)) if i not in plan.skip]
                detour = max(detour, barrier_detour_m(pose[:2], self.goal, course, obstacles,
                                                      unskipped, params.safety_distance_m))
            scored.append((plan, vertical3d.plan_cost_m(plan, alt, detour, hold, params)))
            results.append((command, movers, commit, plan.skip))
        last = self.vertical_choice.plan.kind if self.vertical_choice is not None else None
        choice = vertical3d.choose(scored, last, alt, params)
        self.vertical_choice = choice
        command, movers, commit, skip = results[[p for p, _ in scored].index(choice.plan)]
        if len(scored) > 1:        # the guidance keys of the plan flown (the last evaluated's now)
            self.obstacles(self.strategy == "union" and self.limits is not None)
            view.drop_rows(skip, obstacles)
        return command, movers, commit

    def decide(self, t_s: float) -> tuple[GuidanceCommand, UrgencyChange | None]:
        """Guidance on the current estimate, and the urgency change it implies, if any."""
        pose = self._flight_pose(self.estimator.slam.pose)
        if self.vertical is not None and self.estimator.altitude_m is not None:
            command, movers, commit = self._decide_3d(pose, t_s)
        else:
            command, movers, commit = self._decide_2d(pose, t_s)
        commit(command)
        self._last_heading = command.heading_rad
        if self._looked:
            self._last_heading = self._looked[-1][0]     # the choice's, not a look's
        self._looked = []
        command = self._watch(self._moderate(command), movers)
        if self.goal_look is not None:
            command = self._look_toward_goal(command)
        key = self.view.key(command.urgent_index, movers)
        change = None
        if key != self._urgent:
            self._urgent = key
            oid = key[1] if key is not None and key[0] == "landmark" and key[1] >= 0 else None
            change = UrgencyChange(t_s, command.urgent_index, oid, command.time_to_go_s)
        return command, change
