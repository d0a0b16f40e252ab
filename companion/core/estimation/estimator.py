"""The navigator's estimator: EKF-SLAM with its options, fed odometry, frames and fixes in time.

It owns the filter, its clock, the dead reckoning (odometry only, never corrected), the yaw
error's transfer log and the consistency monitor. Camera frames wait here until the odometry
covers their time; each is then handed to the ``observe`` callable the caller passes (the
landmark manager's per-frame update), at its own time within the odometry interval.
"""
from __future__ import annotations

import math
from collections import deque
from typing import Callable

import numpy as np

from companion.core.estimation.consistency import Consistency, ConsistencyMonitor
from companion.core.estimation.ekf_slam import EkfSlam
from companion.core.estimation.slam_types import (AssociationGates, Observation, SlamNoise,
                                                  UpdateReport)
from companion.core.estimator_options import EstimatorOptions
from companion.core.geometry import move, move_velocity, wrap_angle
from companion.core.sample_interval import (MeanInterval, at_least_reference_s,
                                            interval_turn_rate, long_interval)

# An observation frame stamped at most this much after the last odometry is processed at once
# (the pose is that close); a later one waits for the odometry that covers its time.
FRAME_TIMING_UNCERTAINTY_S = 0.05   # half an odometry period at 10 Hz; half the measured one if longer
SAME_TIME_TOLERANCE_S = 1e-3
MAX_PENDING_FRAMES = 8

Observe = Callable[[list[Observation]], list[UpdateReport]]


