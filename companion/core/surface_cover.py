"""Which landmarks already hold the stretch of surface a depth camera's chain point stands for.

A chain point of a wall or a building's face (core/blobs.py, ``SurfacePoint``) is not the return
of one thing: it is wherever the frame's bins happened to put it, and stands for ``stretch_m`` of
surface around it (its neighbours are at most that far away). Its R carries that spread, so its
NIS against a landmark a few metres along the same wall is small: by the ordinary gates the point
is "ambiguous" against every landmark within about three spreads (12-16 m at a 4 m spacing), and
the map keeps one landmark per 12-16 m of wall, whose safety circles leave the surface between
them as close as 8 m (urban worlds: the vehicle passing a face 6-9 m away, abeam, after it left
the view).

The question for such a point is whether a landmark covers it: whether the point lies within half
a stretch of the landmark, up to the noise of where both are seen. The offset between them,
vehicle-relative (the pose's position cancels; the landmark's relative covariance holds what the
filter correlates), is shortened by half the stretch before it is scored against the point's own
R (the bin's, without the spread), the yaw's share at the point's range and the landmark's
relative covariance. A point no landmark covers is surface the map does not hold: a new landmark.
"""
from __future__ import annotations

import math

import numpy as np


def covering_nis(relative_ne_m: np.ndarray, relative_covs: np.ndarray, z: np.ndarray,
                 own_cov: np.ndarray, yaw_rad: float, yaw_var: float,
                 half_stretch_m: float) -> np.ndarray:
    """NIS (n,) of a surface point z = [range_m, bearing_rad] (R ``own_cov``, 2x2) against each
    landmark at ``relative_ne_m`` (n, 2) from the vehicle with covariance ``relative_covs``
    (n, 2, 2), the offset first shortened by ``half_stretch_m`` (zero inside it)."""
    direction = yaw_rad + float(z[1])
    c, s = math.cos(direction), math.sin(direction)
    r = float(z[0])
    point = np.array([r * c, r * s])
    jac = np.array([[c, -r * s], [s, r * c]])
    tangent = np.array([-s, c])
    point_cov = jac @ own_cov @ jac.T + r * r * yaw_var * np.outer(tangent, tangent)
    offset = point - np.asarray(relative_ne_m, dtype=float).reshape(-1, 2)
    length = np.hypot(offset[:, 0], offset[:, 1])
    scale = np.where(length > half_stretch_m, 1.0 - half_stretch_m / np.maximum(length, 1e-12), 0.0)
    offset = offset * scale[:, None]
    cov = np.asarray(relative_covs, dtype=float).reshape(-1, 2, 2) + point_cov
    a, b, d = cov[:, 0, 0], cov[:, 0, 1], cov[:, 1, 1]
    det = a * d - b * b
    x, y = offset[:, 0], offset[:, 1]
    return (d * x * x - 2.0 * b * x * y + a * y * y) / det
