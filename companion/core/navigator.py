"""The estimate-and-guide pipeline shared by ``simulate``, the live service and ``replay``.

Pure: odometry and observations go in with their times, guidance commands come out. Whoever feeds
it (the in-process truth world, MAVLink, a tlog) cannot be told apart from here.
"""
from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field, replace

import numpy as np

from companion.core.estimation.association import associate_frame
from companion.core.perception.blobs import SurfacePoint
from companion.core.avoidance.commitment import Commitment
from companion.core.avoidance.seen_space import SeenSpace
from companion.core.estimation.consistency import Consistency, ConsistencyMonitor
from companion.core.avoidance.flank_scan import FlankScan, FlankScanParams
from companion.core.estimation.ekf_slam import EkfSlam
from companion.core.estimation.slam_types import (AssociationGates, Observation, SlamNoise,
                                                  UpdateReport)
from companion.core.estimator_options import EstimatorOptions, moderate
from companion.core.sample_interval import (MeanInterval, at_least_reference_s,
                                            interval_turn_rate, long_interval)
from companion.core.geometry import is_visible, move, move_velocity, place, wrap_angle
from companion.core.estimation.lifecycle import Lifecycle, expected_visible
from companion.core.estimation.map_archive import MapArchive, stale
from companion.core.estimation.motion_evidence import is_straight_track, shared_yaw_velocity_cov
from companion.core.estimation.range_noise import with_range_model
from companion.core.perception.surface_cover import covering_nis
from companion.core.avoidance.guidance import (GuidanceCommand, GuidanceInputs, GuidanceParams,
                                               guide_apf, guide_cone)
from companion.core.avoidance.arc import Motion, VehicleLimits
from companion.core.avoidance.look_at import GoalLookParams, LookAtParams, goal_look_yaw, threat_to_watch
from companion.core.estimation.movers import (MoverParams, MoverTracker, apparent_velocity, mover_growth,
                                   mover_spread, start_evidence, world_measurement)
from companion.core.avoidance.path_follow import guide_along_path
from companion.core.avoidance.union import UnionParams, guide_union
from companion.core.avoidance.velocity_choice import guide_flyable
from companion.core.avoidance import vertical as vertical3d
from companion.core.perception.vertical_extent import (ExtentParams, PointHeights, VerticalExtent,
                                                       classify, in_vertical_view)

# An observation frame stamped at most this much after the last odometry is processed at once
# (the pose is that close); a later one waits for the odometry that covers its time.
STRATEGIES = ("cone", "union", "apf")
MAX_MOVER_SPEED_MPS = 3.0      # an id-less young landmark may have moved this fast...
MOVED_GATE_M = 1.5             # ...plus this, between two sightings...
MOVED_MAX_GAP_S = 1.0          # ...at most this long apart (five frames missed in a row at 5 Hz):
                               # a young landmark unseen for longer is no track to extend (its reach
                               # would grow without bound and take another obstacle's sightings)
FRAME_TIMING_UNCERTAINTY_S = 0.05   # half an odometry period at 10 Hz; half the measured one if longer
SAME_TIME_TOLERANCE_S = 1e-3
LOOK_COURSE_MIN_SPEED_MPS = 0.5   # slower, the velocity's direction is noise: the last choice's
NO_LOOK_MODES = ("arrived", "arrival_uncertain")
GOAL_LOOK_STEADY_RAD = math.radians(15.0)  # the goal look only while the choice is this near
                                           # the course flown (not turning)
GOAL_LOOK_BACK_RAD = math.radians(3.0)     # its nose is back along the course within this
MAX_PENDING_FRAMES = 8
SPREAD_MIN_UPDATES = 5         # a track's position sigma widens its safety distance once this
                               # many sightings confirm it (one second in view at 5 Hz)


@dataclass(frozen=True)
class UrgencyChange:
    """Emitted when the most urgent obstacle changes: became urgent (index) or cleared (None)."""
    t_s: float
    landmark_index: int | None
    obstacle_id: int | None
    time_to_go_s: float | None


@dataclass
class _Young:
    """A landmark on probation: its dead-reckoned world points and its last observation."""
    times: list = field(default_factory=list)
    points: list = field(default_factory=list)
    sigmas: list = field(default_factory=list)          # each point's standard deviation, m
    # ... of it, what is the point's own (the measurement's, the frame timing's), m
    free_sigmas: list = field(default_factory=list)
    # and what the pose's yaw error does (motion_evidence.shared_yaw_velocity_cov): each point's
    # range (m), world direction (rad), the yaw variance it was placed with (rad^2) and the
    # filter's running log yaw transfer then (_yaw_transfer_log)
    ranges: list = field(default_factory=list)
    directions: list = field(default_factory=list)
    yaw_vars: list = field(default_factory=list)
    yaw_logs: list = field(default_factory=list)
    last_obs: Observation | None = None
    # _apparent_velocity's answer for the first n sightings, (n, velocity, sigma): the lists
    # only grow, and the answer depends on them alone, so each decision need not redo it
    apparent: tuple | None = None


