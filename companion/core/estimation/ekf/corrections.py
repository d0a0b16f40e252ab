"""The filter's corrections (EkfSlam's): one range-bearing observation's innovation, S and H P
(``_innovation``), the known-id hot path (``_update_known``), the Joseph-form correction as one
rank-k in-place BLAS pass (``_correct_pose``, ``_joseph_rows``, ``_joseph_pass``), the
landmark-only Schmidt update (``_correct_landmark_only``), and the autopilot's yaw and horizontal
position as direct measurements (``update_yaw``, ``update_position``).

The hot path (``_update_known``) writes out what ``_innovation`` and ``_correct_pose`` do, line
for line, on purpose (a call and a record fewer per observation);
tests/core/test_ekf_update_paths.py checks the two ways agree bit for bit. Change both together.
"""
from __future__ import annotations

import math

import numpy as np
from scipy.linalg.blas import dgemm

from companion.core.estimation.ekf.kernels import (_PI, _STATE_COLUMNS, _TWO_PI, _Innovation,
                                                   _identity, _joseph_coef2, _new_object,
                                                   _observed_states, _report)
from companion.core.estimation.slam_types import (LANDMARK_DIM, POSE_DIM, Observation,
                                                  UpdateReport)
from companion.core.geometry import wrap_angle


class EkfCorrections:
    """EkfSlam's measurement corrections (a mixin: the state is EkfSlam's)."""

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

    def _innovation(self, z, index: int, meas_cov=None,
                    range_modelled: bool = False) -> "_Innovation":
        """Innovation, S, its inverse and H P of one range-bearing observation z of a landmark.
        ``range_modelled`` with a range model set (EkfSlam.set_range_model): R's range variance
        is the model's at the predicted range.

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
        if range_modelled and self._range_model is not None:
            r00 = self._modelled_range_var(range_sq)
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
        if obs.range_modelled and self._range_model is not None:     # as in _innovation
            r00 = self._modelled_range_var(range_sq)
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
