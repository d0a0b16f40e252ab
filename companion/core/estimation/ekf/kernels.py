"""The EKF-SLAM filter's small helpers: the innovation's record, the Joseph form's 2x2 middle
factor in scalars, the state columns one observation touches, a fast UpdateReport, a frame's dense
H layout, kept identities and a Cholesky inverse (LAPACK dposv).

Read-only caches live here (per landmark index, per frame size); nothing here holds filter state.
The leading underscores say: the filter's own (core/estimation/ekf/), not for callers.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from scipy.linalg.lapack import dposv

from companion.core.estimation.slam_types import LANDMARK_DIM, POSE_DIM, UpdateReport
from companion.core.geometry import TWO_PI

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
