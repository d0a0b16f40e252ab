"""The cost of flying round a barrier as far as it is mapped (issue 46, "climbing needs time").

vertical.detour_m counts the obstacles within reach, so a 160 m wall first seen through a camera
40 m deep looks 30 m wide and cheaper to fly round than to climb. Here the obstacles a plan flies
round are joined into barriers: two whose centres are less than 2 d apart leave no way between
them at d. A barrier blocks if one of its obstacles is within d of the straight way to the goal,
ahead of the vehicle. Flying round it on one side passes every one of its obstacles on that side,
at least d off: the way is at least the longest of the ways through each obstacle's point d
beyond it on that side, over the obstacles ahead that the straight way passes on the other side
or nearer than d (a lower bound on the way round the barrier's grown hull, exact for a straight
wall across the way). The side is the one the heading given takes (the decider gives the
vehicle's course: the side it is flying toward, whichever plan's command is scored); a heading
still along the way to the goal (within ``ALONG_RAD``) takes the shorter side.

What is not mapped is not counted: the barrier's ends are where the map's end (the cost grows as
the camera sees more of it).
"""
from __future__ import annotations

import math

import numpy as np
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import connected_components

ALONG_RAD = math.radians(5.0)


def barriers(points_ne_m: np.ndarray, gap_m: float) -> list[np.ndarray]:
    """Indices of the points in each group joined by links shorter than ``gap_m`` (single
    linkage: the connected components of the links, scipy.sparse.csgraph), each sorted, the
    groups in the order of their first point."""
    if len(points_ne_m) == 0:
        return []
    diff = points_ne_m[:, None, :] - points_ne_m[None, :, :]
    linked = np.einsum("ijk,ijk->ij", diff, diff) < gap_m * gap_m
    count, labels = connected_components(csr_matrix(linked), directed=False)
    return [np.flatnonzero(labels == k) for k in range(count)]


def blocking_rows(position_ne_m: np.ndarray, obstacles_ne_m: np.ndarray, ahead_ne: np.ndarray,
                  d_m: float) -> frozenset:
    """The rows of every barrier (obstacles joined less than 2 d apart) one of whose obstacles is
    ahead along the unit vector ``ahead_ne`` and within d of that way: what stands in it."""
    pts = np.asarray(obstacles_ne_m, dtype=float).reshape(-1, 2)
    rel = pts - np.asarray(position_ne_m, dtype=float)
    along = rel @ ahead_ne
    lateral = rel @ np.array([-ahead_ne[1], ahead_ne[0]])
    out: set = set()
    for group in barriers(pts, 2.0 * d_m):
        if np.any((along[group] > 0.0) & (np.abs(lateral[group]) < d_m)):
            out.update(int(i) for i in group)
    return frozenset(out)


def barrier_detour_m(position_ne_m: np.ndarray, goal_ne_m: np.ndarray, heading_rad: float,
                     obstacles_ne_m: np.ndarray, rows: list[int], d_m: float) -> float:
    """The extra way, over the straight line to the goal, of flying round every blocking barrier
    of the obstacles ``rows`` (see the module's docstring); 0.0 if none blocks."""
    if not rows:
        return 0.0
    pos = np.asarray(position_ne_m, dtype=float)
    goal = np.asarray(goal_ne_m, dtype=float)
    to_goal = goal - pos
    length = float(np.hypot(*to_goal))
    if length <= 1e-9:
        return 0.0
    u = to_goal / length
    n = np.array([-u[1], u[0]])                       # to the right of the way (north, east)
    pts = np.asarray(obstacles_ne_m, dtype=float)[rows]
    rel = pts - pos
    along, lateral = rel @ u, rel @ n
    heading = np.array([math.cos(heading_rad), math.sin(heading_rad)])
    turn = math.atan2(float(heading @ n), float(heading @ u))
    sides = (1.0, -1.0) if abs(turn) <= ALONG_RAD else (math.copysign(1.0, turn),)
    extra = 0.0
    for group in barriers(pts, 2.0 * d_m):
        ahead = (along[group] > 0.0) & (along[group] < length)
        if not np.any(ahead & (np.abs(lateral[group]) < d_m)):
            continue
        best = math.inf
        for side in sides:
            # the obstacles ahead the straight way passes on the wrong side or within d
            bind = group[(along[group] > 0.0) & (side * lateral[group] + d_m > 0.0)]
            if not len(bind):
                best = length
                break
            via = pts[bind] + side * d_m * n
            way = np.hypot(*(via - pos).T) + np.hypot(*(goal - via).T)
            best = min(best, float(way.max()))
        extra = max(extra, best - length)
    return extra
