"""The collision cone in three dimensions (Chakravarthy and Ghose's 3D cone; the paper's aiming
point with its Z component), and the capped cylinder of a post, wall or building grown by d.

Frame: north, east, up (metres; up so that heights above the ground read as they are). Pure maths.

Sphere (a point obstacle grown by d). The paper's formulas hold as written with 3-vectors: they
live in the plane spanned by X (vehicle to obstacle) and V (the vehicle's velocity relative to
it). With c = sqrt((|X|^2 - d^2) / (|X|^2 |V|^2 - (X.V)^2)),

    u1 = -((c X.V + d) / |X|^2) X + c V        u2 = ((c X.V - d) / |X|^2) X - c V
    p_i = X + d u_i      (the tangent points: |u_i| = 1, X.u_i = -d, so p_i is perpendicular to u_i)
    a = (X.V / (|X|^2 - d^2) + 1 / (c d)) / 2    b = (X.V / (|X|^2 - d^2) - 1 / (c d)) / 2

with a p1 + b p2 = V; V points into the cone iff a > 0 and b > 0, which is the sphere test:
the closest approach |X x V| / |V| < d while X.V > 0 (tests/core/test_cone3d.py checks both
identities and the test against sampling the ray).

Capped cylinder (a vertical extent [base, top] above the ground, grown by d: the axis's
horizontal circle of radius d between base - d and top + d; a flat cap, which contains the exact
grown segment, the capsule, so a velocity outside it keeps at least d in 3D). The ray p + V t
enters it iff the times it is horizontally within d of the axis, one interval from a quadratic,
meet the times it is between the grown base and top, another from a linear equation.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

EPS = 1e-12


@dataclass(frozen=True)
class SphereCone:
    """The paper's quantities for one sphere; ``inside``: |X| <= d (no cone: escape)."""
    inside: bool
    in_cone: bool
    a: float
    b: float
    aim_m: np.ndarray | None       # vehicle to the aiming tangent point (3,), None when inside
    tangents_m: tuple | None       # (p1, p2)


def sphere_cone(rel_m: np.ndarray, vel_mps: np.ndarray, d_m: float) -> SphereCone:
    """The 3D collision cone of a sphere of radius ``d_m`` at ``rel_m`` (vehicle to centre, (3,))
    for the relative velocity ``vel_mps`` (3,). V parallel to X: the tangent pair is any in the
    cone's circle; the one in the vertical plane through X, on the upper side, is chosen (a
    deterministic tie-break: over, for a point obstacle)."""
    x = np.asarray(rel_m, dtype=float)
    v = np.asarray(vel_mps, dtype=float)
    x2 = float(x @ x)
    xv = float(x @ v)
    v2 = float(v @ v)
    if x2 <= d_m * d_m:
        return SphereCone(True, xv > 0.0, math.nan, math.nan, None, None)
    if v2 <= EPS:
        return SphereCone(False, False, 0.0, 0.0, None, None)
    den = x2 * v2 - xv * xv
    if den <= EPS * x2 * v2:
        # along X: a velocity of the same speed tilted up in the plane of X and the vertical
        up = np.array([0.0, 0.0, 1.0])
        side = up - (up @ x) / x2 * x
        if float(side @ side) <= EPS:
            side = np.array([0.0, 1.0, 0.0]) - x[1] / x2 * x
        side /= math.sqrt(float(side @ side))
        v = v + 1e-6 * math.sqrt(v2) * side
        xv = float(x @ v)
        den = x2 * float(v @ v) - xv * xv
    c = math.sqrt((x2 - d_m * d_m) / den)
    u1 = -((c * xv + d_m) / x2) * x + c * v
    u2 = ((c * xv - d_m) / x2) * x - c * v
    p1, p2 = x + d_m * u1, x + d_m * u2
    a = 0.5 * (xv / (x2 - d_m * d_m) + 1.0 / (c * d_m))
    b = 0.5 * (xv / (x2 - d_m * d_m) - 1.0 / (c * d_m))
    in_cone = a > 0.0 and b > 0.0
    aim = p1 if 0.0 < b <= a else p2
    return SphereCone(False, in_cone, a, b, aim, (p1, p2))


def closest_approach_m(rel_m: np.ndarray, vel_mps: np.ndarray) -> float:
    """|X x V| / |V|: how near the straight line along V passes the point X (3D)."""
    x, v = np.asarray(rel_m, dtype=float), np.asarray(vel_mps, dtype=float)
    return float(np.linalg.norm(np.cross(x, v)) / max(np.linalg.norm(v), EPS))


def horizontal_interval_s(rel_ne_m: np.ndarray, vel_ne_mps: np.ndarray, radius_m: float
                          ) -> tuple[float, float] | None:
    """Times t (any sign) at which the vehicle at the origin moving at ``vel_ne_mps`` is within
    ``radius_m`` horizontally of the axis at ``rel_ne_m``: [t1, t2], or None if never. Standing
    still within the radius: (-inf, inf)."""
    x = np.asarray(rel_ne_m, dtype=float)
    v = np.asarray(vel_ne_mps, dtype=float)
    v2 = float(v @ v)
    gap2 = float(x @ x) - radius_m * radius_m
    if v2 <= EPS:
        return (-math.inf, math.inf) if gap2 <= 0.0 else None
    half_b = float(x @ v)                 # |x - v t|^2 - r^2 = v2 t^2 - 2 (x.v) t + gap2
    disc = half_b * half_b - v2 * gap2
    if disc < 0.0:
        return None
    root = math.sqrt(disc)
    return (half_b - root) / v2, (half_b + root) / v2


def vertical_interval_s(low_rel_m: float, high_rel_m: float, vel_up_mps: float
                        ) -> tuple[float, float] | None:
    """Times t at which the height vel_up_mps t (relative to the vehicle) is within
    [low_rel_m, high_rel_m]; None if never."""
    if abs(vel_up_mps) <= EPS:
        return (-math.inf, math.inf) if low_rel_m <= 0.0 <= high_rel_m else None
    t1, t2 = low_rel_m / vel_up_mps, high_rel_m / vel_up_mps
    return (min(t1, t2), max(t1, t2))


def cylinder_entry_s(rel_ne_m: np.ndarray, alt_m: float, vel_mps: np.ndarray, d_m: float,
                     base_m: float, top_m: float, horizon_s: float = math.inf) -> float | None:
    """When the straight flight at ``vel_mps`` (north, east, up) from altitude ``alt_m`` enters the
    capped cylinder of an axis at ``rel_ne_m`` (vehicle to axis) from ``base_m`` to ``top_m``
    above the ground, grown by ``d_m`` (top_m = inf: unbounded); None if it does not within
    [0, horizon_s]. 0.0: already inside."""
    v = np.asarray(vel_mps, dtype=float)
    horizontal = horizontal_interval_s(rel_ne_m, v[:2], d_m)
    if horizontal is None:
        return None
    vertical = vertical_interval_s(base_m - d_m - alt_m, top_m + d_m - alt_m, float(v[2]))
    if vertical is None:
        return None
    start = max(horizontal[0], vertical[0], 0.0)
    end = min(horizontal[1], vertical[1], horizon_s)
    return start if start <= end else None


def in_capped_cylinder(point_neu_m: np.ndarray, axis_ne_m: np.ndarray, d_m: float,
                       base_m: float, top_m: float) -> bool:
    """Whether a point (north, east, up) is inside the grown cylinder (for tests: sampling)."""
    p = np.asarray(point_neu_m, dtype=float)
    return bool(np.hypot(*(p[:2] - axis_ne_m)) <= d_m and base_m - d_m <= p[2] <= top_m + d_m)
