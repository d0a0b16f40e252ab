"""The filter's association scores (EkfSlam's): one measurement's NIS against every landmark at
once, with closed-form 2x2 inverses (``nis_all``); K observations' joint NIS (``joint_nis``, joint
compatibility); one landmark's (``nis_against``).
"""
from __future__ import annotations

from typing import Sequence

import numpy as np

from companion.core.estimation.slam_types import LANDMARK_DIM, POSE_DIM
from companion.core.geometry import wrap_angles


class EkfNis:
    """EkfSlam's NIS for data association (a mixin: the state is EkfSlam's)."""

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
