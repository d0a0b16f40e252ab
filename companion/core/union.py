"""Guidance outside the union of every relevant collision cone (dense obstacle fields).

The paper's law reacts to the single most urgent obstacle; where safety circles overlap, leaving
one cone can enter the next. Here every mapped obstacle (in view or not: that is what the map is
for) that could be reached within the look-ahead blocks a sector of headings, and the vehicle
picks a free heading:

- obstacle i at bearing theta_i and distance |X_i| blocks the headings within
  ``min(eta * asin(d_i / |X_i|), pi/2)`` of theta_i, when its safety circle is closer than
  ``speed * lookahead_s``. With one obstacle met head-on this is the paper's deflection exactly
  (eta times the angle to the tangent); d_i is the safety distance inflated by the relative
  position's uncertainty;
- inside a safety circle, every heading that closes on that obstacle is blocked;
- among free headings, the one minimising ``|h - goal heading| + hysteresis * |h - previous
  choice|``: nearest the goal, without chattering;
- once the goal heading is blocked, the vehicle commits to the side (left or right of the goal
  direction) it first chose and keeps it until the goal heading is free again, as a bug
  algorithm follows a wall: without it, a wall across the way makes the nearest free heading
  flip from one end of the wall to the other and the vehicle dithers in front of it;
- no free heading at the current speed: try half and a quarter of it (a slower vehicle needs to
  look less far ahead); none at all: hold (speed 0), the copter's last resort.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from companion.core.geometry import wrap_angles
from companion.core.guidance import (GuidanceCommand, GuidanceParams, approach_speed,
                                     inflated_radius, toward_goal)

CANDIDATES = 720                      # heading grid, 0.5 degree
SPEED_FRACTIONS = (1.0, 0.5, 0.25)


@dataclass(frozen=True)
class UnionParams:
    lookahead_s: float = 6.0          # how far ahead (in time at the commanded speed) cones count
    hysteresis: float = 0.5           # weight of |h - previous heading| against |h - goal heading|
    fov_rad: float = 0.5 * math.pi    # the camera's field of view: see turn_speed_factor


def turn_speed_factor(heading_rad: float, desired_rad: float, fov_rad: float) -> float:
    """Slow down for sharp turns: cos of the heading error; turn in place beyond the camera's view.

    A turn-rate-limited vehicle sweeps an arc of radius v / rate while it turns; at full speed
    that arc (about 10 m here) can cut through the very obstacles the new heading avoids, and a
    heading outside the field of view points into space the map has not seen yet. A copter can
    yaw on the spot: it does, and moves off once the camera looks where it will go.
    """
    error = abs(math.remainder(desired_rad - heading_rad, 2.0 * math.pi))
    if error > 0.5 * fov_rad:
        return 0.0
    return math.cos(error)


def blocking(candidates: np.ndarray, position: np.ndarray, obstacles: np.ndarray,
             radii: np.ndarray, eta: float, reach_m: float, speed_mps: float = 1.0,
             velocities: np.ndarray | None = None, lookahead_s: float = 0.0) -> np.ndarray:
    """(K, n) True where candidate heading k enters obstacle n's relevant (scaled) cone.

    Static obstacles count when their circle is nearer than ``reach_m``. With ``velocities``
    (n,2), the cone is tested on the velocity relative to each obstacle, speed * u_k - w_n, and a
    moving obstacle counts when its circle is nearer than (speed + |w|) * lookahead.
    """
    if len(obstacles) == 0:
        return np.zeros((len(candidates), 0), dtype=bool)
    rel = obstacles - position
    dist = np.hypot(rel[:, 0], rel[:, 1])
    inside = dist <= radii
    half = np.minimum(eta * np.arcsin(np.clip(radii / np.maximum(dist, 1e-9), 0.0, 1.0)),
                      0.5 * math.pi)
    bearing = np.arctan2(rel[:, 1], rel[:, 0])
    off = np.abs(wrap_angles(candidates[:, None] - bearing[None, :]))          # (K, n)
    relevant = (dist - radii) < reach_m
    if velocities is not None and np.any(velocities):
        moving = np.any(velocities != 0.0, axis=1)
        headings = np.stack([np.cos(candidates), np.sin(candidates)], axis=1)   # (K, 2)
        rel_vel = speed_mps * headings[:, None, :] - velocities[None, :, :]     # (K, n, 2)
        rel_off = np.abs(wrap_angles(np.arctan2(rel_vel[..., 1], rel_vel[..., 0])
                                     - bearing[None, :]))
        still = np.hypot(rel_vel[..., 0], rel_vel[..., 1]) < 1e-9
        off = np.where(moving[None, :], np.where(still, math.pi, rel_off), off)
        mover_reach = (speed_mps + np.hypot(velocities[:, 0], velocities[:, 1])) * lookahead_s
        relevant = np.where(moving, (dist - radii) < mover_reach, relevant)
    cone_hit = (off < half[None, :]) & (relevant & ~inside)[None, :]
    closing = (off < 0.5 * math.pi) & inside[None, :]
    return cone_hit | closing


def guide_union(pose: np.ndarray, goal: np.ndarray, obstacles: np.ndarray,
                rel_covs: np.ndarray | None, params: GuidanceParams, union: UnionParams,
                previous_heading_rad: float | None, side: int = 0,
                velocities: np.ndarray | None = None) -> GuidanceCommand:
    """Pick a speed and heading outside every relevant cone; see the module docstring."""
    position = pose[:2]
    goal_distance, goal_heading = toward_goal(pose, goal)
    if goal_distance <= params.goal_radius_m:
        return GuidanceCommand(0.0, pose[2], "arrived")
    radii = np.array([inflated_radius(params.safety_distance_m,
                                      None if rel_covs is None else rel_covs[i],
                                      params.inflation_sigmas) for i in range(len(obstacles))])
    grid = np.linspace(-math.pi, math.pi, CANDIDATES, endpoint=False)
    candidates = np.concatenate(([goal_heading], grid))       # index 0: the goal heading itself
    reference = pose[2] if previous_heading_rad is None else previous_heading_rad
    cost = (np.abs(wrap_angles(candidates - goal_heading))
            + union.hysteresis * np.abs(wrap_angles(candidates - reference)))
    cruise = approach_speed(params, goal_distance)
    dist = np.hypot(*(obstacles - position).T) - radii if len(obstacles) else np.empty(0)
    for fraction in SPEED_FRACTIONS:
        speed = cruise * fraction
        # obstacles beyond the goal do not matter: the vehicle stops before them
        blocks = blocking(candidates, position, obstacles, radii, params.eta,
                          min(speed * union.lookahead_s, goal_distance), speed, velocities,
                          union.lookahead_s)
        blocked = blocks.any(axis=1)
        if blocked.all():
            continue
        if not blocked[0]:
            return GuidanceCommand(speed * turn_speed_factor(pose[2], goal_heading, union.fov_rad), goal_heading,
                                   "goal")
        offset = wrap_angles(candidates - goal_heading)
        committed = cost + (np.pi * (np.sign(offset) == -side) if side else 0.0)
        best = int(np.argmin(np.where(blocked, np.inf, committed)))
        heading = float(candidates[best])
        new_side = int(np.sign(offset[best])) or 1
        in_way = np.flatnonzero(blocks[0])
        nearest = int(in_way[np.argmin(dist[in_way])])
        return GuidanceCommand(speed * turn_speed_factor(pose[2], heading, union.fov_rad), heading,
                               "avoid", nearest, max(float(dist[nearest]), 0.0) / max(speed, 1e-9),
                               side=new_side)
    return GuidanceCommand(0.0, pose[2], "hold")
