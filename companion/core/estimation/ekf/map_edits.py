"""The filter's map edits (EkfSlam's): a landmark added from one observation with its full
cross-covariance, named, or marginalised out (its rows and columns dropped), and the buffers grown.
"""
from __future__ import annotations

import math
from typing import Sequence

import numpy as np

from companion.core.estimation.slam_types import LANDMARK_DIM, POSE_DIM, UpdateReport
from companion.core.geometry import place_jacobians


class EkfMapEdits:
    """EkfSlam's landmarks added and removed (a mixin: the state is EkfSlam's)."""

    def add_landmark(self, z: np.ndarray, obstacle_id: int | None = None,
                     meas_cov: np.ndarray | None = None) -> UpdateReport:
        """Start a landmark from measurement z (2,) the caller has judged new (R: ``meas_cov``
        (2,2), None: the filter's)."""
        return self._add(np.asarray(z, dtype=float), obstacle_id, meas_cov)

    def set_landmark_id(self, index: int, obstacle_id: int) -> None:
        """Name a landmark (the navigator gives id-less ones internal negative ids)."""
        old = self._index_to_id[index]
        if old is not None:
            self._id_to_index.pop(old, None)
        self._index_to_id[index] = obstacle_id
        self._id_to_index[obstacle_id] = index

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
