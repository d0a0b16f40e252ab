"""Which landmarks already hold the stretch of surface a depth camera's chain point stands for.

A chain point of a wall or a building's face (core/perception/blobs.py, ``SurfacePoint``) is not the return
of one thing: it is wherever the frame's bins happened to put it, and stands for ``stretch_m`` of
surface around it (its neighbours are at most that far away). Its R carries that spread, so its
NIS against a landmark a few metres along the same wall is small: by the ordinary gates the point
is "ambiguous" against every landmark within about three spreads (12-16 m at a 4 m spacing), and
the map keeps one landmark per 12-16 m of wall, whose safety circles leave the surface between
them as close as 8 m (urban worlds: the vehicle passing a face 6-9 m away, abeam, after it left
the view).

The question for such a point is whether a landmark covers it: whether it lies within half a
stretch of a landmark's mean (where guidance puts the landmark's safety circle), up to the noise
of where the point itself is seen: the offset, vehicle-relative, shortened by half the stretch,
scored against the point's own R (its bin's, without the spread) and the yaw's share at its
range. The landmark's own covariance is left out: a landmark made of chain points is uncertain
along the wall by the stretch itself, and counting that again would let one landmark cover twice
its stretch. A point no landmark covers is surface the map does not hold: a new landmark. A
point the frame's association paired with a landmark that does not cover it is new surface too,
not a reason to drag that landmark metres along the wall. An end or a corner (stretch 0) is
covered only by a landmark where it is.
"""
from __future__ import annotations

import math

import numpy as np


def covering_nis(relative_ne_m: np.ndarray, z: np.ndarray, own_cov: np.ndarray, yaw_rad: float,
                 yaw_var: float, half_stretch_m: float) -> np.ndarray:
    """NIS (n,) of a surface point z = [range_m, bearing_rad] (R ``own_cov``, 2x2; the vehicle's
    yaw ``yaw_rad`` with variance ``yaw_var``) against each landmark mean at ``relative_ne_m``
    (n, 2) from the vehicle, the offset first shortened by ``half_stretch_m`` (zero inside it)."""
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
    (a, b), (_, d) = point_cov
    x, y = offset[:, 0], offset[:, 1]
    return (d * x * x - 2.0 * b * x * y + a * y * y) / (a * d - b * b)
