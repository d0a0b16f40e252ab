"""Fly the first leg of a path through the mapped obstacles (path_search.py), forests' guidance.

``guide_along_path`` replaces the velocity choice (velocity_choice.guide_flyable) where
``union.path`` is set and nothing mapped moves:

1. a path is searched from the vehicle to the goal around every mapped obstacle's safety circle
   (path_search.plan_path); its first leg gives the heading to fly;
2. along that heading (then a few degrees either side, nearest first), speeds from cruise down to
   a quarter of it, fastest first: the first command whose roll-out (arc.py: turn and speed limits,
   then a stop) keeps every safety distance, and d from space never seen where the stopping
   distance exceeds d, as the velocity choice checks its own (``_unseen_margin``), keeping of
   the hold from that space no more than the vehicle has where it is (``_unseen_room``);
   then (``crawl_mps``, path_steady) a crawl along the leg keeping d + ``squeeze_m``;
   then, at a quarter of cruise, headings up to 90 degrees either side of the leg;
3. none: a stop turning toward the leg, if stopping keeps d and the leg is beyond the view or
   the vehicle still moves (it brakes before anything else decides);
4. none, or no path at all: the velocity choice decides, with the leg's direction as its goal
   (the goal kept at its distance, so arrival and the approach speed are unchanged), no committed
   side and no commitment reach: the path search has chosen the side.

Movers (and the landmarks on probation that the navigator flies round as movers: in a static
forest there is about one at any time, two sightings of neighbouring trees read as one moving
trunk) are searched around where they are now and rolled out against where they will be, their
radius growing as the velocity choice grows it.
"""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from companion.core.avoidance.arc import clearance, fly_out
from companion.core.avoidance.guidance import (GuidanceCommand, GuidanceInputs, GuidanceParams,
                                               approach_speed, toward_goal)
from companion.core.avoidance.path_search import PlannedPath, plan_path
from companion.core.avoidance.seen_space import SeenSpace
from companion.core.avoidance import speed_limit
from companion.core.avoidance.union import UnionParams, turn_speed_factor
from companion.core.avoidance.velocity_choice import _unseen_margin, guide_flyable, safety_radii

SPEED_FRACTIONS = (1.0, 0.75, 0.5, 0.25)
BRAKE_ABOVE_MPS = 0.5     # no way on along the leg: faster than this, brake first (the velocity
                          # choice's own fallbacks keep d, not the follower's d + hold_m)
OFFSETS_RAD = tuple(math.radians(a) for a in (0.0, 5.0, -5.0, 10.0, -10.0))
# at the slowest speed, then wider: a way on that the grid's resolution missed
WIDE_OFFSETS_RAD = tuple(math.radians(a) for a in (20.0, -20.0, 30.0, -30.0, 45.0, -45.0,
                                                   60.0, -60.0, 90.0, -90.0))


def guide_along_path(inputs: GuidanceInputs, params: GuidanceParams,
                     union: UnionParams) -> GuidanceCommand:
    """The command along the first leg of a path to the goal; see the module docstring."""
    command, _ = guide_with_plan(inputs, params, union)
    return command


def guide_with_plan(inputs: GuidanceInputs, params: GuidanceParams,
                    union: UnionParams) -> tuple[GuidanceCommand, PlannedPath | None]:
    """guide_along_path's command and the path it followed (None: not searched)."""
    pose, goal, obstacles, motion = inputs.pose, inputs.goal, inputs.obstacles, inputs.motion
    goal_distance, _ = toward_goal(pose, goal)
    if union.path is None or motion is None or len(obstacles) == 0 \
            or goal_distance <= params.goal_radius_m:
        return guide_flyable(inputs, params, union), None
    radii = safety_radii(inputs, params)
    plan = plan_path(pose[:2], goal, obstacles, radii, union.path, inputs.previous_heading_rad,
                     inputs.kept_path_ne_m)
    if not plan.found:
        return guide_flyable(replace(inputs, side=0, clear_reach_m=None), params, union), plan
    cruise = approach_speed(params, goal_distance)
    if union.sensor_range_m is not None:
        cruise = min(cruise, speed_limit.cruise_cap(union, params.safety_distance_m, motion))
    chosen = _along(pose, plan.heading_rad, cruise, obstacles, radii, params, union, inputs,
                    min(union.path.hold_m, plan.margin_m))
    if chosen is not None:
        return chosen, plan
    leg = np.array([math.cos(plan.heading_rad), math.sin(plan.heading_rad)])
    toward = replace(inputs, goal=pose[:2] + goal_distance * leg, side=0, clear_reach_m=None)
    return guide_flyable(toward, params, union), plan


