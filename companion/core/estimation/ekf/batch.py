"""A whole camera frame as one joint update (EkfSlam.update_batch): K observations of K mapped
landmarks, one 2K-dimensional Joseph correction in one BLAS pass. Used by tests and benchmarks
only (the navigator updates observation by observation, relinearising after each).
"""
from __future__ import annotations

import math
from typing import Sequence

import numpy as np

from companion.core.estimation.ekf.kernels import (_PI, _TWO_PI, _frame_layout, _new_object,
                                                   _spd_inverse)
from companion.core.estimation.slam_types import (LANDMARK_DIM, POSE_DIM, Observation,
                                                  UpdateReport)


class EkfBatch:
    """EkfSlam's joint frame update (a mixin: the state is EkfSlam's)."""

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
