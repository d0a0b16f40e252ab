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
from typing import TYPE_CHECKING

import numpy as np

from companion.core.avoidance.guidance import (GuidanceCommand, GuidanceInputs, GuidanceParams,
                                               approach_speed, inflated_radius, toward_goal)
from companion.core.geometry import wrap_angles

if TYPE_CHECKING:
    from companion.core.avoidance.path_search import PathParams

CANDIDATES = 720                      # heading grid, 0.5 degree (with movers)
EDGE_MARGIN_RAD = math.radians(0.25)  # candidates sit this far outside a cone's edge
SPEED_FRACTIONS = (1.0, 0.5, 0.25)
MAX_SPREAD_M = 10.0                   # a coasting track's position sigma widens d by at most this


@dataclass(frozen=True)
class UnionParams:
    lookahead_s: float = 6.0          # how far ahead (in time at the commanded speed) cones count
    hysteresis: float = 0.5           # weight of |h - previous heading| against |h - goal heading|
    fov_rad: float = 0.5 * math.pi    # the camera's field of view: see turn_speed_factor
    mover_sigmas: float = 1.0         # a mover's radius grows by this many sigma of its velocity
    sensor_range_m: float | None = None   # velocity choice: never outrun the camera (None: off)
    perception_delay_s: float = 0.0       # ...counting the time a new obstacle stays tentative
    gap_margin_m: float | None = None  # velocity choice: fly through gaps whose safety circles
                                      # leave this much between them (None: never)
    flank_scan_rad: float | None = None   # velocity choice: look this far beyond the view's
    flank_scan_period_s: float = 4.0      # edges, each side within the period (flank_scan.py)
    headway_first: bool = False       # velocity choice: headway at a lower speed before a
                                      # faster heading away from the goal, static fields too
    path: "PathParams | None" = None  # velocity choice, static fields: fly the first leg of a
                                      # path searched over the map (path_follow.py; None: off)
    evade_movers: bool = False        # velocity choice (a multicopter's): side-step, back-off and
                                      # stop candidates with the nose held when a mover is near,
                                      # coasting tracks kept while unseeable near (evade.py)
    keep_near_tracks: bool = False    # a coasting mover track predicted near but out of view is
                                      # kept (movers.prune; with evade_movers always)
    keep_tracks_horizon_s: float | None = None  # ... and one whose closest approach comes
                                      # within d inside this (movers.approaching; None: off)
    mover_max_speed_mps: float | None = None    # velocity choice: cruise no faster than a mover
                                      # this fast met head-on at the range can be dodged
                                      # (blind_side.dodge_speed_cap_mps; None: off)
    view_yaws_rad: tuple[float, ...] = (0.0,)   # a rig of cameras of fov_rad each, by yaw on
                                      # the body: what the camera sees (seen space, the keep)
    seen_speed_limit: bool = False    # velocity choice and path follower: never faster than the
                                      # vehicle stops in the space seen free, the loop's latency
                                      # counted; the last resort brakes sideways too (speed_limit.py)
    control_period_s: float = 0.0     # ... the decision's period, part of that latency


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


@dataclass(frozen=True)
class Geometry:
    """What the cone tests need of each obstacle, computed once per decision. (n,) arrays."""
    bearing: np.ndarray
    dist: np.ndarray
    radii: np.ndarray
    half: np.ndarray          # eta-scaled half-angle, capped at 90 degrees
    inside: np.ndarray

    @classmethod
    def of(cls, position: np.ndarray, obstacles: np.ndarray, radii: np.ndarray,
           eta: float) -> "Geometry":
        rel = obstacles - position
        dist = np.hypot(rel[:, 0], rel[:, 1])
        # np.clip(x, 0, 1) written as the two ufuncs it is, at half its cost (x is never < 0)
        ratio = np.minimum(np.maximum(radii / np.maximum(dist, 1e-9), 0.0), 1.0)
        half = np.minimum(eta * np.arcsin(ratio), 0.5 * math.pi)
        return cls(np.arctan2(rel[:, 1], rel[:, 0]), dist, radii, half, dist <= radii)


