"""The collision cone of Chakravarthy and Ghose, as the paper uses it, with its degenerate cases.

Vectors are 2D in LOCAL_NED (north, east). ``rel_pos`` X is vehicle-to-obstacle, ``rel_vel`` V is
the vehicle's velocity relative to the obstacle, ``d`` the safety radius around the obstacle centre.
With the paper's missing parentheses restored (see ALGORITHM-NOTES.md):

    c  = sqrt((|X|^2 - d^2) / (|X|^2 |V|^2 - (X.V)^2))
    u1 = -((c (X.V) + d) / |X|^2) X + c V,      u2 = ((c (X.V) - d) / |X|^2) X - c V
    p_i = X + d u_i                             (vehicle to tangent point i)
    a  = (X.V / (|X|^2 - d^2) + 1 / (c d)) / 2, b = (X.V / (|X|^2 - d^2) - 1 / (c d)) / 2

so that V = a p1 + b p2, and V points into the cone iff a > 0 and b > 0. Since c > 0, a > b
always: p1 is the tangent on V's side, the nearer one, and the paper's aiming rule picks it.

Degenerate cases (not in the paper), each with an explicit rule:
- ``|V| ~ 0`` (hovering): no cone, nothing is urgent from motion (kind 'stationary').
- ``|X| <= d`` (inside the safety circle): c is imaginary. Urgent now, time to go 0 (kind
  'inside'); the guidance escapes outward rather than aiming at a tangent.
- V parallel to X: the denominator of c is zero. Receding (X.V <= 0): no threat. Closing: inside
  the cone with symmetric tangents; the tie is broken to the RIGHT of V, as two aircraft meeting
  head-on both turn right (kind 'head_on').
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

# |X x V| below this fraction of |X||V| counts as parallel: sin(angle) < 1e-9.
PARALLEL_TOLERANCE = 1e-9
MIN_SPEED_MPS = 1e-6


@dataclass(frozen=True)
class ConeVerdict:
    """Outcome of :func:`check_cone`.

    kind: 'clear' (V outside the cone), 'in_cone', 'head_on' (V along X, closing), 'receding'
    (V along X, opening), 'inside' (|X| <= d), 'stationary' (|V| ~ 0).
    tangent_1, tangent_2: vehicle-to-tangent-point vectors p1, p2 (None when undefined).
    aim: the chosen aiming vector X_ap (None unless in the cone).
    time_to_go_s: time along V to reach the aim point's abeam, (aim . V) / |V|^2.
    """
    kind: str
    in_cone: bool
    a: float
    b: float
    c: float
    tangent_1: tuple[float, float] | None
    tangent_2: tuple[float, float] | None
    aim: tuple[float, float] | None
    time_to_go_s: float


def _tangents_symmetric(rel_pos: np.ndarray, d: float) -> tuple[np.ndarray, np.ndarray]:
    """Vehicle-to-tangent vectors by plain geometry: (right of X, left of X) in NED."""
    dist = math.hypot(rel_pos[0], rel_pos[1])
    half_angle = math.asin(d / dist)
    length = math.sqrt(dist * dist - d * d)
    bearing = math.atan2(rel_pos[1], rel_pos[0])
    right = length * np.array([math.cos(bearing + half_angle), math.sin(bearing + half_angle)])
    left = length * np.array([math.cos(bearing - half_angle), math.sin(bearing - half_angle)])
    return right, left


def check_cone(rel_pos: np.ndarray, rel_vel: np.ndarray, d: float) -> ConeVerdict:
    """Is ``rel_vel`` inside the collision cone of a circle of radius ``d`` at ``rel_pos``?"""
    x = np.asarray(rel_pos, dtype=float)
    v = np.asarray(rel_vel, dtype=float)
    x_sq = float(x @ x)
    v_sq = float(v @ v)
    xv = float(x @ v)
    nan = float("nan")
    if v_sq < MIN_SPEED_MPS ** 2:
        return ConeVerdict("stationary", False, nan, nan, nan, None, None, None, math.inf)
    if x_sq <= d * d:
        return ConeVerdict("inside", True, nan, nan, nan, None, None, None, 0.0)
    cross = float(x[0] * v[1] - x[1] * v[0])
    if abs(cross) <= PARALLEL_TOLERANCE * math.sqrt(x_sq * v_sq):
        if xv <= 0.0:
            return ConeVerdict("receding", False, nan, nan, nan, None, None, None, math.inf)
        right, left = _tangents_symmetric(x, d)
        time_to_go = float(right @ v) / v_sq
        return ConeVerdict("head_on", True, math.inf, math.inf, math.inf, tuple(right),
                           tuple(left), tuple(right), time_to_go)
    c = math.sqrt((x_sq - d * d) / (cross * cross))   # |X|^2|V|^2 - (X.V)^2 == (X x V)^2
    u1 = -((c * xv + d) / x_sq) * x + c * v
    u2 = ((c * xv - d) / x_sq) * x - c * v
    p1 = x + d * u1
    p2 = x + d * u2
    first = xv / (x_sq - d * d)
    a = 0.5 * (first + 1.0 / (c * d))
    b = 0.5 * (first - 1.0 / (c * d))
    in_cone = a > 0.0 and b > 0.0
    if not in_cone:
        return ConeVerdict("clear", False, a, b, c, tuple(p1), tuple(p2), None, math.inf)
    aim = p1 if 0.0 < b <= a else p2
    return ConeVerdict("in_cone", True, a, b, c, tuple(p1), tuple(p2), tuple(aim),
                       float(aim @ v) / v_sq)


def in_cone_by_angle(rel_pos: np.ndarray, rel_vel: np.ndarray, d: float) -> bool:
    """The plain geometric test: angle(V, X) < asin(d / |X|) and X.V > 0 (|X| > d assumed)."""
    x = np.asarray(rel_pos, dtype=float)
    v = np.asarray(rel_vel, dtype=float)
    dist = math.hypot(x[0], x[1])
    angle = math.atan2(abs(x[0] * v[1] - x[1] * v[0]), float(x @ v))
    return float(x @ v) > 0.0 and angle < math.asin(d / dist)


def signed_angle(from_vec: np.ndarray, to_vec: np.ndarray) -> float:
    """Angle from one 2D NED vector to another, positive clockwise (to the right), in [-pi, pi]."""
    return math.atan2(from_vec[0] * to_vec[1] - from_vec[1] * to_vec[0],
                      from_vec[0] * to_vec[0] + from_vec[1] * to_vec[1])
