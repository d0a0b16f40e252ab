"""Plane geometry of the obstacle shapes: circles, walls and convex polygons (buildings).

A wall is a segment with a thickness: the rectangle whose centre line is the segment (its ends
square, not rounded), so walls and buildings are both convex polygons here. Polygons are
(m, 2) arrays of [north_m, east_m] corners, counter-clockwise in the (north, east) plane (positive
signed area with north as x and east as y; ``as_counter_clockwise`` orders them).

Pure functions of numpy arrays: no I/O, no clocks. ``companion simulate``'s truth uses them for
its depth camera (ray casting) and its collision check (distance to the surface); the scenario
loader uses ``convexity_problem`` and ``wall_corners`` to validate and build the shapes.
"""
from __future__ import annotations

import math

import numpy as np

# Below this a length or an area is zero (a wall 1e-9 m long, three corners on one line).
DEGENERATE_M = 1e-6


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """z of the cross product of (..., 2) vectors a x b (north as x, east as y)."""
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def signed_area_m2(corners: np.ndarray) -> float:
    """Shoelace area of a polygon (m, 2); > 0 when counter-clockwise (north x, east y)."""
    nxt = np.roll(corners, -1, axis=0)
    return 0.5 * float(np.sum(cross(corners, nxt)))


def as_counter_clockwise(corners: np.ndarray) -> np.ndarray:
    """The corners (m, 2) in counter-clockwise order (reversed if they were clockwise)."""
    corners = np.asarray(corners, dtype=float).reshape(-1, 2)
    return corners if signed_area_m2(corners) >= 0.0 else corners[::-1].copy()


def convexity_problem(corners: np.ndarray) -> str | None:
    """None if ``corners`` (m, 2), in either order, bound a convex polygon of non-zero area with
    no repeated corner; else what is wrong, naming the corner (0-based) where it shows."""
    corners = np.asarray(corners, dtype=float).reshape(-1, 2)
    m = len(corners)
    if m < 3:
        return f"a polygon needs at least 3 corners, got {m}"
    edges = np.roll(corners, -1, axis=0) - corners
    lengths = np.hypot(edges[:, 0], edges[:, 1])
    for i in np.flatnonzero(lengths <= DEGENERATE_M):
        return f"corners {i} and {(i + 1) % m} are the same point"
    if abs(signed_area_m2(corners)) <= DEGENERATE_M * max(1.0, float(lengths.max())):
        return "the corners lie on one line (zero area)"
    turns = cross(np.roll(edges, 1, axis=0), edges)        # the turn at each corner
    sign = 1.0 if signed_area_m2(corners) > 0.0 else -1.0
    for i in np.flatnonzero(sign * turns < -DEGENERATE_M * lengths * np.roll(lengths, 1)):
        return f"not convex: the outline turns the other way at corner {i}"
    # all turns one way can still wind twice round (a pentagram): the turning must total 2 pi
    angles = np.arctan2(turns, np.sum(np.roll(edges, 1, axis=0) * edges, axis=1))
    if abs(abs(float(angles.sum())) - 2.0 * math.pi) > 1e-6:
        return "not convex: the outline crosses itself"
    return None


def wall_corners(start_ne: np.ndarray, end_ne: np.ndarray, thickness_m: float) -> np.ndarray:
    """The rectangle (4, 2), counter-clockwise, of a wall from ``start_ne`` to ``end_ne`` (its
    centre line) ``thickness_m`` thick."""
    start_ne, end_ne = np.asarray(start_ne, dtype=float), np.asarray(end_ne, dtype=float)
    along = end_ne - start_ne
    length = float(np.hypot(*along))
    if length <= DEGENERATE_M:
        raise ValueError("a wall needs two different end points")
    normal = 0.5 * thickness_m * np.array([-along[1], along[0]]) / length
    return as_counter_clockwise(np.array([start_ne - normal, end_ne - normal,
                                          end_ne + normal, start_ne + normal]))


def ray_cast_circles(origin_ne: np.ndarray, directions: np.ndarray, centres_ne: np.ndarray,
                     radii_m: np.ndarray) -> np.ndarray:
    """Distance along each unit ray (n, 2) from ``origin_ne`` to the nearest circle surface in
    front of it (inf where none): (n,). Circles (k, 2) centres, (k,) radii. A ray starting
    inside a circle sees its far side."""
    out = np.full(len(directions), np.inf)
    for centre, radius in zip(np.asarray(centres_ne).reshape(-1, 2) - origin_ne,
                              np.asarray(radii_m).reshape(-1)):
        along = directions @ centre                                   # (n,)
        off_sq = float(centre @ centre) - along ** 2
        crosses = off_sq <= radius ** 2
        half_chord = np.sqrt(np.where(crosses, radius ** 2 - off_sq, 0.0))
        near = along - half_chord
        hit = np.where(near > 0.0, near, along + half_chord)
        out = np.where(crosses & (hit > 0.0), np.minimum(out, hit), out)
    return out


def ray_cast_polygon(origin_ne: np.ndarray, directions: np.ndarray,
                     corners: np.ndarray) -> np.ndarray:
    """Distance along each unit ray (n, 2) from ``origin_ne`` to the first edge of the polygon
    (m, 2) it meets in front of it (inf where none): (n,)."""
    a = np.asarray(corners, dtype=float) - origin_ne                   # (m, 2) edge starts
    edge = np.roll(a, -1, axis=0) - a                                  # (m, 2)
    denom = cross(directions[:, None, :], edge[None, :, :])            # (n, m)
    parallel = np.abs(denom) < 1e-12
    safe = np.where(parallel, 1.0, denom)
    t = cross(a[None, :, :], edge[None, :, :]) / safe                  # along the ray
    s = cross(a[None, :, :], directions[:, None, :]) / safe            # along the edge, [0, 1]
    hit = ~parallel & (t > 0.0) & (s >= 0.0) & (s <= 1.0)
    return np.where(hit, t, np.inf).min(axis=1) if len(a) else np.full(len(directions), np.inf)


def polygon_distance_m(points_ne: np.ndarray, corners: np.ndarray) -> np.ndarray:
    """Signed distance from each point (k, 2) to the surface of the convex polygon (m, 2)
    (counter-clockwise): > 0 outside, < 0 inside (minus the depth), (k,)."""
    points = np.asarray(points_ne, dtype=float).reshape(-1, 2)
    a = np.asarray(corners, dtype=float)
    edge = np.roll(a, -1, axis=0) - a                                  # (m, 2)
    rel = points[:, None, :] - a[None, :, :]                           # (k, m, 2)
    s = np.clip(np.sum(rel * edge, axis=2) / np.sum(edge * edge, axis=1), 0.0, 1.0)
    foot = a[None, :, :] + s[..., None] * edge[None, :, :]
    gap = np.hypot(*(points[:, None, :] - foot).transpose(2, 0, 1)).min(axis=1)
    inside = np.all(cross(edge[None, :, :], rel) >= 0.0, axis=1)       # left of every edge
    return np.where(inside, -gap, gap)


def circle_distance_m(points_ne: np.ndarray, centres_ne: np.ndarray,
                      radii_m: np.ndarray) -> np.ndarray:
    """Signed distance from each point (k, 2) to the surface of each circle: (k, c)."""
    points = np.asarray(points_ne, dtype=float).reshape(-1, 2)
    centres = np.asarray(centres_ne, dtype=float).reshape(-1, 2)
    return np.hypot(*(points[:, None, :] - centres[None, :, :]).transpose(2, 0, 1)) \
        - np.asarray(radii_m, dtype=float).reshape(1, -1)