def blocking(candidates: np.ndarray, position: np.ndarray, obstacles: np.ndarray,
             radii: np.ndarray, eta: float, reach_m: float, speed_mps: float = 1.0,
             velocities: np.ndarray | None = None, lookahead_s: float = 0.0,
             geometry: Geometry | None = None) -> np.ndarray:
    """(K, n) True where candidate heading k enters obstacle n's relevant (scaled) cone.

    Static obstacles count when their circle is nearer than ``reach_m``. With ``velocities``
    (n,2), the cone is tested on the velocity relative to each obstacle, speed * u_k - w_n, and a
    moving obstacle counts when its circle is nearer than (speed + |w|) * lookahead.
    """
    if len(obstacles) == 0:
        return np.zeros((len(candidates), 0), dtype=bool)
    g = geometry if geometry is not None else Geometry.of(position, obstacles, radii, eta)
    off = np.abs(wrap_angles(candidates[:, None] - g.bearing[None, :]))        # (K, n)
    relevant = (g.dist - g.radii) < reach_m
    if velocities is not None:
        moving = np.any(velocities != 0.0, axis=1)
        headings = np.stack([np.cos(candidates), np.sin(candidates)], axis=1)   # (K, 2)
        rel_vel = speed_mps * headings[:, None, :] - velocities[None, :, :]     # (K, n, 2)
        rel_off = np.abs(wrap_angles(np.arctan2(rel_vel[..., 1], rel_vel[..., 0])
                                     - g.bearing[None, :]))
        still = np.hypot(rel_vel[..., 0], rel_vel[..., 1]) < 1e-9
        off = np.where(moving[None, :], np.where(still, math.pi, rel_off), off)
        mover_reach = (speed_mps + np.hypot(velocities[:, 0], velocities[:, 1])) * lookahead_s
        relevant = np.where(moving, (g.dist - g.radii) < mover_reach, relevant)
    cone_hit = (off < g.half[None, :]) & (relevant & ~g.inside)[None, :]
    closing = (off < 0.5 * math.pi) & g.inside[None, :]
    return cone_hit | closing


def candidate_headings(goal_heading: float, reference: float, g: Geometry,
                       moving: bool) -> np.ndarray:
    """Headings worth scoring, index 0 the goal heading.

    The cost |h - goal| + w |h - reference| (+ a side penalty that jumps at the goal heading and
    its opposite) is piecewise linear in h, so over the free set its minimum lies at the goal or
    reference heading, at the goal's opposite, or at the edge of a blocked sector: just outside
    bearing +- half-angle of each static cone (+- 90 degrees for a circle the vehicle is inside).
    A mover's blocked set in heading space has no such closed form: with movers the 0.5 degree
    grid is scored as well.
    """
    half = np.where(g.inside, 0.5 * math.pi, g.half) + EDGE_MARGIN_RAD
    parts = [np.array([goal_heading, reference, goal_heading + math.pi]),
             g.bearing + half, g.bearing - half]
    if moving:
        parts.append(np.linspace(-math.pi, math.pi, CANDIDATES, endpoint=False))
    return wrap_angles(np.concatenate(parts))