class Estimator:
    """EKF-SLAM plus its options, in time: odometry, the autopilot's yaw and position, frames."""

    def __init__(self, start_pose: np.ndarray, start_pose_cov: np.ndarray, noise: SlamNoise,
                 gates: AssociationGates, options: EstimatorOptions) -> None:
        self.slam = EkfSlam(start_pose, start_pose_cov, noise, gates)
        if options.range_sigma_at_predicted and options.range_sigma_k_per_m > 0.0:
            self.slam.set_range_model(noise.range_sigma_m, options.range_sigma_k_per_m)
        self.options = options
        self.monitor = ConsistencyMonitor(options.monitor)
        self.health: Consistency | None = None
        self.health_changes: list[Consistency] = []     # every change of state, in order
        self.position_fixes = {"fused": 0, "refused": 0}
        self._last_fix_s: float | None = None
        self._last_velocity: tuple[float, float] | None = None   # NED, at the last sample
        self._crab_mps: deque[tuple[float, float]] = deque()   # paper model: (t, unmodelled speed)
        self.velocity_now: tuple[float, float] | None = None    # speed, course: last odometry
        self.clock_s = 0.0                     # the filter's time: odometry time, or summed dt
        self.dr_pose = np.array(start_pose, dtype=float)   # odometry only, never corrected
        # the log of the factor by which the corrections so far scaled the filter's yaw error
        # (yaw_transfer_log), and the yaw variance it was last brought up to date at
        self._yaw_log_transfer = 0.0
        self._yaw_var_mark: float | None = None
        self.turn_rate_rad_s = 0.0
        self.frame_timing_s = 0.0      # how far the heading used may be from the frame's time
        self._odometry_intervals = MeanInterval()   # the odometry's measured period (issue 32)
        self.t_s: float | None = None          # time of the last odometry the filter has absorbed
        self._yaw_rad: float | None = None
        self._pending: deque[tuple[float, list[Observation]]] = deque()
        self.rejected: dict[str, int] = {}
        self.altitude_m: float | None = None    # above the ground, the autopilot's

    # ------------------------------------------------------ timed inputs
    # The live service and the replay feed messages through these methods, stamped with the
    # messages' own clock (time_boot_ms), so the same stream gives the same estimates anywhere.
    def on_odometry(self, t_s: float, speed_mps: float, yaw_rad: float,
                    course_rad: float | None, observe: Observe) -> list[UpdateReport]:
        """Absorb one odometry sample: the speed over the interval ending at ``t_s`` and the
        autopilot's (gyro-integrated) yaw at ``t_s``. The heading change is the yaw difference, so
        a lost sample costs no heading. Then process (``observe``) any observation frames this
        time covers.

        ``course_rad``, the direction of the velocity if known: the unicycle flies along its yaw,
        so the difference of the two velocities, 2 speed |sin((course - yaw) / 2)|, is motion this
        model does not have; the mover test allows for it (a crabbing vehicle's dead reckoning
        sees static obstacles drift by that much).
        """
        if not (math.isfinite(t_s) and math.isfinite(speed_mps) and math.isfinite(yaw_rad)) \
                or speed_mps < 0.0:
            self.reject("odometry_not_finite")
            return []
        if course_rad is not None and math.isfinite(course_rad):
            self._crab_mps.append(
                (t_s, 2.0 * speed_mps * abs(math.sin(0.5 * wrap_angle(course_rad - yaw_rad)))))
        if self.t_s is None:
            self.t_s, self._yaw_rad, self.clock_s = t_s, yaw_rad, t_s
            return self._release(observe)
        dt = t_s - self.t_s
        if dt <= 0.0:
            self.reject("odometry_not_newer")
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
            self.frame_timing_s = at_least_reference_s(0.5 * dt, FRAME_TIMING_UNCERTAINTY_S)
            reports.extend(observe(observations))
            self.frame_timing_s = 0.0
        rest = t_s - cursor
        self.predict(speed_mps, turn - turned, rest,
                     speed_var_scale=1.0 if cursor == start else dt / rest)
        self.t_s, self._yaw_rad = t_s, yaw_rad
        return reports + self._release(observe)

    def on_velocity(self, t_s: float, vel_north_mps: float, vel_east_mps: float, yaw_rad: float,
                    yaw_rate_rad_s: float, observe: Observe) -> list[UpdateReport]:
        """The multicopter's odometry sample: the NED velocity and yaw rate at ``t_s`` and the
        autopilot's yaw then (a measurement of the yaw state). The interval since the last sample
        is flown at the mean of its two velocities (trapezoidal: the velocity at one end would
        misplace the vehicle by half a step's speed change at every acceleration) and turned at
        the yaw rate of ``t_s`` (whatever lag that has, the yaw measurement takes out).
        Frames inside the interval are observed at their own time, as in :meth:`on_odometry`."""
        values = (t_s, vel_north_mps, vel_east_mps, yaw_rad, yaw_rate_rad_s)
        if not all(math.isfinite(v) for v in values):
            self.reject("odometry_not_finite")
            return []
        if self.t_s is None:
            self.t_s, self._yaw_rad, self.clock_s = t_s, yaw_rad, t_s
            self._last_velocity = (vel_north_mps, vel_east_mps)
            self.correct_yaw(yaw_rad)
            return self._release(observe)
        dt = t_s - self.t_s
        if dt <= 0.0:
            self.reject("odometry_not_newer")
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
            self.frame_timing_s = at_least_reference_s(0.5 * dt, FRAME_TIMING_UNCERTAINTY_S)
            reports.extend(observe(observations))
            self.frame_timing_s = 0.0
        rest = t_s - cursor
        self.predict_velocity(vel_north_mps, vel_east_mps, yaw_rate_rad_s, rest,
                              var_scale=1.0 if cursor == start else dt / rest,
                              yaw_var_extra=yaw_var_extra * rest / dt)
        self.correct_yaw(yaw_rad, dt)
        self.t_s, self._yaw_rad = t_s, yaw_rad
        return reports + self._release(observe)

    def on_observations(self, t_s: float, observations: list[Observation],
                        observe: Observe) -> list[UpdateReport]:
        """One camera frame captured at ``t_s``; waits if the odometry has not reached ``t_s``.

        Observations with a non-finite or non-positive range, or a non-finite bearing, are
        refused and counted in ``rejected`` (one NaN would poison the whole state); a frame with
        a non-finite time is refused whole.
        """
        if not math.isfinite(t_s):
            self.reject("frame_time_not_finite")
            return []
        valid = []
        for obs in observations:
            if not (math.isfinite(obs.range_m) and math.isfinite(obs.bearing_rad)):
                self.reject("observation_not_finite")
            elif obs.range_m <= 0.0:
                self.reject("observation_range_not_positive")
            else:
                valid.append(obs)
        observations = valid
        if self.t_s is not None and t_s <= self.t_s + SAME_TIME_TOLERANCE_S:
            self.frame_timing_s = max(self.t_s - t_s, 0.0)       # late: placed with a later pose
            try:
                return observe(observations)
            finally:
                self.frame_timing_s = 0.0
        if len(self._pending) >= MAX_PENDING_FRAMES:
            self._pending.popleft()
            self.reject("frame_overflow")
        self._pending.append((t_s, observations))
        return []

    def _release(self, observe: Observe) -> list[UpdateReport]:
        reports: list[UpdateReport] = []
        while self._pending and self._pending[0][0] <= self.t_s + SAME_TIME_TOLERANCE_S:
            reports.extend(observe(self._pending.popleft()[1]))
        return reports

    def reject(self, kind: str) -> None:
        """Count one refused input of ``kind`` (``rejected``)."""
        self.rejected[kind] = self.rejected.get(kind, 0) + 1

    # ------------------------------------------------------ the filter's steps
    def predict(self, speed_mps: float, heading_change_rad: float, dt_s: float,
                speed_var_scale: float = 1.0, heading_var_extra: float = 0.0) -> None:
        self.slam.predict(speed_mps, heading_change_rad, dt_s, speed_var_scale, heading_var_extra)
        self.clock_s += max(dt_s, 0.0)
        self.dr_pose = move(self.dr_pose, speed_mps, heading_change_rad, dt_s)
        self.velocity_now = (max(speed_mps, 0.0), float(self.slam.mean[2]))
        if dt_s > 0.0:
            self.turn_rate_rad_s = abs(heading_change_rad) / dt_s

    def predict_velocity(self, vel_north_mps: float, vel_east_mps: float, yaw_rate_rad_s: float,
                         dt_s: float, var_scale: float = 1.0, yaw_var_extra: float = 0.0) -> None:
        """The multicopter model's predict (see EkfSlam.predict_velocity). With
        ``options.velocity_in_yaw_frame`` the velocity is taken as turned by the autopilot's own
        yaw: the yaw state's offset from the last reported yaw (both advance by the same rate)."""
        self.yaw_transfer_log()
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
        self.dr_pose = move_velocity(self.dr_pose, vel_north_mps, vel_east_mps, yaw_rate_rad_s,
                                     dt_s)
        self.velocity_now = (math.hypot(vel_north_mps, vel_east_mps),
                             math.atan2(vel_east_mps, vel_north_mps))
        if dt_s > 0.0:
            self.turn_rate_rad_s = abs(yaw_rate_rad_s)

    def correct_yaw(self, yaw_rad: float, dt_s: float | None = None) -> UpdateReport:
        """The autopilot's yaw as a measurement of the yaw state, ``dt_s`` after the last one
        (its sigma: ``EstimatorOptions.yaw_fix_sigma_rad``); the dead reckoning takes it."""
        self.yaw_transfer_log()
        report = self.slam.update_yaw(yaw_rad, self.options.yaw_fix_sigma_rad(dt_s),
                                      self.options.yaw_gate_nis)
        # a reset first inflated the variance by the squared innovation: its K is the inflated one
        self.yaw_transfer_log(report.innovation[0] ** 2 if report.action == "yaw_reset" else 0.0)
        self.monitor.add(self.clock_s, report.nis, 1)
        self.dr_pose[2] = wrap_angle(yaw_rad)
        return report

    def yaw_transfer_log(self, inflated_rad2: float = 0.0) -> float:
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
            self.reject("position_not_finite")
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

    def assess(self) -> Consistency:
        """The consistency monitor's verdict now; state changes are kept in ``health_changes``."""
        health = self.monitor.assess(self.clock_s, self.slam.pose_cov)
        if self.health is None or health.state != self.health.state:
            self.health_changes.append(health)
        self.health = health
        return health

    def odometry_dt_s(self) -> float:
        """The period of one odometry sample, whose error the dead reckoning accumulates: the
        measured one where the link delivers less than the reference rate (a ground station set
        the streams), else the reference."""
        return at_least_reference_s(self._odometry_intervals.mean_s,
                                    self.slam.noise.reference_dt_s)

    def crab_speed(self, horizon_s: float) -> float:
        """The largest unmodelled sideways speed since ``horizon_s`` (paper model); older
        samples are dropped."""
        while self._crab_mps and self._crab_mps[0][0] < horizon_s:
            self._crab_mps.popleft()
        return max((c for _, c in self._crab_mps), default=0.0)
