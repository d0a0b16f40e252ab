"""EKF-SLAM over the state [north_m, east_m, yaw_rad, m1_north, m1_east, m2_north, ...].

Departure from the house style, on purpose: the filter is a small mutable object that updates its
mean and covariance in place. The covariance is (3+2n)^2 numbers; copying it into a frozen result
at every step would cost more than the update itself (see benchmarks/run.py). What the methods
return is frozen: :class:`UpdateReport` carries the diagnostics (innovation, NIS, which landmark).

Two motion models: the paper's unicycle (``predict``: speed along the yaw plus a heading change)
and the multicopter's (``predict_velocity``: the autopilot's NED velocity and yaw rate, the yaw
corrected by the autopilot's own yaw through ``update_yaw``). ``update_position`` fuses the
autopilot's horizontal position when it can be trusted.

Costs: predict touches only the vehicle rows and columns, O(n) (the multicopter's, O(1)). An update
is one gather of the five rows of P its H touches (contiguous, P is symmetric), 2x2 algebra in
scalars, one small product for the mean's step and the Joseph form's middle factor, and one rank-2
in-place correction of the covariance, P -= U M U^T with U = P H^T (the Joseph form exactly, see
_joseph_rows), O(n^2) in a single BLAS pass over the matrix of inner dimension 2 (2K for a frame
of K observations). filterpy's ExtendedKalmanFilter is not used for either: its predict forms
F P F^T densely (O(n^3)) and its update builds the dense (N, N) I - K H product. Nor is
filterpy.stats.mahalanobis, which inverts one S per call: association here scores every landmark
at once with closed-form 2x2 inverses (``nis_all``). filterpy does serve where it fits: the
movers' 4-state KalmanFilter (core/estimation/movers.py) and the NEES of the Monte Carlo runs
(simulation.pose_nees).
"""
from __future__ import annotations

import math
from typing import Iterable, NamedTuple, Sequence

import numpy as np
from scipy.linalg.blas import dgemm
from scipy.linalg.lapack import dposv

from companion.core.estimation.slam_types import (LANDMARK_DIM, POSE_DIM, AssociationGates,
                                                  Observation, SlamNoise, UpdateReport,
                                                  VelocityNoise)
from companion.core.geometry import TWO_PI, place_jacobians, wrap_angle, wrap_angles

_PI, _TWO_PI = math.pi, TWO_PI                  # wrap_angle's, written out on the hot path


class _Innovation(NamedTuple):
    """One observation against one landmark: innovation (2,), S and S^-1 as 2x2 tuples, H P
    (2, N) and the NIS. (A NamedTuple: a frozen dataclass costs a microsecond more to make.)"""
    innovation: tuple[float, float]
    s: tuple
    s_inv: tuple
    hp: np.ndarray
    nis: float


def _joseph_coef2(s00, s01, s11, i00, i01, i11, v0, v1) -> np.ndarray:
    """C of EkfSlam._joseph_rows for a 2-dimensional measurement, in scalars (a dozen numpy
    calls on 2x2 arrays cost more than the arithmetic): S = [[s00, s01], [s01, s11]], G = S^-1
    the same with i, innovation (v0, v1). Rows: M = 2G - G S G (symmetric by construction: its
    off-diagonal entry computed once), then (G v)^T."""
    m00, m01 = s00 * i00 + s01 * i01, s00 * i01 + s01 * i11              # S G
    m10, m11 = s01 * i00 + s11 * i01, s01 * i01 + s11 * i11
    j01 = 2.0 * i01 - (i00 * m01 + i01 * m11)
    return np.array((2.0 * i00 - (i00 * m00 + i01 * m10), j01,          # flat: half the time
                     j01, 2.0 * i11 - (i01 * m01 + i11 * m11),          # of nested tuples
                     i00 * v0 + i01 * v1, i01 * v0 + i11 * v1)).reshape(3, 2)


_STATE_COLUMNS: dict[int, np.ndarray] = {}


def _observed_states(index: int) -> np.ndarray:
    """The five states one observation of landmark ``index`` touches (pose, landmark), kept."""
    s0 = POSE_DIM + LANDMARK_DIM * index
    cols = np.array((0, 1, 2, s0, s0 + 1))
    cols.flags.writeable = False
    return _STATE_COLUMNS.setdefault(index, cols)


def _report(action, landmark_index, innovation, nis, obstacle_id) -> "UpdateReport":
    """UpdateReport(...) for the per-observation hot path: the same frozen object, its fields
    set directly (a frozen dataclass's __init__ sets each through object.__setattr__, about
    0.4 us warm, three times that after the BLAS pass)."""
    report = _new_object(UpdateReport)
    report.__dict__.update(action=action, landmark_index=landmark_index, innovation=innovation,
                           nis=nis, obstacle_id=obstacle_id)
    return report


_new_object = object.__new__


_FRAME_LAYOUTS: dict[int, tuple] = {}
_IDENTITIES: dict[tuple, np.ndarray] = {}