class Navigator:
    """EKF-SLAM plus guidance. ``strategy``: 'cone' (the paper) or 'apf' (Khatib)."""

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
        (core/avoidance/look_at.py); the command then carries ``yaw_rad``. ``goal_look`` (a multicopter's
        only): while it watches nothing, its nose turns toward the goal's direction when the
        velocity swerves (core/avoidance/look_at.py goal_look_yaw). ``extent``: observations with
        a z are judged against the altitude (``on_altitude``): the floor and bad points dropped
        and counted (``points``), each landmark's vertical extent kept (``extents``).
        ``vertical``: avoidance in 3D (core/avoidance/vertical.py); ``vertical_choice`` holds the
        last decision's plan and climb rate."""
        if strategy not in STRATEGIES:
            raise ValueError(f"unknown strategy {strategy!r}")
        self.slam = EkfSlam(start_pose, start_pose_cov, noise, gates)
        self.options = options
        self.monitor = ConsistencyMonitor(options.monitor)
        self.health: Consistency | None = None
        self.health_changes: list[Consistency] = []     # every change of state, in order
        self.position_fixes = {"fused": 0, "refused": 0}
        self._last_fix_s: float | None = None
        self._last_velocity: tuple[float, float] | None = None   # NED, at the last sample
        self._crab_mps: deque[tuple[float, float]] = deque()   # paper model: (t, unmodelled speed)
        self.params = params
        self.goal = np.asarray(goal, dtype=float)
        self.strategy = strategy
        self.union = union
        self.limits = limits            # union: choose velocities the vehicle can fly (arc.py)
        self._velocity_now: tuple[float, float] | None = None    # speed, course: last odometry
        self.look_at = look_at
        # what the nose points at, if anything: a mover's track id, or ("landmark", key) for a
        # landmark on probation already flown around as a mover (_young_motion)
        self.watching: int | tuple | None = None
        self._young_movers: list[tuple] = []  # (key, position, velocity) of those, this decision
        self._young_spread: np.ndarray | None = None   # their extrapolation's sigma, m (by row)
        self._young_found: dict = {}            # _young_evidence of this decision, by key
        self._last_heading: float | None = None
        self._side = 0
        self.commitment = Commitment()  # the velocity choice's side, kept by progress
        # what the camera has looked at (velocity choice with a camera range only)
        self.seen = SeenSpace(union.fov_rad, union.sensor_range_m,
                              keep_m=None if options.archive is None     # the bounded map's
                              else 2.0 * (options.archive.behind_m + union.sensor_range_m)) \
            if limits is not None and union.sensor_range_m is not None else None
        # a fixed camera's look beyond the view's edges (velocity choice; off unless configured)
        self.scan = FlankScan(FlankScanParams(union.fov_rad, union.flank_scan_rad,
                                              union.flank_scan_period_s)) \
            if limits is not None and union.flank_scan_rad is not None else None
        self._looked: list = []         # (base heading, look heading) of this decision
        self.goal_look = goal_look
        self._goal_apart = False        # the nose looked toward the goal (or still comes back)
        self._urgent: tuple | None = None
        self.clock_s = 0.0                     # the filter's time: odometry time, or summed dt
        self.movers = MoverTracker(mover_params)
        self.mover_params = mover_params
        self._strikes: dict[int, int] = {}
        self._strike_points: dict[int, _Young] = {}   # an old landmark's refused sightings
        self._dr_pose = np.array(start_pose, dtype=float)   # odometry only, never corrected
        self._young: dict[int, _Young] = {}
        # the log of the factor by which the corrections so far scaled the filter's yaw error
        # (_yaw_transfer_log), and the yaw variance it was last brought up to date at
        self._yaw_log_transfer = 0.0
        self._yaw_var_mark: float | None = None
        self.movers_detected = 0
        self._next_anonymous_id = -1
        self._turn_rate_rad_s = 0.0
        self._frame_timing_s = 0.0      # how far the heading used may be from the frame's time
        self._odometry_intervals = MeanInterval()   # the odometry's measured period (issue 32)
        self._point_sigma_m = math.hypot(noise.range_sigma_m, 40.0 * noise.bearing_sigma_rad)
        self.t_s: float | None = None          # time of the last odometry the filter has absorbed
        self._yaw_rad: float | None = None
        self._pending: deque[tuple[float, list[Observation]]] = deque()
        self.rejected: dict[str, int] = {}
        self.lifecycle = Lifecycle(options.lifecycle)
        self._frame_hits: set[int] = set()      # landmark keys detected in the current frame
        self._frame_near: set[int] = set()      # ... come near by an ambiguous observation
        self._frame_added: set[int] = set()
        self._frame_taken: set[int] = set()     # ... planned for update by the frame's association
        self._guidance_keys: list = []          # landmark key of each landmark row of obstacles()
        # the bounded map (off unless configured): landmarks left behind, marginalised out
        self.archive = MapArchive(options.archive) if options.archive is not None else None
        self._last_seen: dict[int, float] = {}   # landmark key: last detection (archive only)
        self.extent_params = extent
        self.vertical = vertical
        self.altitude_m: float | None = None    # above the ground, the autopilot's
        self.extents: dict = {}                 # landmark key -> VerticalExtent
        self.points = {"ground": 0, "bad_z": 0}
        self.vertical_choice: vertical3d.VerticalChoice | None = None

    # ------------------------------------------------------ timed inputs
    # The live service and the replay feed messages through these two methods, stamped with the
    # messages' own clock (time_boot_ms), so the same stream gives the same estimates anywhere.
    def on_odometry(self, t_s: float, speed_mps: float, yaw_rad: float,
                    course_rad: float | None = None) -> list[UpdateReport]:
        """Absorb one odometry sample: the speed over the interval ending at ``t_s`` and the
        autopilot's (gyro-integrated) yaw at ``t_s``. The heading change is the yaw difference, so
        a lost sample costs no heading. Then process any observation frames this time covers.

        ``course_rad``, the direction of the velocity if known: the unicycle flies along its yaw,
        so the difference of the two velocities, 2 speed |sin((course - yaw) / 2)|, is motion this
        model does not have; the mover test allows for it (a crabbing vehicle's dead reckoning
        sees static obstacles drift by that much).
        """
        if not (math.isfinite(t_s) and math.isfinite(speed_mps) and math.isfinite(yaw_rad)) \
                or speed_mps < 0.0:
            self._reject("odometry_not_finite")
            return []
        if course_rad is not None and math.isfinite(course_rad):
            self._crab_mps.append(
                (t_s, 2.0 * speed_mps * abs(math.sin(0.5 * wrap_angle(course_rad - yaw_rad)))))
        if self.t_s is None:
            self.t_s, self._yaw_rad, self.clock_s = t_s, yaw_rad, t_s
            return self._release()
        dt = t_s - self.t_s
        if dt <= 0.0:
            self._reject("odometry_not_newer")
            return []
        self._odometry_intervals.add(dt)
        turn = wrap_angle(yaw_rad - self._yaw_rad)
        # A frame captured inside this interval (its own odometry sample was lost) is observed
        # at its time: predict to it on a pro-rata share of the interval, then the rest. The
        # speed sample's error is one error over the whole interval; scaling its variance by
        # dt / part keeps the parts' sum equal to the whole.
        reports: list[UpdateReport] = []
        start, cursor, turned = self.t_s, self.t_s, 0.0
        while self._pending and self._pending[0][0] < t_s - SAME_TIME_TOLERANCE_S:
            frame_t_s, observations = self._pending.popleft()
            part = frame_t_s - cursor
            if part > SAME_TIME_TOLERANCE_S:
                # The heading at the frame's time is interpolated: the vehicle may have done the
                # interval's turn early or late. Say so in the heading variance.
                fraction = (frame_t_s - start) / dt
                share = turn * part / dt
                self.predict(speed_mps, share, part, speed_var_scale=dt / part,
                             heading_var_extra=(2.0 * turn * fraction * (1.0 - fraction)) ** 2)
                cursor, turned = frame_t_s, turned + share
            self._frame_timing_s = at_least_reference_s(0.5 * dt, FRAME_TIMING_UNCERTAINTY_S)
            reports.extend(self.observe(observations))
            self._frame_timing_s = 0.0
        rest = t_s - cursor
        self.predict(speed_mps, turn - turned, rest,
                     speed_var_scale=1.0 if cursor == start else dt / rest)
        self.t_s, self._yaw_rad = t_s, yaw_rad
        return reports + self._release()

    def on_velocity(self, t_s: float, vel_north_mps: float, vel_east_mps: float, yaw_rad: float,
                    yaw_rate_rad_s: float) -> list[UpdateReport]:
        """The multicopter's odometry sample: the NED velocity and yaw rate at ``t_s`` and the
        autopilot's yaw then (a measurement of the yaw state). The interval since the last sample
        is flown at the mean of its two velocities (trapezoidal: the velocity at one end would
        misplace the vehicle by half a step's speed change at every acceleration) and turned at
        the yaw rate of ``t_s`` (whatever lag that has, the yaw measurement takes out).
        Frames inside the interval are observed at their own time, as in :meth:`on_odometry`."""
        values = (t_s, vel_north_mps, vel_east_mps, yaw_rad, yaw_rate_rad_s)
        if not all(math.isfinite(v) for v in values):
            self._reject("odometry_not_finite")
            return []
        if self.t_s is None:
            self.t_s, self._yaw_rad, self.clock_s = t_s, yaw_rad, t_s
            self._last_velocity = (vel_north_mps, vel_east_mps)
            self.correct_yaw(yaw_rad)
            return self._release()
        dt = t_s - self.t_s
        if dt <= 0.0:
            self._reject("odometry_not_newer")
            return []
        self._odometry_intervals.add(dt)
        yaw_var_extra = 0.0
        if self.options.velocity_in_yaw_frame and self._yaw_rad is not None:
            # the autopilot's yaw is its gyro's integral: its change is the exact turn over the
            # interval, samples lost on the way included (the rate at one end is not)
            yaw_rate_rad_s = wrap_angle(yaw_rad - self._yaw_rad) / dt
        elif long_interval(dt, self.slam.noise.reference_dt_s) and self._yaw_rad is not None:
            yaw_rate_rad_s, yaw_var_extra = interval_turn_rate(
                self._yaw_rad, yaw_rad, dt, self.options.yaw_sigma_rad)
        last_north, last_east = self._last_velocity or (vel_north_mps, vel_east_mps)
        self._last_velocity = (vel_north_mps, vel_east_mps)
        vel_north_mps = 0.5 * (vel_north_mps + last_north)
        vel_east_mps = 0.5 * (vel_east_mps + last_east)
        reports: list[UpdateReport] = []
        start = cursor = self.t_s
        while self._pending and self._pending[0][0] < t_s - SAME_TIME_TOLERANCE_S:
            frame_t_s, observations = self._pending.popleft()
            part = frame_t_s - cursor
            if part > SAME_TIME_TOLERANCE_S:
                self.predict_velocity(vel_north_mps, vel_east_mps, yaw_rate_rad_s, part,
                                      var_scale=dt / part, yaw_var_extra=yaw_var_extra * part / dt)
                cursor = frame_t_s
            self._frame_timing_s = at_least_reference_s(0.5 * dt, FRAME_TIMING_UNCERTAINTY_S)
            reports.extend(self.observe(observations))
            self._frame_timing_s = 0.0
        rest = t_s - cursor
        self.predict_velocity(vel_north_mps, vel_east_mps, yaw_rate_rad_s, rest,
                              var_scale=1.0 if cursor == start else dt / rest,
                              yaw_var_extra=yaw_var_extra * rest / dt)
        self.correct_yaw(yaw_rad, dt)
        self.t_s, self._yaw_rad = t_s, yaw_rad
        return reports + self._release()

    def on_observations(self, t_s: float, observations: list[Observation]) -> list[UpdateReport]:
        """One camera frame captured at ``t_s``; waits if the odometry has not reached ``t_s``.

        Observations with a non-finite or non-positive range, or a non-finite bearing, are
        refused and counted in ``rejected`` (one NaN would poison the whole state); a frame with
        a non-finite time is refused whole.
        """
        if not math.isfinite(t_s):
            self._reject("frame_time_not_finite")
            return []
        valid = []
        for obs in observations:
            if not (math.isfinite(obs.range_m) and math.isfinite(obs.bearing_rad)):
                self._reject("observation_not_finite")
            elif obs.range_m <= 0.0:
                self._reject("observation_range_not_positive")
            else:
                valid.append(obs)
        observations = valid
        if self.t_s is not None and t_s <= self.t_s + SAME_TIME_TOLERANCE_S:
            self._frame_timing_s = max(self.t_s - t_s, 0.0)       # late: placed with a later pose
            try:
                return self.observe(observations)
            finally:
                self._frame_timing_s = 0.0
        if len(self._pending) >= MAX_PENDING_FRAMES:
            self._pending.popleft()
            self._reject("frame_overflow")
        self._pending.append((t_s, observations))
        return []

    def _release(self) -> list[UpdateReport]:
        reports: list[UpdateReport] = []
        while self._pending and self._pending[0][0] <= self.t_s + SAME_TIME_TOLERANCE_S:
            reports.extend(self.observe(self._pending.popleft()[1]))
        return reports

    def _reject(self, kind: str) -> None:
        self.rejected[kind] = self.rejected.get(kind, 0) + 1

    def predict(self, speed_mps: float, heading_change_rad: float, dt_s: float,
                speed_var_scale: float = 1.0, heading_var_extra: float = 0.0) -> None:
        self.slam.predict(speed_mps, heading_change_rad, dt_s, speed_var_scale, heading_var_extra)
        self.clock_s += max(dt_s, 0.0)
        self._dr_pose = move(self._dr_pose, speed_mps, heading_change_rad, dt_s)
        self._velocity_now = (max(speed_mps, 0.0), float(self.slam.mean[2]))
        if dt_s > 0.0:
            self._turn_rate_rad_s = abs(heading_change_rad) / dt_s

    def predict_velocity(self, vel_north_mps: float, vel_east_mps: float, yaw_rate_rad_s: float,
                         dt_s: float, var_scale: float = 1.0, yaw_var_extra: float = 0.0) -> None:
        """The multicopter model's predict (see EkfSlam.predict_velocity). With
        ``options.velocity_in_yaw_frame`` the velocity is taken as turned by the autopilot's own
        yaw: the yaw state's offset from the last reported yaw (both advance by the same rate)."""
        self._yaw_transfer_log()
        offset = None
        if self.options.velocity_in_yaw_frame and self._yaw_rad is not None:
            offset = wrap_angle(float(self.slam.mean[2]) - self._yaw_rad
                                - yaw_rate_rad_s * (self.clock_s - self.t_s))
        self.slam.predict_velocity(vel_north_mps, vel_east_mps, yaw_rate_rad_s, dt_s,
                                   self.options.velocity_noise, var_scale, offset)
        if yaw_var_extra > 0.0:
            self.slam.inflate_yaw(yaw_var_extra)      # process noise of this predict's
        self._yaw_var_mark = float(self.slam.cov[2, 2])   # a predict carries the error over whole
        self.clock_s += max(dt_s, 0.0)
        self._dr_pose = move_velocity(self._dr_pose, vel_north_mps, vel_east_mps, yaw_rate_rad_s,
                                      dt_s)
        self._velocity_now = (math.hypot(vel_north_mps, vel_east_mps),
                              math.atan2(vel_east_mps, vel_north_mps))
        if dt_s > 0.0:
            self._turn_rate_rad_s = abs(yaw_rate_rad_s)

    def correct_yaw(self, yaw_rad: float, dt_s: float | None = None) -> UpdateReport:
        """The autopilot's yaw as a measurement of the yaw state, ``dt_s`` after the last one
        (its sigma: ``EstimatorOptions.yaw_fix_sigma_rad``); the dead reckoning takes it."""
        self._yaw_transfer_log()
        report = self.slam.update_yaw(yaw_rad, self.options.yaw_fix_sigma_rad(dt_s),
                                      self.options.yaw_gate_nis)
        # a reset first inflated the variance by the squared innovation: its K is the inflated one
        self._yaw_transfer_log(report.innovation[0] ** 2 if report.action == "yaw_reset" else 0.0)
        self.monitor.add(self.clock_s, report.nis, 1)
        self._dr_pose[2] = wrap_angle(yaw_rad)
        return report

    def _yaw_transfer_log(self, inflated_rad2: float = 0.0) -> float:
        """The running log of the factor by which the corrections so far scaled the filter's yaw
        error, brought up to date: the filter's yaw errors at two times t_i <= t_j then have
        Cov(e_i, e_j) = exp(L_j - L_i) P_i. A predict carries the yaw error over whole (F's yaw
        row is e_2) and adds independent noise, so it adds nothing to L; between predicts only
        corrections change the yaw variance, each by its (1 - K H) of the yaw: exact for the
        autopilot's yaw (a direct measurement), and the yaw's own share for a landmark's or a
        position fix (their cross terms with the yaw error are left out). A variance that grows
        between predicts (an inflation, not a correction) leaves the error as it was."""
        var = float(self.slam.cov[2, 2])
        mark = self._yaw_var_mark
        if mark is not None and mark + inflated_rad2 > 0.0:
            self._yaw_log_transfer += math.log(min(max(var, 1e-300) / (mark + inflated_rad2), 1.0))
        self._yaw_var_mark = var
        return self._yaw_log_transfer

    def correct_position(self, north_m: float, east_m: float, sigma_m: float) -> UpdateReport | None:
        """Fuse the autopilot's horizontal position (sigma_m per axis), at most once per
        ``options.position_period_s``: its error is slow (a GPS's), so fixes closer together
        would be counted as independent when they are not. None: not due yet."""
        if not (math.isfinite(north_m) and math.isfinite(east_m) and sigma_m > 0.0):
            self._reject("position_not_finite")
            return None
        if self._last_fix_s is not None \
                and self.clock_s - self._last_fix_s < self.options.position_period_s - 1e-6:
            return None
        self._last_fix_s = self.clock_s
        report = self.slam.update_position(north_m, east_m, sigma_m, self.options.position_gate_nis)
        self.monitor.add(self.clock_s, report.nis, 2)
        self.position_fixes["fused" if report.action == "position" else "refused"] += 1
        return report

    def on_altitude(self, altitude_m: float) -> None:
        """The vehicle's altitude above the ground (LOCAL_POSITION_NED -z, or the truth's);
        a non-finite one is ignored (heights are then not judged)."""
        if math.isfinite(altitude_m):
            self.altitude_m = float(altitude_m)

    def _heights(self, observations: list[Observation]) -> tuple[list, list]:
        """The observations that may become landmarks, and their heights (None: no z): the
        floor's points and those with a bad z dropped and counted."""
        if self.extent_params is None or self.altitude_m is None:
            return list(observations), [None] * len(observations)
        kept, heights = [], []
        for obs in observations:
            verdict = classify(obs.top_down_m, obs.bottom_down_m, obs.range_m, self.altitude_m,
                               self.extent_params)
            if verdict == "ground":
                self.points["ground"] += 1
                continue
            if verdict == "bad":
                self.points["bad_z"] += 1
                continue
            kept.append(obs)
            heights.append(verdict)
        return kept, heights

    def _note_extent(self, report: UpdateReport, heights: PointHeights | None) -> None:
        if heights is None or report.action not in ("updated", "added") \
                or report.landmark_index is None:
            return
        key = self.slam.landmark_ids()[report.landmark_index]
        if key is not None:
            self.extents.setdefault(key, VerticalExtent()).update(heights)

    def observe(self, observations: list[Observation]) -> list[UpdateReport]:
        """One camera frame: static landmarks update the SLAM state, movers only their tracks.

        A landmark seen for the first time is on probation for ``probation_s``: its observations
        correct only itself (a Schmidt update, never the pose or other landmarks), and its world
        points, placed from the dead-reckoned pose (odometry only, which a mover cannot drag
        along), are watched for motion. If it moves, it is marginalised out of the map and
        tracked; the pose never saw it. After probation it is an ordinary landmark.
        """
        used: set[int] = set()
        reports = []
        if self.seen is not None:
            self.seen.mark(self.slam.pose)
        if self.scan is not None:
            self.scan.mark(self.clock_s, float(self.slam.pose[2]))
        self._frame_hits, self._frame_near, self._frame_added = set(), set(), set()
        noise = self.slam.noise
        observations, heights = self._heights(observations)
        observations = with_range_model(observations, noise.range_sigma_m,
                                        self.options.range_sigma_k_per_m, noise.bearing_sigma_rad)
        anonymous = [obs for obs in observations if obs.obstacle_id is None]
        ids = self.slam.landmark_ids()
        plans = {id(obs): (p.action, ids[p.index] if p.index is not None else None)
                 for obs, p in zip(anonymous, associate_frame(
                     self.slam, np.array([[o.range_m, o.bearing_rad] for o in anonymous]),
                     meas_covs=[o.meas_cov_array() for o in anonymous]))}
        self._frame_taken = {key for action, key in plans.values() if action == "update"}
        for obs, height in zip(observations, heights):
            report = self._observe_one(obs, used, plans.get(id(obs)))
            if report.action in ("updated", "added") and report.landmark_index is not None:
                used.add(report.landmark_index)
                self._note_extent(report, height)
            reports.append(report)
        reports.extend(self._judge_young())
        reports.extend(self._judge_lifecycle())
        if self.archive is not None:
            reports.extend(self._bound_map())
        # a multicopter's only (a unicycle's flights stay as they were; the same reason holds)
        keep = (self.union.keep_near_tracks or self.union.evade_movers) and self.limits is not None \
            and self.limits.lateral_accel_limited and self.union.sensor_range_m is not None
        self.movers.prune(self.clock_s, self._unseeable_near if keep else None)
        return reports

    def _bound_map(self) -> list[UpdateReport]:
        """The bounded map (core/estimation/map_archive.py): this frame's new landmarks take the place of
        the archived ones they are; landmarks (not tentative) behind, far and unseen leave the
        filter (marginalised: their rows and columns deleted) for the archive."""
        slam, archive = self.slam, self.archive
        keys = slam.landmark_ids()
        for key in self._frame_hits | self._frame_added:
            self._last_seen[key] = self.clock_s
        if self._frame_added and len(archive):
            index_of = {key: i for i, key in enumerate(keys)}
            covs = slam.landmark_covs()
            points = slam.landmarks()
            for key in self._frame_added:
                if key in index_of:
                    archive.reacquire(key, points[index_of[key]], covs[index_of[key]])
        old = stale(slam.pose, slam.landmarks(), np.array([self._last_seen.get(k, self.clock_s)
                                                           for k in keys]), self.clock_s,
                    archive.params)
        # tentatives are left to the lifecycle; a landmark still on probation for motion is
        # archived too (seen too few times at the view's edge, many never leave probation)
        drop = [i for i in np.flatnonzero(old).tolist() if not self.lifecycle.is_tentative(keys[i])]
        if not drop:
            return []
        points, covs = slam.landmarks(), slam.landmark_covs()
        reports = []
        for i in drop:
            key = keys[i]
            archive.add(key, points[i], covs[i], self._last_seen.pop(key, self.clock_s), self.clock_s)
            self.lifecycle.forget(key)
            self._young.pop(key, None)
            self._strikes.pop(key, None)
            self._strike_points.pop(key, None)
            reports.append(UpdateReport("archived", None, None, None, key))
        slam.remove_landmarks(drop)
        return reports

    def _unseeable_near(self, position: np.ndarray) -> bool:
        """A coasting track predicted within the camera's range of the vehicle but outside its
        view: kept (movers.prune) until the camera could have seen it there (a multicopter's
        velocity choice with a camera range only)."""
        pose = self.slam.pose
        gap = np.asarray(position, dtype=float) - pose[:2]
        range_m = float(np.hypot(*gap))
        bearing = wrap_angle(math.atan2(gap[1], gap[0]) - float(pose[2]))
        return range_m <= self.union.sensor_range_m \
            and not is_visible(range_m, bearing, self.union.fov_rad, self.union.sensor_range_m)

    def _schmidt(self, key) -> bool:
        """Whether a landmark's observations correct only itself: on probation for motion, or
        tentative (a landmark not yet confirmed never corrects the pose)."""
        return key in self._young or self.lifecycle.is_tentative(key)

    def _born(self, key: int) -> None:
        self._young[key] = _Young()
        self.lifecycle.add(key, self.clock_s)
        self._frame_added.add(key)

    def _judge_lifecycle(self) -> list[UpdateReport]:
        """Count this frame's chance for every landmark; remove (marginalise) the deleted and
        the expired ones."""
        slam = self.slam
        keys = slam.landmark_ids()
        visible = expected_visible(slam.pose, slam.landmarks(), self.lifecycle.params)
        if self.extents and self.altitude_m is not None:
            # a landmark whose extent lies wholly above or below the vertical view is not missed
            ranges = np.hypot(*(slam.landmarks() - slam.pose[:2]).T)
            visible = visible & np.array([
                key not in self.extents or in_vertical_view(
                    self.extents[key], float(r), self.altitude_m, self.extent_params)
                for key, r in zip(keys, ranges)], dtype=bool).reshape(visible.shape)
        verdict = self.lifecycle.judge(self.clock_s, keys, visible, self._frame_hits,
                                       self._frame_near, self._frame_added)
        reports = []
        for action, removed in (("deleted", verdict.deleted), ("expired", verdict.expired)):
            for key in removed:
                slam.remove_landmark(slam.landmark_ids().index(key))
                self._young.pop(key, None)
                self._strikes.pop(key, None)
                self._strike_points.pop(key, None)
                reports.append(UpdateReport(action, None, None, None, key))
        return reports

    def _observe_one(self, obs: Observation, used: set[int], plan=None) -> UpdateReport:
        slam, oid = self.slam, obs.obstacle_id
        if oid is None:
            return self._observe_anonymous(obs, used, plan)
        if oid in self.movers.by_obstacle_id:
            return self._update_mover(self.movers.by_obstacle_id[oid], obs)
        young = self._schmidt(oid)
        report = slam.update(obs, exclude=used, landmark_only=young)
        if not young and report.action in ("updated", "outlier"):
            self.monitor.add(self.clock_s, report.nis, 2)
        if report.action == "added":
            self._born(oid)
        self._note_young(oid, obs, report.action)
        if report.action != "outlier":
            self._strikes.pop(oid, None)
            self._strike_points.pop(oid, None)
            return report
        self._strikes[oid] = self._strikes.get(oid, 0) + 1
        if oid not in self._young:
            self._add_sighting(self._strike_points.setdefault(oid, _Young()), obs)
        if self._strikes[oid] < self.mover_params.strikes_to_mover or oid in self._young:
            return report                    # a young landmark is judged by _judge_young
        # An old landmark refused twice in a row by the static map has started to move. Its
        # refused observations never touched map or pose: take it out of the map, track it,
        # at the velocity they show if they pass the motion test's speed test, else at rest.
        strikes = self._strike_points.pop(oid, None)
        shown = None if strikes is None else self._young_velocity(strikes, self._crab_speed())
        self._demote(oid, obs, used, None if shown is None else shown[:2],
                     None if shown is None else strikes)
        return UpdateReport("mover_detected", None, report.innovation, report.nis, oid)

    def _observe_anonymous(self, obs: Observation, used: set[int], plan=None) -> UpdateReport:
        """An observation without an id: the frame's joint association first (``plan``, from
        core/estimation/association.py: (action, landmark key)), then a young landmark that may have moved
        (a gate as wide as a mover's top speed allows), then the mover tracks, then a new
        landmark unless it was ambiguous. Id-less landmarks get internal negative ids (never
        published)."""
        slam = self.slam
        z = np.array([obs.range_m, obs.bearing_rad])
        action, key = plan if plan is not None else ("new", None)
        ids = slam.landmark_ids()
        if isinstance(obs, SurfacePoint):
            return self._observe_surface(obs, z, key if action == "update" else None)
        if action == "update" and key in ids:
            return self._update_landmark(key, ids.index(key), z, obs)
        moved = self._moved_young(place(self._young_pose(), z))
        if moved is not None:
            self._relocate(moved, z, obs, used)
            self._note_young(moved, obs, "moved")
            return UpdateReport("moved", None, None, None, None)
        if len(self.movers):
            point, cov = self._world_point(obs)
            track = self.movers.nearest(self.clock_s, point, cov)
            if track is not None:
                return self._update_mover(track, obs)
        if action == "new":
            # New against the map the frame began with; one born from this frame's own earlier
            # observation may be what this one sees (two returns of one post): ambiguous then.
            nis, _ = slam.nis_all(z, obs.meas_cov_array())
            near = [i for i in range(len(nis)) if ids[i] in self._frame_added]
            if near and float(np.min(nis[near])) <= slam.gates.new_landmark_nis:
                action, key = "ambiguous", ids[near[int(np.argmin(nis[near]))]]
        if action == "ambiguous":
            # Never an update: the landmark it gated on is another observation's this frame.
            if key in ids:
                self._frame_near.add(key)
                return UpdateReport("ambiguous", ids.index(key), None, None, None)
            return UpdateReport("ambiguous", None, None, None, None)
        if action == "new":
            return self._add_anonymous(z, obs)
        report = slam.update(obs, exclude=used)
        if report.action == "added":
            self._name_anonymous(report, obs)
        return report

    def _observe_surface(self, obs: SurfacePoint, z: np.ndarray, paired: int | None) -> UpdateReport:
        """A wall's or a face's chain point: it updates the landmark the frame's association
        paired it with (``paired``, a key) if that landmark covers it (core/perception/surface_cover.py);
        else it is ambiguous if another one covers it, and surface the map does not hold yet (a
        new landmark) if none does. Never a young landmark 'moved' there (a wall does not move;
        its chain points fall elsewhere along it every frame) and never a mover's."""
        slam = self.slam
        ids = slam.landmark_ids()
        if ids:
            pose = slam.pose
            nis = covering_nis(slam.landmarks() - pose[:2], z, np.asarray(obs.own_cov, dtype=float),
                               float(pose[2]), float(slam.pose_cov[2, 2]), 0.5 * obs.stretch_m)
            covers = nis <= slam.gates.accept_nis
            if paired in ids and covers[ids.index(paired)]:
                return self._update_landmark(paired, ids.index(paired), z, obs)
            if covers.any():
                best = int(np.argmin(nis))
                self._frame_near.add(ids[best])
                return UpdateReport("ambiguous", best, None, float(nis[best]), None)
        return self._add_anonymous(z, obs)

    def _update_landmark(self, key: int, index: int, z: np.ndarray,
                         obs: Observation) -> UpdateReport:
        """Update the id-less landmark ``key`` (state index ``index``) the association chose;
        a young or tentative one corrects only itself and is left out of the monitor."""
        young = self._schmidt(key)
        report = self.slam.update_landmark(z, index, landmark_only=young,
                                           meas_cov=obs.meas_cov_array())
        if not young:
            self.monitor.add(self.clock_s, report.nis, 2)
        self._note_young(key, obs, report.action)
        return report

    def _add_anonymous(self, z: np.ndarray, obs: Observation) -> UpdateReport:
        report = self.slam.add_landmark(z, None, obs.meas_cov_array())
        self._name_anonymous(report, obs)
        return report

    def _name_anonymous(self, report: UpdateReport, obs: Observation) -> None:
        """A landmark just added without an id gets the next internal negative one (never
        published) and starts its probation."""
        key = self._next_anonymous_id
        self._next_anonymous_id -= 1
        self.slam.set_landmark_id(report.landmark_index, key)
        self._born(key)
        self._note_young(key, obs, "added")

    def _note_young(self, key: int, obs: Observation, action: str) -> None:
        if action in ("updated", "added", "outlier", "moved"):
            self._frame_hits.add(key)
        young = self._young.get(key)
        if young is not None and action in ("updated", "added", "outlier", "moved"):
            self._add_sighting(young, obs)

    def _add_sighting(self, young: _Young, obs: Observation) -> None:
        """Add an observation to sightings placed from the dead reckoning (``_young_pose``)."""
        young.times.append(self.clock_s)
        young.points.append(place(self._young_pose(),
                                  np.array([obs.range_m, obs.bearing_rad])))
        # A frame placed with an interpolated heading (its own odometry sample was lost) or
        # with a later one (it came late) may be misplaced sideways while the vehicle turns.
        # The multicopter's points take the filter's yaw, as uncertain as its variance says.
        yaw_sigma = math.sqrt(max(float(self.slam.pose_cov[2, 2]), 0.0)) \
            if self.options.motion_model == "velocity_ned" else 0.0
        point_sigma = self._point_sigma_m if obs.meas_cov is None else math.sqrt(
            obs.meas_cov[0][0] + obs.range_m ** 2 * obs.meas_cov[1][1])
        timing_sigma = obs.range_m * self._turn_rate_rad_s * self._frame_timing_s
        young.sigmas.append(math.hypot(point_sigma, timing_sigma, obs.range_m * yaw_sigma))
        # the yaw's share is common to the frames (shared_yaw_velocity_cov), the rest is not
        young.free_sigmas.append(math.hypot(point_sigma, timing_sigma, 0.0))
        young.ranges.append(obs.range_m)
        young.directions.append(float(self._young_pose()[2]) + obs.bearing_rad)
        young.yaw_vars.append(yaw_sigma ** 2)
        young.yaw_logs.append(self._yaw_transfer_log()
                              if self.options.motion_model == "velocity_ned" else 0.0)
        young.last_obs = obs

    def _young_pose(self) -> np.ndarray:
        """The pose a young landmark's points are placed from: the dead reckoning (odometry only,
        which a mover on probation cannot drag along). The multicopter's dead-reckoned position
        does not depend on its yaw (its odometry is a NED velocity), and its dead-reckoned yaw
        is the autopilot's last sample, noisy per sample (2 deg: 1.2 m sideways at 35 m, enough
        to hide a crossing mover at 4.7 m/s from a 1.4 s motion test); the filter's yaw, the same
        samples fused with the gyro, is several times steadier and no young landmark corrects it
        (their updates are Schmidt's)."""
        if self.options.motion_model != "velocity_ned":
            return self._dr_pose
        return np.array([self._dr_pose[0], self._dr_pose[1], float(self.slam.mean[2])])

    def _moved_young(self, dr_point: np.ndarray) -> int | None:
        """The young landmark whose last dead-reckoned point is near enough for a mover (one
        already seen in this frame, or taken by another of its observations, is not: nothing
        moves between two returns of one frame)."""
        best, best_gap = None, math.inf
        for key, young in self._young.items():
            if key in self._frame_hits or key in self._frame_taken \
                    or self.clock_s - young.times[-1] > MOVED_MAX_GAP_S:
                continue
            gap = float(np.hypot(*(dr_point - young.points[-1])))
            reach = (MAX_MOVER_SPEED_MPS * (self.clock_s - young.times[-1]) + MOVED_GATE_M)
            if gap <= reach and gap < best_gap:
                best, best_gap = key, gap
        return best

    def _relocate(self, key: int, z: np.ndarray, obs: Observation, used: set[int]) -> None:
        """A young landmark's object was seen where it has moved to: the landmark restarts there
        (marginalised and added again under its key; on probation it never corrected the pose,
        so nothing else learnt from where it was). A false alarm born beside a post that takes
        the post's first sightings so stands on the post, not where the false alarm was, and
        the post's next sightings update it; a mover is mapped where it is until demoted."""
        slam = self.slam
        index = slam.landmark_ids().index(key)
        slam.remove_landmark(index)
        shifted = {i - 1 if i > index else i for i in used if i != index}
        used.clear()
        used.update(shifted)
        report = slam.add_landmark(z, None, obs.meas_cov_array())
        slam.set_landmark_id(report.landmark_index, key)
        used.add(report.landmark_index)

    def _demote(self, oid: int, obs: Observation, used: set[int] | None = None,
                velocity: tuple[np.ndarray, float] | None = None,
                young: _Young | None = None) -> None:
        """Marginalise landmark ``oid`` out of the map and start a mover track at ``obs``;
        ``young``: the sightings whose fit gave ``velocity``, the track starting when the last
        of them was seen, its position correlated with that velocity as the fit made it."""
        index = self._forget(oid)
        if used is not None:
            shifted = {i - 1 if i > index else i for i in used if i != index}
            used.clear()
            used.update(shifted)
        point, cov = self._world_point(obs)
        start_s, cross = self.clock_s, None
        if young is not None and velocity is not None:
            start_s = min(self.clock_s, young.times[-1])
            cross = start_evidence(np.array(young.times), max(young.sigmas), velocity[1], cov)
        self.movers.create(start_s, point, cov, oid if oid >= 0 else None, velocity, cross)
        self.movers_detected += 1

    def _judge_young(self) -> list[UpdateReport]:
        params = self.mover_params
        detected = []
        crab = self._crab_speed()
        for oid, young in list(self._young.items()):
            # unseen for as long as a track coasts, and its sightings showed motion: it is not
            # where it was seen, and no longer where they extrapolate to; forgotten as a track is
            # (movers.prune), not left to be flown round for ever
            if self.clock_s - young.times[-1] > params.coast_s \
                    and self._young_velocity(young, crab) is not None:
                self._forget(oid)
                detected.append(UpdateReport("expired", None, None, None, oid))
                continue
            # Only the motion test judges a young landmark: refused outliers early on are more
            # often a poor pose at the frame's time (a lost sample under packet loss) than motion.
            # It runs before the probation ends, on every sighting: a mover seen for half a
            # second, out of view, then seen again once the probation is over is convicted by
            # its sightings, not established static (and then started from rest by its strikes)
            moving = False
            if young.times[-1] - young.times[0] >= params.min_span_s:
                velocity, sigma = self._apparent_velocity(young)
                # What a static obstacle seems to do: the dead reckoning's own drift (sigma) and,
                # for the unicycle, the vehicle's sideways motion it does not model (crab).
                speed = float(np.hypot(*velocity)) - crab
                moving = speed > params.speed_threshold_mps and speed > params.speed_sigmas * sigma
                # ... and the points are one object's straight track, not clutter that a fit
                # joins (two false alarms, or one beside a post's first sighting)
                moving = moving and is_straight_track(
                    young.times, young.points, self._track_sigmas(young))
            if moving:
                # the track starts at the velocity that convicted it: a mover that leaves the
                # view soon after is then predicted where it goes, not left standing
                self._demote(oid, young.last_obs, velocity=(velocity, sigma), young=young)
                detected.append(UpdateReport("mover_detected", None, None, None, oid))
                continue
            # established only once watched over min_span_s (or the whole probation, if
            # shorter): a mover seen for half a second and then out of view must not be taken
            # for a static obstacle
            if self.clock_s - young.times[0] > params.probation_s \
                    and len(young.times) >= self.options.established_sightings \
                    and young.times[-1] - young.times[0] >= min(params.min_span_s,
                                                                params.probation_s):
                del self._young[oid]             # watched long enough: established, static
        return detected

    def _forget(self, oid: int) -> int:
        """Marginalise landmark ``oid`` out of the map with its probation and strikes, without
        a track (``_demote`` starts one); the state index it had."""
        self._strikes.pop(oid, None)
        self._strike_points.pop(oid, None)
        self._young.pop(oid, None)
        self.lifecycle.forget(oid)
        index = self.slam.landmark_ids().index(oid)
        self.slam.remove_landmark(index)
        return index

    def _apparent_velocity(self, young: _Young) -> tuple[np.ndarray, float]:
        """A landmark on probation's apparent velocity and its sigma (movers.apparent_velocity):
        its points' own noise and the dead reckoning's drift, independent from frame to frame,
        plus the pose's yaw error, which is not (shared_yaw_velocity_cov: nearly the same in
        two frames 0.2 s apart, it mostly cancels in their difference; counted independent,
        two points at 35 m would give +-2.1 m/s where their errors are about 1 m/s). Zero for
        the unicycle, whose points are placed with the dead-reckoned yaw and carry no yaw term."""
        if young.apparent is not None and young.apparent[0] == len(young.times):
            return young.apparent[1].copy(), young.apparent[2]
        times = np.array(young.times)
        velocity, sigma = apparent_velocity(times, np.array(young.points), max(young.free_sigmas),
                                            self._dr_speed_sigma_mps(), self._odometry_dt_s())
        if max(young.yaw_vars) > 0.0:
            shared = shared_yaw_velocity_cov(times, young.ranges, young.directions,
                                             young.yaw_vars, young.yaw_logs)
            sigma = math.sqrt(sigma ** 2 + float(np.linalg.eigvalsh(shared)[-1]))
        young.apparent = (len(young.times), velocity.copy(), sigma)
        return velocity, sigma

    def _track_sigmas(self, young: _Young) -> np.ndarray:
        """Each dead-reckoned point's sigma for the straight-track test: its own, plus the dead
        reckoning's random walk over the track's span (what a line does not absorb of it)."""
        span = young.times[-1] - young.times[0]
        walk_var = self._dr_speed_sigma_mps() ** 2 * self._odometry_dt_s() * span
        return np.sqrt(np.asarray(young.sigmas) ** 2 + walk_var)

    def _odometry_dt_s(self) -> float:
        """The period of one odometry sample, whose error the dead reckoning accumulates: the
        measured one where the link delivers less than the reference rate (a ground station set
        the streams), else the reference."""
        return at_least_reference_s(self._odometry_intervals.mean_s,
                                    self.slam.noise.reference_dt_s)

    def _dr_speed_sigma_mps(self) -> float:
        if self.options.motion_model == "velocity_ned":
            vel = self.options.velocity_noise
            return max(vel.vel_north_sigma_mps, vel.vel_east_sigma_mps)
        return self.slam.noise.speed_sigma_mps

    def _crab_speed(self) -> float:
        """The largest unmodelled sideways speed over the probation window (paper model)."""
        horizon = self.clock_s - self.mover_params.probation_s - self.mover_params.min_span_s
        while self._crab_mps and self._crab_mps[0][0] < horizon:
            self._crab_mps.popleft()
        return max((c for _, c in self._crab_mps), default=0.0)

    def _world_point(self, obs: Observation) -> tuple[np.ndarray, np.ndarray]:
        return world_measurement(self.slam.pose, self.slam.pose_cov,
                                 np.array([obs.range_m, obs.bearing_rad]),
                                 obs.meas_cov_array() if obs.meas_cov is not None
                                 else self.slam.noise.measurement_cov())

    def _update_mover(self, track_id: int, obs: Observation) -> UpdateReport:
        point, cov = self._world_point(obs)
        nis = self.movers.update(track_id, self.clock_s, point, cov)
        return UpdateReport("mover", None, None, nis, obs.obstacle_id)

    def obstacles(self, young_movers: bool = False
                  ) -> tuple[np.ndarray, np.ndarray | None, np.ndarray | None, list]:
        """Everything guidance must avoid: positions (n,2); velocities (n,2), or None when all
        are static; relative-position covariances (n,2,2), or None when the safety distance is
        not inflated; and the movers, whose rows follow the landmarks'. ``young_movers`` (the
        velocity choice): the landmarks on probation whose sightings already show motion
        (``_young_evidence``) are kept even while tentative, for ``_young_motion``."""
        slam = self.slam
        landmarks = slam.landmarks()
        inflate = self.params.inflation_sigmas > 0
        rel_covs = slam.relative_covs() if inflate else None
        keys = slam.landmark_ids()
        if young_movers:
            self._young_found = self._young_evidence()
        if not self.lifecycle.params.tentative_in_guidance:
            keep = [i for i, key in enumerate(keys) if not self.lifecycle.is_tentative(key)
                    or (young_movers and key in self._young_found)]
            landmarks, keys = landmarks[keep], [keys[i] for i in keep]
            rel_covs = rel_covs[keep] if rel_covs is not None else None
        self._guidance_keys = keys
        movers = self.movers.states(self.clock_s)
        if not movers:
            return landmarks, None, rel_covs, movers
        positions = np.vstack([landmarks, [m.position_ne_m for m in movers]])
        velocities = np.vstack([np.zeros_like(landmarks), [m.velocity_ne_mps for m in movers]])
        if inflate:
            pose_cov = slam.pose_cov[:2, :2]
            rel_covs = np.concatenate([rel_covs, [m.position_cov + pose_cov for m in movers]])
        return positions, velocities, rel_covs, movers

    def _young_evidence(self) -> dict:
        """The landmarks on probation whose sightings so far already show motion, by key:
        (velocity, its sigma, the sightings' mean time); see ``_young_velocity``."""
        crab = self._crab_speed()
        found = {}
        for key, young in self._young.items():
            shown = self._young_velocity(young, crab)
            if shown is not None:
                found[key] = shown
        return found

    def _young_velocity(self, young: _Young, crab: float) -> tuple | None:
        """(velocity, its sigma, the sightings' mean time) if a landmark on probation's
        sightings already show motion, else None. The conviction's speed test (speed_sigmas
        standard errors) on at least ``young_min_sightings`` of them; with the default 2, a
        crossing mover seen in two frames at the edge of the view, still tentative, shows its
        velocity (two points 0.2 s apart, each 0.1 m: +-0.74 m/s, so 3.7 m/s at 5 sigma).
        Tentative or not: a landmark seen too briefly to be confirmed is kept out of the
        decision as a possible false alarm, but a static false alarm does not move and two
        false alarms rarely fall within a mover's reach of each other."""
        if len(young.times) < self.mover_params.young_min_sightings \
                or young.times[-1] - young.times[0] <= SAME_TIME_TOLERANCE_S:
            return None
        velocity, sigma = self._apparent_velocity(young)
        speed = float(np.hypot(*velocity)) - crab
        if speed > self.mover_params.speed_threshold_mps \
                and speed > self.mover_params.speed_sigmas * sigma:
            return velocity, sigma, float(np.mean(young.times))
        return None

    def _young_motion(self, obstacles: np.ndarray, velocities: np.ndarray | None,
                      growth: np.ndarray | None) -> tuple[np.ndarray, np.ndarray | None,
                                                          np.ndarray | None]:
        """Guidance's view of the landmarks still on probation: one whose sightings so far
        already show motion (``_young_evidence``, before its min_span_s) is flown around as a
        mover at its apparent velocity, its radius growing by that velocity's uncertainty,
        while the map keeps it as a landmark until it is judged. A crossing mover in view for
        half a second, then out of it, stays in the decision where it goes, not where it was
        seen. (The velocity choice only: rows as ``obstacles()``'s, just before.)"""
        found = [(row, *self._young_found[key]) for row, key in enumerate(self._guidance_keys)
                 if key in self._young_found]
        self._young_movers = []
        self._young_spread = None
        if not found:
            return obstacles, velocities, growth
        n = len(obstacles)
        obstacles = np.array(obstacles, dtype=float)
        velocities = np.zeros((n, 2)) if velocities is None else velocities.copy()
        growth = np.zeros(n) if growth is None else growth.copy()
        self._young_spread = np.zeros(n)
        for row, velocity, sigma, mean_t in found:
            # the landmark's static estimate sits near its sightings' mean: move it on from there
            obstacles[row] = obstacles[row] + velocity * (self.clock_s - mean_t)
            velocities[row] = velocity
            growth[row] = self.union.mover_sigmas * sigma
            # ... and that extrapolation is as uncertain as the velocity times its age
            self._young_spread[row] = self.union.mover_sigmas * sigma * (self.clock_s - mean_t)
            self._young_movers.append((self._guidance_keys[row], obstacles[row].copy(), velocity))
        return obstacles, velocities, growth

    def _spread(self, movers: list, rows: int, motion: Motion | None) -> np.ndarray | None:
        """(rows,) how far each obstacle may be from its estimate now, for the velocity choice
        (None: nowhere): confirmed tracks' position sigma (movers.mover_spread) and the
        extrapolation of the landmarks on probation flown round as movers (_young_motion)."""
        if motion is None:
            return None
        spread = mover_spread(movers, rows, self.union.mover_sigmas, SPREAD_MIN_UPDATES)
        if self._young_spread is None:
            return spread
        return self._young_spread if spread is None else spread + self._young_spread

    def assess(self) -> Consistency:
        """The consistency monitor's verdict now; state changes are kept in ``health_changes``."""
        health = self.monitor.assess(self.clock_s, self.slam.pose_cov)
        if self.health is None or health.state != self.health.state:
            self.health_changes.append(health)
        self.health = health
        return health

    def _moderate(self, command: GuidanceCommand) -> GuidanceCommand:
        return moderate(command, self.assess(), self.options, float(self.slam.mean[2]))

    def _key(self, index: int | None, movers: list) -> tuple | None:
        """A stable name for obstacle row ``index``: landmark ids shift as movers leave the map."""
        if index is None:
            return None
        landmarks = len(self._guidance_keys)
        if index >= landmarks:
            return ("mover", movers[index - landmarks].track_id)
        oid = self._guidance_keys[index]
        return ("landmark", oid if oid is not None else index)

    def _motion(self, pose: np.ndarray) -> Motion | None:
        """The vehicle's limits and its velocity now (cruising along the yaw before any odometry)."""
        if self.limits is None:
            return None
        speed, course = self._velocity_now or (self.params.cruise_speed_mps, float(pose[2]))
        return self.limits.motion(speed, course, float(pose[2]))

    def _flight_pose(self, pose: np.ndarray) -> np.ndarray:
        """The pose guidance sees: while the nose looks at a mover, its yaw is the direction the
        vehicle flies (the velocity's, or the last choice's when nearly still), since the choice
        reads the yaw as where the vehicle goes and what its camera has in view. The same while
        the goal look's nose is apart, if the vehicle flies (slower: the nose's own yaw)."""
        speed, course = self._velocity_now or (0.0, float(pose[2]))
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
             for key, position, velocity in self._young_movers]
        if self.look_at is None or not candidates or command.mode in NO_LOOK_MODES \
                or command.mode.startswith("hold: "):
            return command
        watch = threat_to_watch(self.slam.pose[:2], command.heading_rad, command.speed_mps,
                                np.array([c[1] for c in candidates]),
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
        pose = self.slam.pose
        speed, course = self._velocity_now or (0.0, float(pose[2]))
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
        swing = self.scan.look(self.clock_s, heading)
        if swing is not None:
            self._looked.append((heading, swing))
        return swing

    def _decide_2d(self, pose: np.ndarray, t_s: float, skip: frozenset = frozenset()):
        """The horizontal law's command with the landmark rows ``skip`` (flown over or under)
        left out, its movers, and what to commit if it is flown (the union law's side and
        commitment). Without ``skip``: the 2D decision as it always was."""
        young_movers = self.strategy == "union" and self.limits is not None
        obstacles, velocities, rel_covs, movers = self.obstacles(young_movers)
        self._young_movers = []
        if self.strategy == "apf":
            obstacles, _, _, _ = self._drop_rows(skip, obstacles)
            return guide_apf(pose, self.goal, obstacles, self.params), movers, lambda c: None
        if self.strategy == "union":
            growth = mover_growth(movers, len(obstacles), self.union.mover_sigmas)
            motion = self._motion(pose)
            if motion is not None:
                obstacles, velocities, growth = self._young_motion(obstacles, velocities, growth)
            spread = self._spread(movers, len(obstacles), motion)
            if skip:
                obstacles, velocities, rel_covs, (growth, spread) = self._drop_rows(
                    skip, obstacles, velocities, rel_covs, growth, spread)
            goal_distance = float(np.hypot(*(self.goal - pose[:2])))
            reach = None if motion is None else self.commitment.goal_reach_m(
                goal_distance, self.params.safety_distance_m, self.union.sensor_range_m or 0.0)
            inputs = GuidanceInputs(
                pose, self.goal, obstacles, rel_covs, self._last_heading,
                self.commitment.side if motion is not None else self._side, velocities, motion,
                growth, reach or None, self.seen, spread,
                self._look_for if self.scan is not None else None)
            guide = guide_union if motion is None else \
                guide_flyable if self.union.path is None else guide_along_path
            command = guide(inputs, self.params, self.union)

            def commit(chosen: GuidanceCommand) -> None:
                self._side = chosen.side
                if motion is not None and chosen.mode != "arrived":
                    self.commitment = self.commitment.after(chosen.side, goal_distance)
            return command, movers, commit
        obstacles, velocities, rel_covs, _ = self._drop_rows(skip, obstacles, velocities, rel_covs)
        return (guide_cone(pose, self.goal, obstacles, rel_covs, self.params, t_s, velocities),
                movers, lambda c: None)

    def _drop_rows(self, skip: frozenset, obstacles: np.ndarray, velocities=None, rel_covs=None,
                   *per_row):
        """The guidance arrays without the landmark rows ``skip``; ``_guidance_keys`` follows
        (the urgency's key names the rows left). ``per_row``: more (n,) arrays or None."""
        if not skip:
            return obstacles, velocities, rel_covs, per_row
        keep = [i for i in range(len(obstacles)) if i not in skip]
        self._guidance_keys = [k for i, k in enumerate(self._guidance_keys) if i not in skip]
        pick = (lambda a: None if a is None else a[keep])
        return (obstacles[keep], pick(velocities), pick(rel_covs),
                tuple(pick(a) for a in per_row))

    def _decide_3d(self, pose: np.ndarray, t_s: float):
        """Each altitude plan's horizontal command, scored (core/avoidance/vertical.py); the
        least costly one's command, with ``vertical_choice`` set."""
        params = self.vertical
        obstacles, _, _, _ = self.obstacles(self.strategy == "union" and self.limits is not None)
        extents = [self._extent_of(key) for key in self._guidance_keys]
        extents += [vertical3d.UNBOUNDED] * (len(obstacles) - len(extents))
        alt = float(self.altitude_m)
        to_goal = self.goal - pose[:2]
        ahead = to_goal / max(float(np.hypot(*to_goal)), 1e-9)
        scored, results = [], []
        for plan in vertical3d.plans(pose[:2], alt, obstacles, extents, params, ahead):
            command, movers, commit = self._decide_2d(pose, t_s, plan.skip)
            rows = [i for i in range(len(obstacles)) if i not in plan.skip
                    and float(np.hypot(*(obstacles[i] - pose[:2]))) <= params.reach_m]
            hold = command.mode in ("hold", "stop", "escape") or command.mode.startswith("hold")
            detour = vertical3d.detour_m(pose[:2], self.goal, command.heading_rad, obstacles,
                                         rows) + (0.0 if command.mode != "slow" else 20.0)
            scored.append((plan, vertical3d.plan_cost_m(plan, alt, detour, hold, params)))
            results.append((command, movers, commit, plan.skip))
        last = self.vertical_choice.plan.kind if self.vertical_choice is not None else None
        choice = vertical3d.choose(scored, last, alt, params)
        self.vertical_choice = choice
        command, movers, commit, skip = results[[p for p, _ in scored].index(choice.plan)]
        if len(scored) > 1:        # the guidance keys of the plan flown (the last evaluated's now)
            self.obstacles(self.strategy == "union" and self.limits is not None)
            self._drop_rows(skip, obstacles)
        return command, movers, commit

    def _extent_of(self, key) -> "vertical3d.Extent":
        extent = self.extents.get(key)
        if extent is None or extent.top_m is None:
            return vertical3d.Extent(None, 0.0, 0.0 if extent is None else extent.bottom_m,
                                     extent is not None and extent.bottom_var_m2 is not None)
        return vertical3d.Extent(extent.top_m, extent.top_sigma_m or 0.0, extent.bottom_m,
                                 extent.bottom_var_m2 is not None)

    def decide(self, t_s: float) -> tuple[GuidanceCommand, UrgencyChange | None]:
        """Guidance on the current estimate, and the urgency change it implies, if any."""
        pose = self._flight_pose(self.slam.pose)
        if self.vertical is not None and self.altitude_m is not None:
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
        key = self._key(command.urgent_index, movers)
        change = None
        if key != self._urgent:
            self._urgent = key
            oid = key[1] if key is not None and key[0] == "landmark" and key[1] >= 0 else None
            change = UrgencyChange(t_s, command.urgent_index, oid, command.time_to_go_s)
        return command, change
