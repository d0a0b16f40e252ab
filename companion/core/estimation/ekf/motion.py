"""The filter's predicts (EkfSlam's): the paper's unicycle (``predict``: speed along the yaw plus
a heading change) and the multicopter's (``predict_velocity``: the autopilot's NED velocity and yaw
rate, optionally turned by the yaw state's offset from the autopilot's yaw), and process noise on
the pose alone (``inflate_position``, ``inflate_yaw``). Each touches only the vehicle's rows and
columns: O(n), the multicopter's NED model O(1).
"""
from __future__ import annotations

import math

from companion.core.estimation.slam_types import POSE_DIM, VelocityNoise
from companion.core.geometry import wrap_angle


class EkfMotion:
    """EkfSlam's motion models (a mixin: the state is EkfSlam's)."""

    def predict(self, speed_mps: float, heading_change_rad: float, dt_s: float,
                speed_var_scale: float = 1.0, heading_var_extra: float = 0.0) -> None:
        """Propagate through the motion model with the odometry control [v, gamma].

        ``speed_var_scale`` multiplies the speed sample's variance, for a sample's interval
        predicted in parts; ``heading_var_extra`` (rad^2) adds to the heading change's variance
        (see Estimator.on_odometry, core/estimation/estimator.py).

        Touches only the vehicle rows and columns of the covariance: O(n), not O(n^2).
        Speed noise is per sample (a held sample's error persists over its dt); heading-change
        noise accumulates, so its variance scales with dt / reference_dt.
        """
        if dt_s <= 0.0:
            return
        # F = [[1, 0, a], [0, 1, b], [0, 0, 1]] and G = [[dt c, a], [dt s, b], [0, 1]] with
        # a = -v dt sin(course), b = v dt cos(course): written out in scalars, because a dozen
        # numpy calls on 3x3 blocks cost more than the arithmetic (see benchmarks/run.py).
        mean, cov = self._mean_buf, self._cov_buf
        course = float(mean[2]) + heading_change_rad
        c, s = math.cos(course), math.sin(course)
        step = speed_mps * dt_s
        a, b = -step * s, step * c
        mean[0] += step * c
        mean[1] += step * s
        mean[2] = wrap_angle(course)
        m00, m01, r02, m11, r12, p22 = self._shear_position_by_yaw(a, b)
        q_speed = self.noise.speed_sigma_mps ** 2 * speed_var_scale * dt_s * dt_s
        q_turn = (self.noise.heading_change_sigma_rad ** 2 * dt_s / self.noise.reference_dt_s
                  + heading_var_extra)
        n00 = m00 + c * c * q_speed + a * a * q_turn
        n01 = m01 + c * s * q_speed + a * b * q_turn
        n02 = r02 + a * q_turn
        n11 = m11 + s * s * q_speed + b * b * q_turn
        n12 = r12 + b * q_turn
        n22 = p22 + q_turn
        cov[:3, :3] = ((n00, n01, n02), (n01, n11, n12), (n02, n12, n22))

    def _predict_velocity_in_yaw_frame(self, vel_north_mps: float, vel_east_mps: float,
                                       dt_s: float, offset_rad: float) -> None:
        """The position part of predict_velocity when the velocity was turned into NED by the
        autopilot's own yaw (see there): it moves by R(offset) v dt, offset = the yaw state minus
        that yaw, so F couples the position to the yaw, F = [[1, 0, a], [0, 1, b], [0, 0, 1]],
        (a, b) = dt (-v'_e, v'_n) with v' = R(offset) v. O(n), as the paper model's predict."""
        mean, cov = self._mean_buf, self._cov_buf
        c, s = math.cos(offset_rad), math.sin(offset_rad)
        vn, ve = c * vel_north_mps - s * vel_east_mps, s * vel_north_mps + c * vel_east_mps
        mean[0] += vn * dt_s
        mean[1] += ve * dt_s
        a, b = -ve * dt_s, vn * dt_s
        n00, n01, n02, n11, n12, n22 = self._shear_position_by_yaw(a, b)
        cov[:3, :3] = ((n00, n01, n02), (n01, n11, n12), (n02, n12, n22))

    def _shear_position_by_yaw(self, a: float, b: float) -> tuple[float, ...]:
        """F P F^T for F = [[1, 0, a], [0, 1, b], [0, 0, 1]] on the pose (the position moved by
        a yaw error): the pose-landmark rows 0 and 1 updated in place (F @ P_vm, O(n)); the pose
        block returned, not written, as its upper triangle (00, 01, 02, 11, 12, 22), for the
        caller to add its process noise. Shared by the paper model's predict and the velocity
        model's yaw frame."""
        cov, dim = self._cov_buf, self._dim
        if dim > POSE_DIM:                                  # F @ P_vm: rows 0 and 1 take row 2
            row2 = cov[2, POSE_DIM:dim]
            cov[0, POSE_DIM:dim] += a * row2
            cov[1, POSE_DIM:dim] += b * row2
            cov[POSE_DIM:dim, 0] = cov[0, POSE_DIM:dim]
            cov[POSE_DIM:dim, 1] = cov[1, POSE_DIM:dim]
        (p00, p01, p02), (_, p11, p12), (_, _, p22) = cov[:3, :3].tolist()
        r00, r01, r02 = p00 + a * p02, p01 + a * p12, p02 + a * p22          # rows of F P
        r11, r12 = p11 + b * p12, p12 + b * p22
        return r00 + a * r02, r01 + b * r02, r02, r11 + b * r12, r12, p22

    def predict_velocity(self, vel_north_mps: float, vel_east_mps: float, yaw_rate_rad_s: float,
                         dt_s: float, noise: VelocityNoise, var_scale: float = 1.0,
                         frame_offset_rad: float | None = None) -> None:
        """Propagate through the multicopter model (geometry.move_velocity): the position moves by
        the autopilot's NED velocity, the yaw by its yaw rate, course and yaw independent.

        ``frame_offset_rad`` None: the velocity is NED as it is (a GPS-aided autopilot's: its
        error does not depend on the yaw). Else the autopilot turned its body velocity into NED
        with its own yaw (a flow sensor's, or the stub's unicycle odometry: the velocity shares
        the yaw's error) and this is the yaw state minus that yaw: the velocity is turned by it,
        and F couples the position to the yaw error (an O(n) predict).

        F is the identity, so the covariance only gains Q on the vehicle's diagonal: O(1), and
        the vehicle-landmark cross-covariance is untouched. ``var_scale`` as in :meth:`predict`
        (an interval predicted in parts keeps one sample's variance).
        """
        if dt_s <= 0.0:
            return
        mean, cov = self._mean_buf, self._cov_buf
        if frame_offset_rad is not None:
            self._predict_velocity_in_yaw_frame(vel_north_mps, vel_east_mps, dt_s,
                                                frame_offset_rad)
        else:
            mean[0] += vel_north_mps * dt_s
            mean[1] += vel_east_mps * dt_s
        mean[2] = wrap_angle(float(mean[2]) + yaw_rate_rad_s * dt_s)
        held = var_scale * dt_s * dt_s
        cov[0, 0] += noise.vel_north_sigma_mps ** 2 * held
        cov[1, 1] += noise.vel_east_sigma_mps ** 2 * held
        cov[2, 2] += noise.yaw_rate_sigma_rad_s ** 2 * held

    def inflate_position(self, var_m2: float) -> None:
        """Add ``var_m2`` to the vehicle's north and east variances (process noise on the pose
        alone: an error of the odometry the landmarks do not share)."""
        if var_m2 > 0.0:
            self._cov_buf[0, 0] += var_m2
            self._cov_buf[1, 1] += var_m2

    def inflate_yaw(self, var_rad2: float) -> None:
        """Add ``var_rad2`` to the vehicle's yaw variance (process noise on the yaw alone)."""
        if var_rad2 > 0.0:
            self._cov_buf[2, 2] += var_rad2