def _along(pose: np.ndarray, heading_rad: float, cruise: float, obstacles: np.ndarray,
           radii: np.ndarray, params: GuidanceParams, union: UnionParams,
           inputs: GuidanceInputs, hold_m: float) -> GuidanceCommand | None:
    """The fastest command near the leg's heading whose roll-out keeps every margin (d +
    ``hold_m``: hold_m, or less if the path was searched with less; the leg's heading first at
    each speed), else a turn in place toward it if stopping keeps d, else None."""
    motion, seen = inputs.motion, inputs.seen
    velocities, growth = inputs.velocities, inputs.growth_mps
    if velocities is not None and not np.any(velocities != 0.0):
        velocities = growth = None
    position, yaw = pose[:2], float(pose[2])
    # inside the margin already (a trunk seen late): the path out need not gain it at once
    # (clearance() counts a circle it is inside by what the path loses beyond that)
    now = float(np.min(np.hypot(*(obstacles - position).T) - radii))
    need = min(hold_m, max(now, 0.0))
    headings = np.array([heading_rad + o for o in OFFSETS_RAD])
    headings = np.arctan2(np.sin(headings), np.cos(headings))
    wide = np.array([heading_rad + o for o in WIDE_OFFSETS_RAD])
    wide = np.arctan2(np.sin(wide), np.cos(wide))
    previous = inputs.previous_heading_rad
    if union.seen_speed_limit and previous is not None:
        # the wide way last chosen first (a turn in place toward it goes on): a way on each side
        # that passes or fails as the nose turns had the nose swing between them, never there
        # (forest seeds 4 at 7 m/s and 49 at 10 m/s: 60 s in place, +90 and -60 degrees apart)
        wide = wide[np.argsort(np.abs(np.remainder(wide - previous + math.pi, 2.0 * math.pi)
                                      - math.pi), kind="stable")]
    tries = [(cruise * f, headings, need) for f in SPEED_FRACTIONS]
    crawl, squeeze = union.path.crawl_mps, union.path.squeeze_m
    if crawl is not None and crawl < cruise * SPEED_FRACTIONS[-1]:
        # a quarter of cruise rolls out past a short first leg, and a gap the search's cell
        # slack found may keep less than the search's need: at a crawl, d + squeeze_m will do
        tries.append((crawl, headings, need if squeeze is None else min(need, squeeze)))
    room = _unseen_room(seen, position, union, params.safety_distance_m)
    for speed, headings, keep in tries + [(cruise * SPEED_FRACTIONS[-1], wide, need)]:
        rolled = fly_out(position, motion, headings, np.full(len(headings), speed),
                         union.path.follow_s, union.fov_rad)
        ok = clearance(rolled, obstacles, radii, velocities, growth, position) >= keep
        unseen = _unseen_margin(seen, position, motion, headings, speed, union,
                                params.safety_distance_m)
        if unseen is not None:
            ok &= unseen >= min(keep, room)
        passing = np.flatnonzero(ok)
        if passing.size:
            heading = float(headings[passing[0]])
            return GuidanceCommand(speed * turn_speed_factor(yaw, heading, union.fov_rad),
                                   heading, "path")
    if abs(math.remainder(heading_rad - yaw, 2.0 * math.pi)) <= 0.5 * union.fov_rad \
            and motion.speed_mps < BRAKE_ABOVE_MPS:
        return None               # facing the leg, nearly still, no way on: the velocity choice
    rolled = fly_out(position, motion, np.array([heading_rad]), np.zeros(1), union.path.follow_s,
                     union.fov_rad)
    if clearance(rolled, obstacles, radii, velocities, growth, position)[0] >= 0.0:
        return GuidanceCommand(0.0, float(heading_rad), "stop")
    return None


def _unseen_room(seen: SeenSpace | None, position: np.ndarray, union: UnionParams,
                 d: float) -> float:
    """How far beyond its need from space not seen the vehicle is here, the worst over the seen
    grid's views (speed_limit.unseen_margins; 0 if short of it, inf without a seen space). A
    way on keeps no more than that of the hold: every roll-out begins in the vehicle's own
    cell, so none gains on it, and a vehicle started at rest at its first view's apex (1.83 m
    from unseen space behind, d 1.8 m) found no way on and swung its nose in place for 120 s
    (forest-near at rest, seeds 8, 10, 13, 19): the obstacles' own rule."""
    if seen is None:
        return math.inf
    need = speed_limit.seen_need_m(union, d, seen.cell_m)
    here = min(float(grid.margin(position[None, :])[0]) for _, grid in seen.views())
    return max(here - need, 0.0)
