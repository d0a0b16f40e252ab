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

The class is one object on one state (the mean and covariance buffers below); its methods are
grouped by job in core/estimation/ekf/ and composed here as mixins: motion.py (the predicts),
corrections.py (the innovation and the Joseph-form corrections, the yaw and position fixes),
nis.py (association scores), batch.py (a frame as one joint update, for tests and benchmarks),
map_edits.py (landmarks added and removed), kernels.py (the hot path's helpers). What stays here:
the state, its views, the association entry points (``update``, ``update_frame``,
``update_landmark``), ``copy`` and ``is_healthy``.
"""
from __future__ import annotations

from typing import Iterable, Sequence

import numpy as np

from companion.core.estimation.ekf.batch import EkfBatch
from companion.core.estimation.ekf.corrections import EkfCorrections
from companion.core.estimation.ekf.map_edits import EkfMapEdits
from companion.core.estimation.ekf.motion import EkfMotion
from companion.core.estimation.ekf.nis import EkfNis
from companion.core.estimation.slam_types import (LANDMARK_DIM, POSE_DIM, AssociationGates,
                                                  Observation, SlamNoise, UpdateReport,
                                                  VelocityNoise)
from companion.core.geometry import wrap_angle

__all__ = ["EkfSlam", "AssociationGates", "Observation", "SlamNoise", "UpdateReport",
           "VelocityNoise"]


class EkfSlam(EkfMotion, EkfCorrections, EkfNis, EkfBatch, EkfMapEdits):
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
        self._range_model: tuple[float, float] | None = None   # see set_range_model

    def set_range_model(self, floor_m: float, k_per_m: float) -> None:
        """Updates evaluate a range-modelled observation's range sigma (Observation.range_modelled)
        again at the landmark's predicted range r: floor + k r^2 (core/estimation/range_noise.py:
        R at the measured range biases the map short); its bearing variance is kept."""
        self._range_model = (float(floor_m), float(k_per_m))

    def _modelled_range_var(self, range_sq: float) -> float:
        """The range model's variance (floor + k r^2)^2 at the predicted range r, given r^2
        (both update paths have it; only called with a model set)."""
        floor_m, k_per_m = self._range_model
        sigma = floor_m + k_per_m * range_sq
        return sigma * sigma

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
            return self._correct(self._innovation(z, best, r, obs.range_modelled), best, None,
                                 landmark_only)
        if best_nis > self.gates.new_landmark_nis:
            return self._add(np.array(z), None, r)
        return UpdateReport("ambiguous", best, None, best_nis, None)

    def update_landmark(self, z: np.ndarray, index: int, landmark_only: bool = False,
                        meas_cov: np.ndarray | None = None,
                        range_modelled: bool = False) -> UpdateReport:
        """Update with measurement z (2,) of a landmark the caller has already associated
        (``range_modelled``: ``meas_cov`` is the range model's, Observation.range_modelled)."""
        return self._correct(self._innovation(z, index, meas_cov, range_modelled), index,
                             self._index_to_id[index], landmark_only)

    def copy(self) -> "EkfSlam":
        """An independent copy (for the navigator's rollback when a young landmark moves)."""
        clone = object.__new__(EkfSlam)
        clone.__dict__.update(self.__dict__)
        clone._mean_buf = self._mean_buf.copy()
        clone._cov_buf = self._cov_buf.copy()
        clone._id_to_index = dict(self._id_to_index)
        clone._index_to_id = list(self._index_to_id)
        return clone

    # ------------------------------------------------------------- health
    def is_healthy(self) -> bool:
        """Finite mean, finite non-negative covariance diagonal. O(n): it runs before every
        decision; a NaN anywhere in the covariance reaches the mean and the diagonal at the
        next update, through the gain."""
        diag = np.diagonal(self._cov_buf)
        return bool(np.isfinite(self._mean_buf).all() and np.isfinite(diag).all()
                    and (diag >= 0.0).all())