def guide_union(inputs: GuidanceInputs, params: GuidanceParams,
                union: UnionParams) -> GuidanceCommand:
    """Pick a speed and heading outside every relevant cone, seen from where the vehicle is; see
    the module docstring. Headings only: with ``inputs.motion`` (the vehicle's limits) the choice
    is velocity_choice.guide_flyable's, on paths the vehicle can fly."""
    if inputs.motion is not None:
        raise ValueError("guide_union decides headings only: with a motion, "
                         "velocity_choice.guide_flyable decides")
    pose, goal, obstacles = inputs.pose, inputs.goal, inputs.obstacles
    rel_covs, velocities, side = inputs.rel_covs, inputs.velocities, inputs.side
    previous_heading_rad = inputs.previous_heading_rad
    position = pose[:2]
    goal_distance, goal_heading = toward_goal(pose, goal)
    if goal_distance <= params.goal_radius_m:
        return GuidanceCommand(0.0, pose[2], "arrived")
    cruise = approach_speed(params, goal_distance)
    reference = pose[2] if previous_heading_rad is None else previous_heading_rad
    if velocities is None and (rel_covs is None or params.inflation_sigmas <= 0.0):
        # The common case, in plain Python (a handful of obstacles: numpy's call costs dominate).
        px, py, d = float(pose[0]), float(pose[1]), params.safety_distance_m
        reach = cruise * union.lookahead_s
        near = [i for i, (north, east) in enumerate(obstacles.tolist())
                if math.hypot(north - px, east - py) - d < reach]
        if not near:
            return GuidanceCommand(cruise * turn_speed_factor(pose[2], goal_heading, union.fov_rad),
                                   goal_heading, "goal")
        return _choose_static(pose, goal_heading, goal_distance, cruise, reference, side,
                              obstacles[near], np.full(len(near), d), np.array(near), params,
                              union)
    if rel_covs is None or params.inflation_sigmas <= 0.0:
        radii = np.full(len(obstacles), params.safety_distance_m)
    else:
        radii = np.array([inflated_radius(params.safety_distance_m, cov, params.inflation_sigmas)
                          for cov in rel_covs])
    gaps = np.hypot(*(obstacles - position).T) - radii if len(obstacles) else np.empty(0)
    # Only obstacles some speed could reach within the look-ahead can block anything.
    speeds = np.zeros(len(obstacles)) if velocities is None else np.hypot(*velocities.T)
    near = np.flatnonzero(gaps < (cruise + speeds) * union.lookahead_s)
    if near.size == 0:
        return GuidanceCommand(cruise * turn_speed_factor(pose[2], goal_heading, union.fov_rad),
                               goal_heading, "goal")
    obstacles, radii = obstacles[near], radii[near]
    velocities = None if velocities is None or not np.any(velocities[near]) else velocities[near]
    choose = _choose_static if velocities is None else _choose_general
    return choose(pose, goal_heading, goal_distance, cruise, reference, side, obstacles, radii,
                  near, params, union, velocities)


def _choose_general(pose: np.ndarray, goal_heading: float, goal_distance: float, cruise: float,
                    reference: float, side: int, obstacles: np.ndarray, radii: np.ndarray,
                    near: np.ndarray, params: GuidanceParams, union: UnionParams,
                    velocities: np.ndarray | None) -> GuidanceCommand:
    """Score the candidates with numpy: any obstacles, moving ones included."""
    position = pose[:2]
    gaps = np.hypot(*(obstacles - position).T) - radii
    geometry = Geometry.of(position, obstacles, radii, params.eta)
    candidates = candidate_headings(goal_heading, reference, geometry, velocities is not None)
    offset = wrap_angles(candidates - goal_heading)
    cost = np.abs(offset) + union.hysteresis * np.abs(wrap_angles(candidates - reference))
    if side:
        cost = cost + np.pi * (np.sign(offset) == -side)
    for fraction in SPEED_FRACTIONS:
        speed = cruise * fraction
        # obstacles beyond the goal do not matter: the vehicle stops before them
        blocks = blocking(candidates, position, obstacles, radii, params.eta,
                          min(speed * union.lookahead_s, goal_distance), speed, velocities,
                          union.lookahead_s, geometry)
        blocked = blocks.any(axis=1)
        if blocked.all():
            continue
        if not blocked[0]:
            return GuidanceCommand(speed * turn_speed_factor(pose[2], goal_heading, union.fov_rad),
                                   goal_heading, "goal")
        best = int(np.argmin(np.where(blocked, np.inf, cost)))
        heading = float(candidates[best])
        in_way = np.flatnonzero(blocks[0])
        nearest = int(in_way[np.argmin(gaps[in_way])])
        return GuidanceCommand(speed * turn_speed_factor(pose[2], heading, union.fov_rad), heading,
                               "avoid", int(near[nearest]),
                               max(float(gaps[nearest]), 0.0) / max(speed, 1e-9),
                               side=int(np.sign(offset[best])) or 1)
    return GuidanceCommand(0.0, pose[2], "hold")