def _frame_layout(k_obs: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A frame of K observations' dense H (2K, 3+2K), on the pose and the K landmarks' states:
    its template (zeros, -1 on the yaw column of every bearing row), the flat positions of the
    eight entries each observation sets (-a, -b, a, b on its range row's pose and landmark
    columns, then c, -e, -c, e on its bearing row's), and the flat positions of each
    observation's s00, s01, s11 in S (2K, 2K). Kept per K, read-only."""
    layout = _FRAME_LAYOUTS.get(k_obs)
    if layout is None:
        width, put, gate = POSE_DIM + LANDMARK_DIM * k_obs, [], []
        template = np.zeros((2 * k_obs, width))
        template[1::2, 2] = -1.0
        for k in range(k_obs):
            for row in (2 * k * width, (2 * k + 1) * width):
                col = row + POSE_DIM + 2 * k
                put += (row, row + 1, col, col + 1)
            diag = 2 * k * (2 * k_obs + 1)
            gate += (diag, diag + 1, diag + 2 * k_obs + 1)
        layout = (template, np.array(put), np.array(gate))
        for array in layout:
            array.flags.writeable = False
        _FRAME_LAYOUTS[k_obs] = layout
    return layout


def _identity(k: int, scale: float = 1.0) -> np.ndarray:
    """``scale`` times the (k, k) identity, kept per (k, scale), read-only."""
    identity = _IDENTITIES.get((k, scale))
    if identity is None:
        identity = _IDENTITIES.setdefault((k, scale), np.eye(k) * scale)
        identity.flags.writeable = False
    return identity


def _spd_inverse(s: np.ndarray) -> np.ndarray:
    """S^-1 of a symmetric positive definite S by Cholesky (LAPACK dposv on the identity: one
    call, where numpy.linalg.inv's checks and LU cost several times more for a frame's S);
    numpy.linalg.inv if S is not positive definite to rounding."""
    _, inverse, info = dposv(s, _identity(len(s)))
    return inverse if info == 0 else np.linalg.inv(s)


class EkfSlam:
    """EKF-SLAM with known-id or gated nearest-neighbour data association.

    ``pose``: initial (3,) [north_m, east_m, yaw_rad]; ``pose_cov``: its (3,3) covariance.
    """

    def __init__(self, pose: Sequence[float], pose_cov: np.ndarray, noise: SlamNoise,
                 gates: AssociationGates = AssociationGates()) -> None:
        self.noise = noise
        self.gates = gates                      # sets the thresholds the hot path reads
        self._meas_cov = noise.measurement_cov()
        self._meas_cov_rows = tuple(map(tuple, self._meas_cov.tolist()))
        # Exact-size, C-contiguous arrays: the update writes the covariance in place through
        # BLAS, which needs contiguous memory.
        self._mean_buf = np.array(pose, dtype=float)
        self._mean_buf[2] = wrap_angle(self._mean_buf[2])
        self._cov_buf = np.array(pose_cov, dtype=float)
        self._dim = POSE_DIM
        self._id_to_index: dict[int, int] = {}
        self._index_to_id: list[int | None] = []
        self._scratch: tuple = (None,)          # see _make_scratch

    # ----------------------------------------------------------------- views
    @property
    def gates(self) -> AssociationGates:
        return self._gates

    @gates.setter
    def gates(self, gates: AssociationGates) -> None:
        self._gates = gates
        self._outlier_nis, self._pose_nis = gates.outlier_nis, gates.pose_nis

    @property
    def mean(self) -> np.ndarray:
        """The state mean (3+2n,), a view: do not modify."""
        return self._mean_buf[:self._dim]

    @property
    def cov(self) -> np.ndarray:
        """The state covariance (3+2n, 3+2n), a view: do not modify."""
        return self._cov_buf[:self._dim, :self._dim]

    @property
    def pose(self) -> np.ndarray:
        return self._mean_buf[:3].copy()

    @property
    def pose_cov(self) -> np.ndarray:
        return self._cov_buf[:3, :3].copy()

    @property
    def landmark_count(self) -> int:
        return (self._dim - POSE_DIM) // LANDMARK_DIM

    def landmarks(self) -> np.ndarray:
        """Landmark means, (n, 2) copy."""
        return self._mean_buf[POSE_DIM:self._dim].reshape(-1, 2).copy()

    def landmark_covs(self) -> np.ndarray:
        """Landmark marginal covariances, (n, 2, 2)."""
        idx = POSE_DIM + LANDMARK_DIM * np.arange(self.landmark_count)
        cov = self.cov
        out = np.empty((len(idx), 2, 2))
        out[:, 0, 0] = cov[idx, idx]
        out[:, 0, 1] = out[:, 1, 0] = cov[idx, idx + 1]
        out[:, 1, 1] = cov[idx + 1, idx + 1]
        return out

    def relative_covs(self) -> np.ndarray:
        """Covariance of (landmark - vehicle position) for every landmark, (n, 2, 2).

        This, not the landmark's own covariance, is what the avoidance needs: SLAM correlates the
        two, so the relative position is often much better known than either alone.
        """
        n = self.landmark_count
        cov = self.cov
        cross = cov[:2, POSE_DIM:].reshape(2, n, 2).transpose(1, 0, 2)  # (n, 2, 2): P_pm
        return self.landmark_covs() + cov[:2, :2] - cross - cross.transpose(0, 2, 1)

    def landmark_ids(self) -> list[int | None]:
        return list(self._index_to_id)

    # --------------------------------------------------------------- predict
    def predict(self, speed_mps: float, heading_change_rad: float, dt_s: float,
                speed_var_scale: float = 1.0, heading_var_extra: float = 0.0) -> None:
        """Propagate through the motion model with the odometry control [v, gamma].

        ``speed_var_scale`` multiplies the speed sample's variance, for a sample's interval
        predicted in parts; ``heading_var_extra`` (rad^2) adds to the heading change's variance
        (see Navigator.on_odometry).

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

    def update_yaw(self, yaw_rad: float, sigma_rad: float, gate_nis: float) -> UpdateReport:
        """Correct with a direct yaw measurement (the autopilot's AHRS yaw), R = sigma^2.

        The autopilot's yaw is the reference the vehicle flies by, so it is never refused: when
        its NIS exceeds ``gate_nis`` (1 dof) the yaw variance is first inflated by the squared
        innovation (a yaw reset, as ArduPilot's EKF does its own), then the update is made
        ('yaw_reset'; the report's NIS is the one before the reset). Refusing it instead would
        lock the filter out of the yaw for good once it had drifted past the gate.
        """
        cov = self._cov_buf
        innovation = wrap_angle(yaw_rad - self._mean_buf.item(2))
        var_r = sigma_rad ** 2
        nis = innovation * innovation / (cov.item(2, 2) + var_r)
        action = "yaw"
        if not nis <= gate_nis:
            cov[2, 2] += innovation * innovation
            action = "yaw_reset"
        s = cov.item(2, 2) + var_r                          # H = e_2: H P is row 2 of P
        s_inv = 1.0 / s
        hp = cov[2:3].copy()                                # not a view: the pass writes P
        coef = np.array(((2.0 * s_inv - s_inv * s * s_inv,), (s_inv * innovation,)))
        self._joseph_pass(hp, coef.dot(hp), 1)
        return UpdateReport(action, None, (innovation,), nis, None)

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

    def update_position(self, north_m: float, east_m: float, sigma_m: float,
                        gate_nis: float) -> UpdateReport:
        """Correct with a horizontal position fix (the autopilot's LOCAL_POSITION_NED x, y),
        R = sigma^2 I. Refused ('outlier', state untouched) when its NIS exceeds ``gate_nis``
        (2 dof), so a glitch cannot drag the pose and the map."""
        cov = self._cov_buf
        north, east = self._mean_buf[:2].tolist()
        v0, v1 = north_m - north, east_m - east
        (p00, p01), (_, p11) = cov[:2, :2].tolist()          # H = [I 0]: H P is rows 0, 1
        var_r = sigma_m ** 2
        s00, s01, s11 = p00 + var_r, p01, p11 + var_r
        det = s00 * s11 - s01 * s01
        i00, i01, i11 = s11 / det, -s01 / det, s00 / det
        nis = i00 * v0 * v0 + 2.0 * i01 * v0 * v1 + i11 * v1 * v1
        if not nis <= gate_nis:
            return UpdateReport("outlier", None, (v0, v1), nis, None)
        hp = cov[0:2].copy()                                # not a view: the pass writes P
        self._joseph_pass(hp, _joseph_coef2(s00, s01, s11, i00, i01, i11, v0, v1).dot(hp), 2)
        return UpdateReport("position", None, (v0, v1), nis, None)

    # ---------------------------------------------------------------- update
    def update_frame(self, observations: Iterable[Observation]) -> list[UpdateReport]:
        """Process one camera frame. Without ids, each landmark takes at most one observation."""
        used: set[int] = set()
        reports = []
        for obs in observations:
            report = self.update(obs, exclude=used)
            if report.landmark_index is not None:
                used.add(report.landmark_index)
            reports.append(report)
        return reports

    def update(self, obs: Observation, exclude: set[int] | None = None,
               landmark_only: bool = False) -> UpdateReport:
        """Associate one observation and update, or add a landmark, or drop it.

        ``landmark_only``: a Schmidt ("consider") update that corrects only the observed
        landmark and leaves the vehicle and every other landmark as they are, with the
        covariance kept exact for that suboptimal gain (Joseph form). The navigator uses it
        while a new landmark is on probation: if it turns out to move, it never touched the pose.
        """
        if obs.obstacle_id is not None:
            index = self._id_to_index.get(obs.obstacle_id)
            if index is not None:
                return self._update_known(obs, index, landmark_only)
            return self._add(np.array((float(obs.range_m), float(obs.bearing_rad))),
                             obs.obstacle_id, None if obs.meas_cov is None
                             else np.asarray(obs.meas_cov, dtype=float))
        z = (float(obs.range_m), float(obs.bearing_rad))     # numpy scalars cost 3x in arithmetic
        r = obs.meas_cov
        if r is not None:
            r = np.asarray(r, dtype=float)
        if self.landmark_count == 0:
            return self._add(np.array(z), None, r)
        nis_all, _ = self.nis_all(z, r)
        if exclude:
            nis_all[list(exclude)] = np.inf
        best = int(np.argmin(nis_all))
        best_nis = float(nis_all[best])
        if best_nis <= self.gates.accept_nis:
            return self._correct(self._innovation(z, best, r), best, None, landmark_only)
        if best_nis > self.gates.new_landmark_nis:
            return self._add(np.array(z), None, r)
        return UpdateReport("ambiguous", best, None, best_nis, None)

    def add_landmark(self, z: np.ndarray, obstacle_id: int | None = None,
                     meas_cov: np.ndarray | None = None) -> UpdateReport:
        """Start a landmark from measurement z (2,) the caller has judged new (R: ``meas_cov``
        (2,2), None: the filter's)."""
        return self._add(np.asarray(z, dtype=float), obstacle_id, meas_cov)

    def update_landmark(self, z: np.ndarray, index: int, landmark_only: bool = False,
                        meas_cov: np.ndarray | None = None) -> UpdateReport:
        """Update with measurement z (2,) of a landmark the caller has already associated."""
        return self._correct(self._innovation(z, index, meas_cov), index, self._index_to_id[index],
                             landmark_only)

    def update_batch(self, observations: Sequence[Observation]) -> list[UpdateReport]:
        """One joint update for a whole camera frame of observations with known obstacle ids.

        A separate path from :meth:`update` / :meth:`update_frame` (which stay as they are):
        K observations of K distinct mapped landmarks become one 2K-dimensional measurement,
        so the covariance takes one rank-2K Joseph correction in one BLAS pass (dgemm with
        inner dimension 2K) instead of K passes. Every Jacobian is taken at the prior mean (the
        sequential path relinearises after each observation): equal in the linear case, a
        second-order difference here. Each observation is gated alone (its own 2x2 block of
        the joint S, as :meth:`update` gates it) before the joint update; unknown ids become
        new landmarks afterwards, as in :meth:`update`.

        Returns one report per observation, in order. Raises ValueError for an observation
        without an id or two observations of one landmark.
        """
        known, indices, cols = [], [], [0, 1, 2]         # cols: the states the frame's H touches
        id_to_index = self._id_to_index
        for k, obs in enumerate(observations):
            if obs.obstacle_id is None:
                raise ValueError("update_batch needs obstacle ids (use update_frame without)")
            index = id_to_index.get(obs.obstacle_id)
            if index is not None:
                known.append(k)
                indices.append(index)
                cols += (POSE_DIM + LANDMARK_DIM * index, POSE_DIM + LANDMARK_DIM * index + 1)
        if len(set(indices)) != len(indices):
            raise ValueError("update_batch: two observations of one landmark in one frame")
        reports = [None] * len(observations)
        if known:
            for k, report in zip(known, self._correct_batch(
                    [observations[k] for k in known], indices, cols)):
                reports[k] = report
        for k, obs in enumerate(observations):
            if reports[k] is None:
                reports[k] = self._add(np.array([obs.range_m, obs.bearing_rad]), obs.obstacle_id)
        return reports

    def _correct_batch(self, observations: Sequence[Observation], indices: Sequence[int],
                       cols: list[int]) -> list[UpdateReport]:
        """Joint Joseph update of the landmarks ``indices`` (K,) observed as ``observations``;
        ``cols``: the 3+2K states H touches (the pose, then each landmark's two).

        H is (2K, 3+2K) on those states; each row touches five of them only, but one dense
        product H P (2K, N) of the 3+2K rows of P it touches is one call, where the sparse sum
        took four (the arithmetic is a few hundred thousand products either way, against the
        pass's 2K N^2). The innovations, H's entries and each observation's gate in scalars,
        per observation (numpy calls on K-vectors cost more, a dozen of them). S (2K, 2K) from
        those columns of H P, S^-1 by a Cholesky solve (S is symmetric positive definite).
        Returns the observations' reports, in order.
        """
        mean, cov, k_obs = self._mean_buf, self._cov_buf, len(indices)
        template, put, gate = _frame_layout(k_obs)
        cols = np.array(cols)
        states = mean.take(cols).tolist()
        north, east, yaw = states[:POSE_DIM]
        entries, innovation = [], []
        for k, obs in enumerate(observations):
            d_north = states[POSE_DIM + 2 * k] - north
            d_east = states[POSE_DIM + 2 * k + 1] - east
            range_sq = d_north * d_north + d_east * d_east
            range_m = math.sqrt(range_sq)
            a, b = d_north / range_m, d_east / range_m
            c, e = d_east / range_sq, d_north / range_sq
            entries += (-a, -b, a, b, c, -e, -c, e)
            innovation += (float(obs.range_m) - range_m, (float(obs.bearing_rad) - (
                math.atan2(d_east, d_north) - yaw) + _PI) % _TWO_PI - _PI)     # wrap_angle
        jac = template.copy()                                       # H on (pose, landmarks)
        jac.put(put, entries)
        hp = jac.dot(cov.take(cols, axis=0))                        # H P, (2K, N)
        s = hp.take(cols, axis=1).dot(jac.T)
        s += s.T
        s *= 0.5
        s += self._block_meas_cov(k_obs)
        # each observation gated alone, on its own 2x2 block of S
        blocks, outlier_nis, reports, ok = s.take(gate).tolist(), self._outlier_nis, [], []
        for k, obs in enumerate(observations):
            s00, s01, s11 = blocks[3 * k:3 * k + 3]
            v_r, v_b = innovation[2 * k], innovation[2 * k + 1]
            nis = (s11 * v_r * v_r - 2.0 * s01 * v_r * v_b + s00 * v_b * v_b) / (
                s00 * s11 - s01 * s01)
            ok.append(nis <= outlier_nis)
            report = _new_object(UpdateReport)                      # _report, written out
            report.__dict__.update(action="updated" if ok[-1] else "outlier",
                                   landmark_index=indices[k], innovation=(v_r, v_b), nis=nis,
                                   obstacle_id=obs.obstacle_id)
            reports.append(report)
        if not any(ok):
            return reports
        if not all(ok):
            keep = np.repeat(ok, 2)
            hp, s = hp[keep], s[np.ix_(keep, keep)]
            innovation = np.array(innovation)[keep]
        # one rank-2K Joseph correction, the same single dgemm pass as one observation's
        self._joseph_rows(hp, s, _spd_inverse(s), innovation)
        return reports

    def _block_meas_cov(self, k_obs: int) -> np.ndarray:
        """R of K observations stacked, block diagonal (2K, 2K), kept per K."""
        cache = self.__dict__.setdefault("_block_r", {})
        if k_obs not in cache:
            cache[k_obs] = np.kron(np.eye(k_obs), self._meas_cov)
        return cache[k_obs]

    def set_landmark_id(self, index: int, obstacle_id: int) -> None:
        """Name a landmark (the navigator gives id-less ones internal negative ids)."""
        old = self._index_to_id[index]
        if old is not None:
            self._id_to_index.pop(old, None)
        self._index_to_id[index] = obstacle_id
        self._id_to_index[obstacle_id] = index

    def nis_all(self, z: np.ndarray, meas_cov: np.ndarray | None = None
                ) -> tuple[np.ndarray, np.ndarray]:
        """NIS of measurement z (2,) against every landmark, vectorised: ((n,), (n, 2) innovations).
        R: ``meas_cov`` (2,2), None: the filter's."""
        n = self.landmark_count
        mean, cov = self.mean, self.cov
        lm = mean[POSE_DIM:].reshape(n, 2)
        d = lm - mean[:2]
        range_sq = np.einsum("ij,ij->i", d, d)
        range_m = np.sqrt(range_sq)
        innovation = np.empty((n, 2))
        innovation[:, 0] = z[0] - range_m
        innovation[:, 1] = wrap_angles(z[1] - (np.arctan2(d[:, 1], d[:, 0]) - mean[2]))
        # H_m (n,2,2) and H_v = [-H_m | (0, -1)^T]
        jac_lm = np.empty((n, 2, 2))
        jac_lm[:, 0, 0] = d[:, 0] / range_m
        jac_lm[:, 0, 1] = d[:, 1] / range_m
        jac_lm[:, 1, 0] = -d[:, 1] / range_sq
        jac_lm[:, 1, 1] = d[:, 0] / range_sq
        jac_pose = np.zeros((n, 2, 3))
        jac_pose[:, :, :2] = -jac_lm
        jac_pose[:, 1, 2] = -1.0
        cross = cov[:3, POSE_DIM:].reshape(3, n, 2).transpose(1, 0, 2)      # P_vm, (n,3,2)
        mixed = jac_pose @ cross @ jac_lm.transpose(0, 2, 1)              # H_v P_vm H_m^T
        s = (jac_pose @ cov[:3, :3] @ jac_pose.transpose(0, 2, 1)
             + mixed + mixed.transpose(0, 2, 1)
             + jac_lm @ self.landmark_covs() @ jac_lm.transpose(0, 2, 1)
             + (self._meas_cov if meas_cov is None else meas_cov))
        det = s[:, 0, 0] * s[:, 1, 1] - s[:, 0, 1] * s[:, 1, 0]
        nis = (s[:, 1, 1] * innovation[:, 0] ** 2
               - (s[:, 0, 1] + s[:, 1, 0]) * innovation[:, 0] * innovation[:, 1]
               + s[:, 0, 0] * innovation[:, 1] ** 2) / det
        return nis, innovation

    def joint_nis(self, z: np.ndarray, indices: Sequence[int],
                  meas_covs: np.ndarray | None = None) -> float:
        """NIS of K observations z (K, 2) taken jointly as measurements of the distinct landmarks
        ``indices`` (K,): the stacked innovation against the joint S (2K, 2K), which holds the
        observations' correlation through the shared pose. Chi-square with 2K dof when every
        pairing is right (joint compatibility, Neira and Tardos 2001)."""
        indices = np.asarray(indices, dtype=int)
        k_obs, n = len(indices), self._dim
        if k_obs == 0:
            return 0.0
        mean = self._mean_buf
        lm_cols = (POSE_DIM + LANDMARK_DIM * indices[:, None] + np.arange(2)).ravel()
        d = mean[lm_cols].reshape(k_obs, 2) - mean[:2]
        range_sq = np.einsum("ij,ij->i", d, d)
        range_m = np.sqrt(range_sq)
        innovation = np.empty((k_obs, 2))
        innovation[:, 0] = z[:, 0] - range_m
        innovation[:, 1] = wrap_angles(z[:, 1] - (np.arctan2(d[:, 1], d[:, 0]) - mean[2]))
        rows = np.arange(k_obs)
        lm = np.empty((k_obs, 2, 2))
        lm[:, 0, 0], lm[:, 0, 1] = d[:, 0] / range_m, d[:, 1] / range_m
        lm[:, 1, 0], lm[:, 1, 1] = -d[:, 1] / range_sq, d[:, 0] / range_sq
        jac = np.zeros((k_obs, 2, POSE_DIM + 2 * k_obs))
        jac[:, :, :2] = -lm
        jac[:, 1, 2] = -1.0
        jac[:, :, POSE_DIM:].reshape(k_obs, 2, k_obs, 2)[rows, :, rows, :] = lm
        jac = jac.reshape(2 * k_obs, -1)
        cols = np.concatenate((np.arange(POSE_DIM), lm_cols))
        s = jac @ self._cov_buf[:n, :n][np.ix_(cols, cols)] @ jac.T
        s4 = s.reshape(k_obs, 2, k_obs, 2)
        s4[rows, :, rows, :] += self._meas_cov if meas_covs is None else meas_covs
        v = innovation.ravel()
        return float(v @ np.linalg.solve(s, v))

    def nis_against(self, z: np.ndarray, index: int) -> tuple[float, np.ndarray]:
        """NIS and innovation of z against one landmark."""
        parts = self._innovation(z, index)
        return parts.nis, np.array(parts.innovation)

    def _innovation(self, z, index: int, meas_cov=None) -> "_Innovation":
        """Innovation, S, its inverse and H P of one range-bearing observation z of a landmark.

        H touches five states only (the pose and the landmark): with a = dn/r, b = de/r,
        c = de/r^2, e = dn/r^2 its rows are [-a, -b, 0, a, b] and [c, -e, -1, -c, e] on the
        columns (0, 1, 2, m, m+1). H P (2, N) comes from those five rows of P (contiguous, P is
        symmetric) in one small product; S and its inverse are 2x2, written out in scalars.
        """
        mean, cov = self._mean_buf, self._cov_buf
        cols = _STATE_COLUMNS.get(index)
        if cols is None:
            cols = _observed_states(index)
        north, east, yaw, d_north, d_east = mean.take(cols).tolist()
        d_north -= north
        d_east -= east
        range_sq = d_north * d_north + d_east * d_east
        range_m = math.sqrt(range_sq)
        innov_r = z[0] - range_m
        innov_b = wrap_angle(z[1] - (math.atan2(d_east, d_north) - yaw))
        a, b = d_north / range_m, d_east / range_m
        c, e = d_east / range_sq, d_north / range_sq
        jac = np.array(((-a, -b, 0.0, a, b), (c, -e, -1.0, -c, e)))
        hp = jac.dot(cov.take(cols, axis=0))                          # H P, (2, N)
        (h00, h01, h02, h03, h04), (h10, h11, h12, h13, h14) = hp.take(cols, axis=1).tolist()
        u0, v0, u1, v1 = h03 - h00, h04 - h01, h13 - h10, h14 - h11   # S = H P H^T
        if meas_cov is None:
            (r00, r01), (_, r11) = self._meas_cov_rows
        else:
            (r00, r01), (_, r11) = meas_cov
        s00 = a * u0 + b * v0 + r00
        s01 = 0.5 * ((-c * u0 + e * v0 - h02) + (a * u1 + b * v1)) + r01
        s11 = -c * u1 + e * v1 - h12 + r11
        det = s00 * s11 - s01 * s01
        i00, i01, i11 = s11 / det, -s01 / det, s00 / det
        nis = (i00 * innov_r * innov_r + 2.0 * i01 * innov_r * innov_b
               + i11 * innov_b * innov_b)
        return _Innovation((innov_r, innov_b), ((s00, s01), (s01, s11)),
                           ((i00, i01), (i01, i11)), hp, nis)

    def _update_known(self, obs: Observation, index: int, landmark_only: bool) -> UpdateReport:
        """:meth:`update` of an observation its id has associated with landmark ``index``:
        :meth:`_innovation`, the gates and :meth:`_correct_pose` in one function, the navigator's
        hot path (their calls and the _Innovation between them cost about 2 us in 15 of
        non-BLAS work at 200 landmarks). The arithmetic is theirs, line for line, so the result
        is bit-identical (tests/core/test_ekf_update_paths.py checks it against update_landmark,
        which goes through them); falls back to them off the straight path. Right after the
        previous BLAS pass every step here costs about 3 times its warm time, so what is cheap
        warm counts: H and [M; (G v)^T] filled into arrays kept in the scratch, wrap_angle and
        _report written out, the gates' thresholds read from attributes (not the property)."""
        mean, cov, scratch = self._mean_buf, self._cov_buf, self._scratch
        if scratch[0] is not cov:
            scratch = self._make_scratch()
        cols = _STATE_COLUMNS.get(index)
        if cols is None:
            cols = _observed_states(index)
        north, east, yaw, d_north, d_east = mean.take(cols).tolist()
        d_north -= north
        d_east -= east
        range_sq = d_north * d_north + d_east * d_east
        range_m = math.sqrt(range_sq)
        v0 = float(obs.range_m) - range_m                  # numpy scalars cost 3x in arithmetic
        v1 = (float(obs.bearing_rad) - (math.atan2(d_east, d_north) - yaw) + _PI) % _TWO_PI - _PI
        a, b = d_north / range_m, d_east / range_m
        c, e = d_east / range_sq, d_north / range_sq
        scratch[6][:] = (-a, -b, 0.0, a, b, c, -e, -1.0, -c, e)           # H on the 5 states
        hp = scratch[5].dot(cov.take(cols, axis=0))
        (h00, h01, h02, h03, h04), (h10, h11, h12, h13, h14) = hp.take(cols, axis=1).tolist()
        u0, u1, w0, w1 = h03 - h00, h13 - h10, h04 - h01, h14 - h11
        meas_cov = obs.meas_cov
        if meas_cov is None:
            (r00, r01), (_, r11) = self._meas_cov_rows
        else:
            (r00, r01), (_, r11) = meas_cov
        s00 = a * u0 + b * w0 + r00
        s01 = 0.5 * ((-c * u0 + e * w0 - h02) + (a * u1 + b * w1)) + r01
        s11 = -c * u1 + e * w1 - h12 + r11
        det = s00 * s11 - s01 * s01
        i00, i01, i11 = s11 / det, -s01 / det, s00 / det
        nis = i00 * v0 * v0 + 2.0 * i01 * v0 * v1 + i11 * v1 * v1
        if nis > self._outlier_nis:
            return UpdateReport("outlier", index, (v0, v1), nis, obs.obstacle_id)
        if landmark_only or nis > self._pose_nis:
            return self._correct(_Innovation((v0, v1), ((s00, s01), (s01, s11)),
                                             ((i00, i01), (i01, i11)), hp, nis),
                                 index, obs.obstacle_id, True)
        m00, m01 = s00 * i00 + s01 * i01, s00 * i01 + s01 * i11              # S G
        m10, m11 = s01 * i00 + s11 * i01, s01 * i01 + s11 * i11
        j01 = 2.0 * i01 - (i00 * m01 + i01 * m11)                           # M = 2G - G S G
        scratch[8][:] = (2.0 * i00 - (i00 * m00 + i01 * m10), j01,
                         j01, 2.0 * i11 - (i01 * m01 + i11 * m11),
                         i00 * v0 + i01 * v1, i01 * v0 + i11 * v1)
        np.dot(scratch[7], hp, out=scratch[1])
        mean += scratch[2]
        mean[2] = (mean.item(2) + _PI) % _TWO_PI - _PI                      # wrap_angle
        # the report made before the pass (after it, making it costs 3x): _report, written out
        report = _new_object(UpdateReport)
        report.__dict__.update(action="updated", landmark_index=index, innovation=(v0, v1),
                               nis=nis, obstacle_id=obs.obstacle_id)
        dgemm(-1.0, hp.T, scratch[3], 1.0, scratch[4], 0, 1, 1)
        return report

    def _correct(self, parts: "_Innovation", index: int, obstacle_id: int | None,
                 landmark_only: bool = False) -> UpdateReport:
        """Kalman update of one landmark; Joseph form, applied in place as one rank-2 correction
        (:meth:`_joseph_rows`), or the landmark-only (Schmidt) update."""
        if landmark_only:
            self._correct_landmark_only(index, np.array(parts.innovation), np.array(parts.s),
                                        np.array(parts.s_inv), parts.hp.T)
            return UpdateReport("updated", index, parts.innovation, parts.nis, obstacle_id)
        return self._correct_pose(parts, index, obstacle_id)

    def _correct_pose(self, parts: "_Innovation", index: int,
                      obstacle_id: int | None) -> UpdateReport:
        """:meth:`_correct` of the whole state (not landmark-only): :meth:`_joseph_rows` for a
        2-dimensional measurement, M of :func:`_joseph_coef2` written out here, one call fewer
        on the navigator's path."""
        (s00, s01), (_, s11) = parts.s
        (i00, i01), (_, i11) = parts.s_inv
        v0, v1 = parts.innovation
        m00, m01 = s00 * i00 + s01 * i01, s00 * i01 + s01 * i11              # S G
        m10, m11 = s01 * i00 + s11 * i01, s01 * i01 + s11 * i11
        j01 = 2.0 * i01 - (i00 * m01 + i01 * m11)                           # M = 2G - G S G
        coef = np.array((2.0 * i00 - (i00 * m00 + i01 * m10), j01,
                         j01, 2.0 * i11 - (i01 * m01 + i11 * m11),
                         i00 * v0 + i01 * v1, i01 * v0 + i11 * v1)).reshape(3, 2)
        # The rank-2 path, the navigator's: [M; (G v)^T] H P into a buffer kept with the
        # covariance, whose views dgemm and the mean take are made once per size (each numpy
        # call after the BLAS pass, which has just streamed P through the cache, costs about 3x
        # its warm time).
        scratch = self._scratch
        if scratch[0] is not self._cov_buf:
            scratch = self._make_scratch()
        np.dot(coef, parts.hp, out=scratch[1])
        mean = self._mean_buf
        mean += scratch[2]
        mean[2] = wrap_angle(mean.item(2))
        dgemm(-1.0, parts.hp.T, scratch[3], 1.0, scratch[4], 0, 1, 1)
        return _report("updated", index, parts.innovation, parts.nis, obstacle_id)

    def _make_scratch(self) -> tuple:
        """(P, rows (3, N), the mean's step row, (M H P)^T as a Fortran (N, 2) view, P^T,
        H (2, 5) and its flat view, [M; (G v)^T] (3, 2) and its flat view) for the rank-2 pass
        of :meth:`_update_known` and :meth:`_correct_pose`, made again whenever P is
        reallocated (filling a kept array from a tuple costs half of making one)."""
        rows = np.empty((LANDMARK_DIM + 1, self._cov_buf.shape[0]))
        jac, coef = np.empty((LANDMARK_DIM, 5)), np.empty((LANDMARK_DIM + 1, LANDMARK_DIM))
        self._scratch = (self._cov_buf, rows, rows[LANDMARK_DIM], rows[:LANDMARK_DIM].T,
                         self._cov_buf.T, jac, jac.reshape(-1), coef, coef.reshape(-1))
        return self._scratch

    def _joseph_rows(self, hp: np.ndarray, s, s_inv, innovation) -> None:
        """The in-place mean and Joseph update from H P (k, N), S and G = S^-1 (k, k),
        innovation (k,).

        Joseph: P <- (I-KH) P (I-KH)^T + K R K^T = P - K U^T - U K^T + K S K^T, U = P H^T.
        With the gain K = U G (G the S^-1 computed, rounding and all) that is exactly
            P - U M U^T,   M = G + G^T - G S G^T  (2G - G S G: S and G symmetric),
        a rank-k correction, one dgemm pass of inner dimension k whose operands are U = (H P)^T
        and (M H P)^T, Fortran-ordered (N, k) views of C-ordered rows, so the pass copies
        nothing. (The former P - [K B][B K]^T, B = U - K S / 2, is the same matrix at inner
        dimension 2k: twice the arithmetic, which costs twice the time once the pass is no
        longer bound by memory, as for a frame.) The mean's step K v = (G v)^T H P is one more
        row of the same product.
        """
        k = len(s_inv)
        right = np.empty((k, k + 1))                                 # [2I - S G, v]
        np.subtract(_identity(k, 2.0), np.dot(s, s_inv), out=right[:, :k])
        right[:, k] = innovation
        # G [2I - S G, v] = [M, G v]: its transpose's rows are [M^T; (G v)^T], M^T = M to rounding
        self._joseph_pass(hp, np.dot(s_inv, right).T.dot(hp), k)

    def _joseph_pass(self, hp: np.ndarray, rows: np.ndarray, k: int) -> None:
        """Apply [M; (G v)^T] H P (k+1, N) of :meth:`_joseph_rows` to the mean and the
        covariance; ``hp``: H P (k, N), C-contiguous (else dgemm would copy its transpose),
        not a view of P (which the pass writes)."""
        mean = self._mean_buf
        mean += rows[k]
        mean[2] = wrap_angle(mean.item(2))
        # P -= U (M H P) in one BLAS pass, no (N, N) temporary: P is symmetric, so its
        # transpose is a Fortran-ordered view of the same memory, which dgemm updates in
        # place (P^T <- P^T - U (U M)^T). numpy's ``P -= left @ right.T`` takes two passes.
        dgemm(-1.0, hp.T, rows[:k].T, 1.0, self._cov_buf.T, 0, 1, 1)

    def _correct_landmark_only(self, index: int, innovation: np.ndarray, s: np.ndarray,
                               s_inv: np.ndarray, p_ht: np.ndarray) -> None:
        """Schmidt update: gain zero outside the landmark's two rows. O(n).

        With K = [0; K_m; 0], Joseph gives P'_mj = P_mj - K_m (HP)_j off the landmark's block and
        P'_mm = P_mm - K_m (HP)_m - (PH^T)_m K_m^T + K_m S K_m^T; every other entry is unchanged.
        """
        m = slice(POSE_DIM + LANDMARK_DIM * index, POSE_DIM + LANDMARK_DIM * index + 2)
        cov = self._cov_buf
        gain_m = p_ht[m] @ s_inv                                   # (2, 2)
        self._mean_buf[m] += gain_m @ innovation
        rows = cov[m, :] - gain_m @ p_ht.T                         # (2, N)
        block = cov[m, m] - gain_m @ p_ht[m].T - p_ht[m] @ gain_m.T + gain_m @ s @ gain_m.T
        rows[:, m] = 0.5 * (block + block.T)
        cov[m, :] = rows
        cov[:, m] = rows.T

    def _add(self, z: np.ndarray, obstacle_id: int | None,
             meas_cov: np.ndarray | None = None) -> UpdateReport:
        """Initialise a landmark from one observation, with its full cross-covariance."""
        dim = self._dim
        self._grow(dim + LANDMARK_DIM)
        pose = self._mean_buf[:3]
        direction = pose[2] + z[1]
        position = (pose[0] + z[0] * math.cos(direction), pose[1] + z[0] * math.sin(direction))
        jac_pose, jac_meas = place_jacobians(pose, z)
        cov = self._cov_buf
        cross = jac_pose @ cov[:3, :dim]                          # (2, N): cov(new, old state)
        new_cov = jac_pose @ cov[:3, :3] @ jac_pose.T + jac_meas @ (
            self._meas_cov if meas_cov is None else meas_cov) @ jac_meas.T
        self._mean_buf[dim:dim + 2] = position
        cov[dim:dim + 2, :dim] = cross
        cov[:dim, dim:dim + 2] = cross.T
        cov[dim:dim + 2, dim:dim + 2] = new_cov
        self._dim = dim + LANDMARK_DIM
        index = len(self._index_to_id)
        self._index_to_id.append(obstacle_id)
        if obstacle_id is not None:
            self._id_to_index[obstacle_id] = index
        return UpdateReport("added", index, None, None, obstacle_id)

    def copy(self) -> "EkfSlam":
        """An independent copy (for the navigator's rollback when a young landmark moves)."""
        clone = object.__new__(EkfSlam)
        clone.__dict__.update(self.__dict__)
        clone._mean_buf = self._mean_buf.copy()
        clone._cov_buf = self._cov_buf.copy()
        clone._id_to_index = dict(self._id_to_index)
        clone._index_to_id = list(self._index_to_id)
        return clone

    def remove_landmark(self, index: int) -> None:
        """Marginalise a landmark out of the state (a Gaussian's marginal: drop its rows/columns).

        Later landmarks shift down one index; their ids follow them.
        """
        if not 0 <= index < self.landmark_count:
            raise IndexError(f"no landmark {index}")
        s0 = POSE_DIM + LANDMARK_DIM * index
        dim = self._dim
        keep = np.r_[0:s0, s0 + LANDMARK_DIM:dim]
        self._mean_buf = self._mean_buf[keep]
        self._cov_buf = np.ascontiguousarray(self._cov_buf[np.ix_(keep, keep)])
        self._dim = dim - LANDMARK_DIM
        removed = self._index_to_id.pop(index)
        if removed is not None:
            self._id_to_index.pop(removed, None)
        self._id_to_index = {oid: i for i, oid in enumerate(self._index_to_id) if oid is not None}

    def remove_landmarks(self, indices: Sequence[int]) -> None:
        """Marginalise several landmarks at once (one O(n^2) gather, as remove_landmark for
        one): their rows and columns go, the rest of the mean and covariance is unchanged."""
        drop = sorted(set(int(i) for i in indices))
        if not drop:
            return
        if drop[0] < 0 or drop[-1] >= self.landmark_count:
            raise IndexError(f"no landmark {drop[0] if drop[0] < 0 else drop[-1]}")
        keep_state = np.ones(self._dim, dtype=bool)
        for index in drop:
            s0 = POSE_DIM + LANDMARK_DIM * index
            keep_state[s0:s0 + LANDMARK_DIM] = False
        keep = np.flatnonzero(keep_state)
        self._mean_buf = self._mean_buf[keep]
        self._cov_buf = np.ascontiguousarray(self._cov_buf[np.ix_(keep, keep)])
        self._dim = len(keep)
        gone = set(drop)
        self._index_to_id = [oid for i, oid in enumerate(self._index_to_id) if i not in gone]
        self._id_to_index = {oid: i for i, oid in enumerate(self._index_to_id) if oid is not None}

    def _grow(self, dim: int) -> None:
        """Reallocate to ``dim`` (O(n^2), once per new landmark; updates stay in place)."""
        old = self._dim
        mean = np.zeros(dim)
        cov = np.zeros((dim, dim))
        mean[:old] = self._mean_buf
        cov[:old, :old] = self._cov_buf
        self._mean_buf, self._cov_buf = mean, cov

    # ------------------------------------------------------------- health
    def is_healthy(self) -> bool:
        """Finite mean, finite non-negative covariance diagonal. O(n): it runs before every
        decision; a NaN anywhere in the covariance reaches the mean and the diagonal at the
        next update, through the gain."""
        diag = np.diagonal(self._cov_buf)
        return bool(np.isfinite(self._mean_buf).all() and np.isfinite(diag).all()
                    and (diag >= 0.0).all())