def _choose_static(pose: np.ndarray, goal_heading: float, goal_distance: float, cruise: float,
                   reference: float, side: int, obstacles: np.ndarray, radii: np.ndarray,
                   near: np.ndarray, params: GuidanceParams, union: UnionParams,
                   velocities: None = None) -> GuidanceCommand:
    """The same choice as the general path, for static obstacles only, in plain Python.

    A decision sees a handful of near obstacles and a dozen candidates: numpy's per-call cost
    dominated there (44 us a decision, a quarter of a replay). Same rules, same candidates;
    tests/core/test_union.py checks both paths agree.
    """
    px, py, yaw = float(pose[0]), float(pose[1]), float(pose[2])
    reference = float(reference)             # numpy scalars would make every step below slow
    cones = []                                   # (bearing, half, inside, gap, index)
    for (north, east), radius, index in zip(obstacles.tolist(), radii.tolist(), near.tolist()):
        dist = math.hypot(north - px, east - py)
        inside = dist <= radius
        half = 0.5 * math.pi if inside else \
            min(params.eta * math.asin(min(radius / max(dist, 1e-9), 1.0)), 0.5 * math.pi)
        cones.append((math.atan2(east - py, north - px), half, inside, dist - radius, index))
    two_pi = 2.0 * math.pi
    candidates = [goal_heading, reference, goal_heading + math.pi]
    for bearing, half, _, _, _ in cones:
        candidates += [bearing + half + EDGE_MARGIN_RAD, bearing - half - EDGE_MARGIN_RAD]
    candidates = [(c + math.pi) % two_pi - math.pi for c in candidates]
    offsets = [(c - goal_heading + math.pi) % two_pi - math.pi for c in candidates]
    costs = []
    for c, o in zip(candidates, offsets):
        cost = abs(o) + union.hysteresis * abs((c - reference + math.pi) % two_pi - math.pi)
        if side and (o > 0) - (o < 0) == -side:
            cost += math.pi
        costs.append(cost)
    for fraction in SPEED_FRACTIONS:
        speed = cruise * fraction
        reach = min(speed * union.lookahead_s, goal_distance)
        # (bearing, half-width, cone) of every sector that blocks at this speed
        sectors = [(b, h, cone) for cone in cones for b, h, inside, gap, _ in (cone,)
                   if inside or gap < reach]

        def blocked(heading: float) -> bool:
            for bearing, half, _ in sectors:
                if abs((heading - bearing + math.pi) % two_pi - math.pi) < half:
                    return True
            return False
        free = [not blocked(c) for c in candidates]
        if not any(free):
            continue
        if free[0]:
            return GuidanceCommand(speed * turn_speed_factor(yaw, goal_heading, union.fov_rad),
                                   goal_heading, "goal")
        best = min((k for k in range(len(candidates)) if free[k]), key=lambda k: (costs[k], k))
        heading = candidates[best]
        in_way = [cone for bearing, half, cone in sectors
                  if abs((goal_heading - bearing + math.pi) % two_pi - math.pi) < half]
        nearest = min(in_way, key=lambda cone: cone[3])
        return GuidanceCommand(speed * turn_speed_factor(yaw, heading, union.fov_rad), heading,
                               "avoid", nearest[4], max(nearest[3], 0.0) / max(speed, 1e-9),
                               side=((offsets[best] > 0) - (offsets[best] < 0)) or 1)
    return GuidanceCommand(0.0, yaw, "hold")


def sensed_speed_limit(sensor_range_m: float, safety_distance_m: float,
                       max_accel_mps2: float, perception_delay_s: float = 0.0) -> float:
    """The fastest speed v from which the vehicle stops d short of the camera's range: an
    obstacle that first shows up at the edge of the range is then never closer than d when
    stopped. ``perception_delay_s``: how long a new obstacle may stay out of the decision (a
    tentative landmark until confirmed), flown at v before braking starts:
    v t + v^2 / (2 a) = range - d."""
    a, t = max_accel_mps2, perception_delay_s
    margin_m = max(sensor_range_m - safety_distance_m, 0.0)
    return -a * t + math.sqrt((a * t) ** 2 + 2.0 * a * margin_m)
