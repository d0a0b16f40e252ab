"""Choose a velocity, not only a heading: the union law on paths the vehicle can fly.

The union law (union.py) blocks every heading inside a relevant cone, seen from where the vehicle
is. At speed that is not enough: the vehicle reaches a free heading along an arc of radius
v / turn rate (29 m at 15 m/s and 30 deg/s), and the arc can cross a neighbour's circle. Here a
command (speed, heading) is taken only if it is free of every cone *and* its rolled-out path
(arc.py: turn and speed limits, then a stop) keeps every safety distance, movers at their
predicted positions with a radius that grows with their velocity's uncertainty:

1. speeds from cruise down to a quarter of it, fastest first; at each, the free headings scored
   as the union law scores them (goal, hysteresis, committed side); the best reachable one wins;
2. none: the cones are dropped, the roll-out alone decides (a quarter speed, then a stop while
   turning): the path that keeps d, nearest the goal;
3. none at all: brake, turning toward the heading whose path keeps the most clearance.

The obstacle reported as urgent is, among those the goal heading's path would violate, the one
whose closest approach comes first (time to closest approach ranks them).

Why over 400 lines: the three steps above are one decision over one candidate set: they share
the roll-out, the clearance measure and the scoring, and each later step reads what the earlier
one found; split apart, a reader would follow one choice through three files.
"""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from companion.core.avoidance.arc import (MAX_GROWTH_M, Motion, Rollout, clearance, fly_out,
                                          margins_by_obstacle)
from companion.core.avoidance.evade import evasion_candidates, evasion_margins
from companion.core.avoidance.guidance import (GuidanceCommand, GuidanceInputs, GuidanceParams,
                                               approach_speed, inflated_radius, toward_goal)
from companion.core.avoidance.blind_side import dodge_speed_cap_mps
from companion.core.avoidance import speed_limit
from companion.core.avoidance.seen_space import SeenSpace
from companion.core.avoidance.union import (MAX_SPREAD_M, Geometry, UnionParams, blocking,
                                            candidate_headings, turn_speed_factor)
from companion.core.geometry import wrap_angle, wrap_angles

SPEED_FRACTIONS = (1.0, 0.75, 0.5, 0.25)
KEEP_TOLERANCE_M = 0.25    # the previous heading stays reachable down to d minus this: a choice
                           # on the edge of reachable must not flip every decision...
KEEP_FRACTION_OF_D = 0.05  # ...and at most this fraction of d: a success keeps 0.95 d (forest.md)
LOOK_PARTS = (1.0, 0.75, 0.5)  # a flank look's swing, then parts of it (flank_scan.py)
EVADE_SPARE_M = 1.0       # with a mover near, an evasion nearer the goal keeps this over margin
BRAKE_ASIDE_TIE_M = 0.2   # with avoidance.speed_limit: a last resort braking aside must keep this
                          # much more clearance than the nose-led hold (speed_limit.py)
FIRST_CHUNK = 32           # candidates rolled out before the rest (see _first_passing)
GRID = np.linspace(-math.pi, math.pi, 72, endpoint=False)     # 5 degrees, beside the cone edges


def safety_radii(inputs: GuidanceInputs, params: GuidanceParams) -> np.ndarray:
    """(n,) each obstacle's safety radius as the velocity choice takes it: d, inflated by the
    relative position's sigma when configured, widened by the spread (at most MAX_SPREAD_M)."""
    obstacles, rel_covs, spread_m = inputs.obstacles, inputs.rel_covs, inputs.spread_m
    if rel_covs is None or params.inflation_sigmas <= 0.0:
        radii = np.full(len(obstacles), params.safety_distance_m)
    else:
        radii = np.array([inflated_radius(params.safety_distance_m, cov, params.inflation_sigmas)
                          for cov in rel_covs])
    if spread_m is not None and len(obstacles):
        radii = radii + np.minimum(spread_m, MAX_SPREAD_M)
    return radii


def guide_flyable(inputs: GuidanceInputs, params: GuidanceParams,
                  union: UnionParams) -> GuidanceCommand:
    """The union law on paths the vehicle can fly (``inputs.motion``: its limits and velocity
    now): only commands whose rolled-out path keeps every safety distance (choose_velocity).
    Cruise is capped so that the vehicle stops d short of the camera's range
    (union.sensed_speed_limit); only obstacles the roll-out can reach are considered."""
    pose, goal, obstacles, rel_covs = inputs.pose, inputs.goal, inputs.obstacles, inputs.rel_covs
    previous_heading_rad, side = inputs.previous_heading_rad, inputs.side
    velocities = inputs.velocities
    motion, growth_mps, clear_reach_m = inputs.motion, inputs.growth_mps, inputs.clear_reach_m
    seen, spread_m, look = inputs.seen, inputs.spread_m, inputs.look
    goal_distance, goal_heading = toward_goal(pose, goal)
    if goal_distance <= params.goal_radius_m:
        return GuidanceCommand(0.0, pose[2], "arrived")
    cruise = approach_speed(params, goal_distance)
    if union.sensor_range_m is not None:
        cruise = min(cruise, speed_limit.cruise_cap(union, params.safety_distance_m, motion))
        if union.mover_max_speed_mps is not None:
            cruise = min(cruise, dodge_speed_cap_mps(
                union.sensor_range_m, params.safety_distance_m, motion.max_accel_mps2,
                speed_limit.latency_s(motion, union), union.mover_max_speed_mps))
    reference = pose[2] if previous_heading_rad is None else previous_heading_rad
    radii = safety_radii(inputs, params)
    gaps = np.hypot(*(obstacles - pose[:2]).T) - radii if len(obstacles) else np.empty(0)
    # what the roll-out can reach: the look-ahead at the faster of now and cruise, then a stop
    top = max(cruise, motion.speed_mps)
    reach = top * union.lookahead_s + top * top / (2.0 * motion.max_accel_mps2)
    if velocities is None and growth_mps is None:
        near = (gaps < reach).nonzero()[0]      # what the sum below adds here: zeros
    else:
        speeds = np.zeros(len(obstacles)) if velocities is None else np.hypot(*velocities.T)
        grow = np.zeros(len(obstacles)) if growth_mps is None else growth_mps
        horizon = union.lookahead_s + top / motion.max_accel_mps2
        near = (gaps < reach + speeds * horizon
                + np.minimum(grow * horizon, MAX_GROWTH_M)).nonzero()[0]
    if near.size == 0:
        heading = goal_heading
        in_view = abs(wrap_angle(goal_heading - pose[2])) <= 0.5 * union.fov_rad
        swing = None if look is None or not in_view else look(goal_heading)
        if swing is not None and look_flyable(pose, swing, cruise, params, union, motion, seen):
            heading = swing
        return GuidanceCommand(cruise * turn_speed_factor(pose[2], heading, union.fov_rad),
                               heading, "goal")
    moving = velocities is not None and bool(np.any(velocities[near]))
    return choose_velocity(pose, goal_heading, goal_distance, cruise, reference, side,
                           obstacles[near], radii[near], near, params, union,
                           velocities[near] if moving else None, motion,
                           None if growth_mps is None or not moving else growth_mps[near],
                           clear_reach_m, seen, look)


def choose_velocity(pose: np.ndarray, goal_heading: float, goal_distance: float, cruise: float,
                    reference: float, side: int, obstacles: np.ndarray, radii: np.ndarray,
                    near: np.ndarray, params: GuidanceParams, union: UnionParams,
                    velocities: np.ndarray | None, motion: Motion,
                    growth_mps: np.ndarray | None = None,
                    clear_reach_m: float | None = None,
                    seen: SeenSpace | None = None, look=None) -> GuidanceCommand:
    """A speed and heading outside every cone whose path is flyable; see the module docstring.

    obstacles (n,2), radii (n,), velocities (n,2) or None, growth_mps (n,) or None: the near
    obstacles only; ``near`` (n,) their indices in the caller's list. ``clear_reach_m``
    (commitment.py: a side taken, no progress yet): a heading toward the goal (within 90
    degrees of it) counts as free only if no static cone blocks it this far ahead, unless no
    heading at all is free so. ``seen`` (seen_space.py): a command is flyable only if, flown for
    the loop's latency and then braked, it keeps d from space never seen (_unseen_margin).
    ``look`` (flank_scan.py): a function of the chosen heading giving the heading to fly instead
    to look at a flank, or None; taken only if free, committed and reachable at the same speed.
    """
    position = pose[:2]
    yaw = float(pose[2])
    geometry = Geometry.of(position, obstacles, radii, params.eta)
    gates = gate_headings(position, obstacles, radii, union.gap_margin_m) \
        if velocities is None and union.gap_margin_m is not None else np.empty(0)
    candidates = np.concatenate([candidate_headings(goal_heading, reference, geometry,
                                                    velocities is not None), GRID, gates])
    candidates = wrap_angles(candidates)
    far_blocked = _far_blocked(candidates, goal_heading, position, obstacles, radii, velocities,
                               params.eta, clear_reach_m)
    through_gate = np.zeros(len(candidates), dtype=bool)
    if gates.size:
        through_gate[-gates.size:] = True
    offset = wrap_angles(candidates - goal_heading)
    cost = np.abs(offset) + union.hysteresis * np.abs(wrap_angles(candidates - reference))
    if side:
        cost = cost + np.pi * (np.sign(offset) == -side)

    keep_m = min(KEEP_TOLERANCE_M, KEEP_FRACTION_OF_D * params.safety_distance_m)
    goal_path: list = []      # the goal heading's path at cruise, when a decision rolls it out
    same_goal = float(candidates[0]) == goal_heading     # index 0 is the goal heading, wrapped

    def flown_margin(headings: np.ndarray, speed: float):
        """The commands' roll-outs and each one's worst margin (m): from the obstacles, and from
        space never seen where that applies (_unseen_margin)."""
        rolled = fly_out(position, motion, headings, np.full(len(headings), speed),
                         union.lookahead_s, union.fov_rad)
        margin = clearance(rolled, obstacles, radii, velocities, growth_mps, position)
        unseen = _unseen_margin(seen, position, motion, headings, speed, union,
                                params.safety_distance_m)
        return rolled, margin if unseen is None else np.minimum(margin, unseen)

    def reachable(indices: np.ndarray, speed: float) -> np.ndarray:
        """Each command's worst margin (m), the previous heading's raised by the tolerance."""
        rolled, margin = flown_margin(candidates[indices], speed)
        if same_goal and speed == cruise and len(indices) == 1 and indices[0] == 0:
            goal_path.append(rolled)
        return margin + np.where(indices == 1, keep_m, 0.0)

    def flyable(indices: np.ndarray, speed: float, keep: float = keep_m) -> np.ndarray:
        """The fallbacks' margin, the mapped obstacles alone (the last resort's ranking: 0.25 m)."""
        rolled = fly_out(position, motion, candidates[indices], np.full(len(indices), speed),
                         union.lookahead_s, union.fov_rad)
        margin = clearance(rolled, obstacles, radii, velocities, growth_mps, position)
        return margin + np.where(indices == 1, keep, 0.0)

    def look_ok(heading: float, speed: float) -> bool:
        """The look heading is free of every cone, committed and reachable at ``speed``."""
        h = np.array([wrap_angles(np.array([heading]))[0]])
        blocked = blocking(h, position, obstacles, radii, params.eta,
                           min(max(speed, motion.speed_mps) * union.lookahead_s, goal_distance),
                           speed, velocities, union.lookahead_s, geometry).any()
        if blocked or _far_blocked(h, goal_heading, position, obstacles, radii, velocities,
                                   params.eta, clear_reach_m)[0]:
            return False
        return bool(flown_margin(h, speed)[1][0] >= 0.0)

    def looked(chosen: GuidanceCommand, speed: float) -> GuidanceCommand:
        """``chosen``, or the flank scan's look instead: only cruising on a heading in view."""
        if look is None or speed <= 0.0 or \
                abs(wrap_angles(np.array([chosen.heading_rad - yaw]))[0]) > 0.5 * union.fov_rad:
            return chosen
        swing = look(chosen.heading_rad)
        if swing is None:
            return chosen
        turn = float(wrap_angles(np.array([swing - chosen.heading_rad]))[0])
        for part in LOOK_PARTS:       # a post beside the way may leave room for part of a look
            heading = float(wrap_angles(np.array([chosen.heading_rad + part * turn]))[0])
            if look_ok(heading, speed):
                return replace(chosen, heading_rad=heading,
                               speed_mps=speed * turn_speed_factor(yaw, heading, union.fov_rad))
        return chosen

    def command(index: int, speed: float, mode: str) -> GuidanceCommand:
        heading = float(candidates[index])
        urgent, ttca = _most_urgent(position, motion, goal_heading, cruise, obstacles, radii,
                                    velocities, growth_mps, union,
                                    goal_path[0] if goal_path else None)
        return GuidanceCommand(speed * turn_speed_factor(yaw, heading, union.fov_rad), heading,
                               "goal" if index == 0 and mode == "avoid" else mode,
                               None if urgent is None else int(near[urgent]), ttca,
                               side=int(np.sign(offset[index])) or 1 if index else 0)

    def evade_command(heading: float, speed: float, mode: str = "evade") -> GuidanceCommand:
        """An evasion (evade.py): the velocity setpoint at once, the nose held where it is."""
        urgent, ttca = _most_urgent(position, motion, goal_heading, cruise, obstacles, radii,
                                    velocities, growth_mps, union,
                                    goal_path[0] if goal_path else None)
        if speed <= 0.0:
            heading = motion.course_rad
        turn = float(wrap_angles(np.array([heading - goal_heading]))[0])
        return GuidanceCommand(speed, heading, mode, None if urgent is None else int(near[urgent]),
                               ttca, side=int(np.sign(turn)) or 1 if speed > 0.0 else side,
                               yaw_rad=yaw, free_course=True)

    evades = union.evade_movers and _evades(motion, velocities)
    # the last resort brakes sideways too: with movers (evade_movers), or anywhere with the speed
    # limit's key (speed_limit.py), a multicopter's
    brakes_aside = evades or (union.seen_speed_limit and motion.nose_rad is not None
                              and motion.max_lateral_accel_mps2 is not None)
    evasion: list = []          # _evasion's answer, computed once, when asked for

    def evasion_now() -> tuple:
        if not evasion:
            evasion.append(_evasion(position, motion, goal_heading, reference, side, cruise,
                                    obstacles, radii, velocities, growth_mps, seen, union,
                                    params.safety_distance_m))
        return evasion[0]

    def in_place(chosen: GuidanceCommand) -> bool:
        """A turn in place (a heading beyond the view: no speed until the nose is there), where
        an evasion may come first."""
        return evades and chosen.speed_mps <= 0.0

    away: GuidanceCommand | None = None
    deferred: GuidanceCommand | None = None
    for fraction in SPEED_FRACTIONS:
        speed = cruise * fraction
        blocked = blocking(candidates, position, obstacles, radii, params.eta,
                           min(max(speed, motion.speed_mps) * union.lookahead_s, goal_distance),
                           speed, velocities, union.lookahead_s, geometry).any(axis=1)
        # a gate's heading passes between cones by construction: its flown path alone decides
        free = (~blocked | through_gate).nonzero()[0]
        if free.size == 0:
            continue
        committed = free[~far_blocked[free] | through_gate[free]]
        if committed.size:
            free = committed
        free = free[cost[free].argsort(kind="stable")]
        skip = 0
        if free[0] == 0:
            if reachable(free[:1], speed)[0] >= 0.0:
                deferred = looked(command(0, speed, "avoid"), speed)
                break
            skip = 1                     # the goal heading is not reachable: scan the others
        away_last = velocities is not None or union.headway_first
        first, first_forward = _first_passing(free, skip, lambda k: reachable(k, speed),
                                              offset, away_last)
        if first is None:
            continue
        if not away_last or abs(offset[first]) < 0.5 * np.pi:
            deferred = looked(command(first, speed, "avoid"), speed)
            break
        # Flying away from the goal to keep clear of a mover: at full speed beside a crossing
        # mover that heading can stay free for as long as the mover goes on (traffic worlds: an
        # escort 300 m off the way); a slower speed that makes headway, behind it, comes first.
        away = away or command(first, speed, "avoid")
        if first_forward is not None:
            deferred = looked(command(first_forward, speed, "avoid"), speed)
            break
    chosen = deferred or away
    if chosen is not None and not in_place(chosen):
        return chosen
    if chosen is not None:
        # a multicopter turning in place with a mover near: side-stepping or backing off with
        # its nose held comes first, if one keeps every margin (evade.py)
        moving = evasion_now()[0]
        return evade_command(*moving[:2]) if moving is not None else chosen
    everything = cost.argsort(kind="stable")
    for speed in (0.25 * cruise, 0.0):
        first, _ = _first_passing(everything, 0, lambda k: flyable(k, speed), offset, False)
        if first is not None:
            return command(first, speed, "slow" if speed else "stop")
    if brakes_aside and evasion_now()[0] is not None:
        return evade_command(*evasion_now()[0][:2])
    best_margin, best = -np.inf, (0, 0.0)
    for speed in (0.0, 0.5 * cruise, cruise):
        margin = flyable(everything, speed, KEEP_TOLERANCE_M)
        k = int(np.argmax(margin))
        if margin[k] > best_margin + 0.5:       # a slower option wins ties: less to go wrong
            best_margin, best = float(margin[k]), (int(everything[k]), speed)
    if evades and evasion_now()[1][2] > best_margin + 0.5:
        return evade_command(*evasion_now()[1][:2], mode="hold")
    if brakes_aside and not evades:
        # the speed limit's key: braking aside wins on its clearance alone, against the hold's
        # own (without the previous heading's tolerance), by more than the roll-out's step
        own = best_margin - (KEEP_TOLERANCE_M if best[0] == 1 else 0.0)
        if evasion_now()[1][2] > own + BRAKE_ASIDE_TIE_M:
            return evade_command(*evasion_now()[1][:2], mode="hold")
    return command(best[0], best[1], "hold")


def _evades(motion: Motion, velocities: np.ndarray | None) -> bool:
    """Evasions (evade.py) are candidates for a multicopter (its nose known, its velocity limited
    as a vector) with a mover among the obstacles; static worlds and the unicycle fly as before."""
    return (motion.nose_rad is not None and motion.max_lateral_accel_mps2 is not None
            and velocities is not None and bool(np.any(velocities != 0.0)))


def _evasion(position: np.ndarray, motion: Motion, goal_heading: float, reference: float,
             side: int, cruise: float, obstacles: np.ndarray, radii: np.ndarray,
             velocities: np.ndarray, growth_mps: np.ndarray | None, seen: SeenSpace | None,
             union: UnionParams, d: float) -> tuple[tuple | None, tuple]:
    """The evasions (evade.py) as (heading, speed, margin): the first moving one by the union
    law's cost (goal, hysteresis, side) whose margin is >= 0, or None; and the one with the most
    margin, the stop winning ties of 0.5 m (less to go wrong), for the last resort. With a mover
    near (issue 46): space never seen over the latency, then a stop; a back-off beyond 90 deg
    of the nose only within a camera's view (a mover may come from where none looks: traffic
    seed 58, 4.15 m); the first must spare EVADE_SPARE_M, else the widest is taken."""
    headings, speeds = evasion_candidates(GRID, cruise, union.seen_speed_limit)
    # (1)-(3) evade movers; a static world's brake aside (speed_limit) is chosen as measured
    movers = _evades(motion, velocities)
    margin = evasion_margins(position, motion, headings, speeds, union.lookahead_s, obstacles,
                             radii, velocities, growth_mps, seen, d,
                             speed_limit.latency_s(motion, union) if movers else None)   # (1)
    if movers:                                                                          # (2)
        margin = np.where(_in_view(headings, motion.nose_rad, union) | (speeds <= 0.0), margin,
                          -np.inf)
    offset = wrap_angles(headings - goal_heading)
    cost = np.abs(offset) + union.hysteresis * np.abs(wrap_angles(headings - reference))
    if side:
        cost = cost + np.pi * (np.sign(offset) == -side)
    passing = np.flatnonzero(margin[1:] >= 0.0) + 1          # index 0 is the stop
    if movers:                                                                          # (3)
        spare = passing[margin[passing] >= EVADE_SPARE_M]
        passing = spare if spare.size or not passing.size \
            else passing[[int(np.argmax(margin[passing]))]]
    first = None
    if passing.size:
        k = int(passing[np.argmin(cost[passing])])
        first = (float(headings[k]), float(speeds[k]), float(margin[k]))
    k = int(np.argmax(margin))
    if margin[0] >= margin[k] - 0.5:
        k = 0
    return first, (float(headings[k]), float(speeds[k]), float(margin[k]))


def _in_view(headings: np.ndarray, nose_rad: float, union: UnionParams) -> np.ndarray:
    """(K,) whether each course is a side-step (within 90 deg of the nose at ``nose_rad``) or
    lies within some camera's view."""
    seen = np.stack([np.abs(wrap_angles(headings - nose_rad - yaw))
                     for yaw in union.view_yaws_rad]).min(axis=0)
    return (np.abs(wrap_angles(headings - nose_rad)) <= 0.5 * np.pi + 1e-9) \
        | (seen <= 0.5 * union.fov_rad + 1e-9)


def _first_passing(order: np.ndarray, skip: int, margin_of, offset: np.ndarray,
                   forward_too: bool) -> tuple[int | None, int | None]:
    """The first candidate in ``order[skip:]`` whose margin is >= 0 and (``forward_too``) the
    first such within 90 degrees of the goal; None where there is none.

    Margins are computed for the first candidate alone, then the next FIRST_CHUNK, then the
    rest, each only if the answer is not there yet: the best-scored candidate usually passes
    (every time on the paper scenario), one command rolls out in plain Python floats
    (arc._fly_one, about a tenth of a vectorised roll-out's time, whose cost is numpy's
    per-step dispatch whatever the count), and a roll-out's margin depends on its own command
    only, to the last bit (the same operations either way), so the answer is the one of
    rolling out all at once.
    """
    first = forward = None
    position, size = skip, 1
    while position < len(order):
        chunk = order[position:position + size]
        passing = chunk[margin_of(chunk) >= 0.0]
        if passing.size:
            if first is None:
                first = int(passing[0])
            if not forward_too:
                break
            ahead = passing[np.abs(offset[passing]) < 0.5 * np.pi]
            if ahead.size:
                forward = int(ahead[0])
                break
        position, size = position + size, FIRST_CHUNK if size == 1 else len(order)
    return first, forward


def look_flyable(pose: np.ndarray, heading: float, speed: float, params: GuidanceParams,
                 union: UnionParams, motion: Motion, seen: SeenSpace | None) -> bool:
    """With no obstacle near: a look heading (flank_scan.py) is flyable if it keeps d from
    space never seen (only where the stopping distance exceeds d, as choose_velocity)."""
    unseen = _unseen_margin(seen, pose[:2], motion, np.array([heading]), speed, union,
                            params.safety_distance_m)
    return unseen is None or bool(unseen[0] >= 0.0)


def _unseen_margin(seen: SeenSpace | None, position: np.ndarray, motion: Motion,
                   headings: np.ndarray, speed: float, union: UnionParams,
                   d: float) -> np.ndarray | None:
    """_seen_margin where the check applies (a seen space, and a stopping distance beyond d:
    an obstacle that shows up nearer is never nearer than d before the vehicle has stopped),
    else None."""
    if seen is None or not speed_limit.applies(speed, motion, union, d):
        return None
    return _seen_margin(seen, position, motion, headings, speed, union, d)


def _seen_margin(seen: SeenSpace, position: np.ndarray, motion: Motion, headings: np.ndarray,
                 speed: float, union: UnionParams, d: float) -> np.ndarray:
    """(J,) how far each command, flown until a new obstacle would enter the decision and then
    braked, stays beyond d from space never seen (less what it lacks already here), and from
    space seen too lately to be mapped (speed_limit.unseen_margins)."""
    speeds = np.full(len(headings), speed)
    return speed_limit.unseen_margins(seen, position, lambda fly_s: fly_out(
        position, motion, headings, speeds, fly_s, union.fov_rad).positions,
        speed_limit.latency_s(motion, union), speed_limit.seen_need_m(union, d, seen.cell_m))


def _far_blocked(candidates: np.ndarray, goal_heading: float, position: np.ndarray,
                 obstacles: np.ndarray, radii: np.ndarray, velocities: np.ndarray | None,
                 eta: float, clear_reach_m: float | None) -> np.ndarray:
    """(K,) True where a heading toward the goal meets a static cone within ``clear_reach_m``."""
    far = np.zeros(len(candidates), dtype=bool)
    if clear_reach_m is None or len(obstacles) == 0:
        return far
    static = np.ones(len(obstacles), dtype=bool) if velocities is None \
        else ~np.any(velocities != 0.0, axis=1)
    forward = np.abs(wrap_angles(candidates - goal_heading)) < 0.5 * np.pi - 1e-6
    if not static.any() or not forward.any():
        return far
    far[forward] = blocking(candidates[forward], position, obstacles[static], radii[static], eta,
                            clear_reach_m).any(axis=1)
    return far


def _most_urgent(position: np.ndarray, motion: Motion, goal_heading: float, cruise: float,
                 obstacles: np.ndarray, radii: np.ndarray, velocities: np.ndarray | None,
                 growth_mps: np.ndarray | None, union: UnionParams,
                 rolled: Rollout | None = None) -> tuple[int | None, float | None]:
    """The obstacle the straight-to-goal path violates first, and the time of that approach.
    ``rolled``: that path, when the caller has rolled it out already."""
    if rolled is None:
        rolled = fly_out(position, motion, np.array([goal_heading]), np.array([cruise]),
                         union.lookahead_s, union.fov_rad)
    margin, when = margins_by_obstacle(rolled, obstacles, radii, velocities, growth_mps)
    violated = (margin < 0.0).nonzero()[0]
    if violated.size == 0:
        return None, None
    first = int(violated[np.argmin(when[violated])])
    return first, float(when[first])


def gate_headings(position: np.ndarray, obstacles: np.ndarray, radii: np.ndarray,
                  margin_m: float) -> np.ndarray:
    """Headings to the middle of every gap between two obstacles whose safety circles leave at
    least ``margin_m`` between them, with no other circle across the gap. (k,) radians.

    The eta-scaled cones close such a gap (eta * asin(d / |X|) of each side overlap), so the
    union law goes round a wall with a gate in it; the gate's heading is taken when its flown
    path keeps every safety distance, and wins when it is nearer the goal.
    """
    n = len(obstacles)
    if n < 2:
        return np.empty(0)
    i, j = np.triu_indices(n, 1)
    width = np.hypot(*(obstacles[i] - obstacles[j]).T)
    ok = width >= radii[i] + radii[j] + margin_m
    i, j = i[ok], j[ok]
    if i.size == 0:
        return np.empty(0)
    a, b = obstacles[i], obstacles[j]                                   # (m, 2)
    ab = b - a
    # no third obstacle between a and b whose circle reaches the line a-b (neighbours beyond
    # either end, as the rest of a wall, overlap its ends only: the flown path decides those)
    t = np.einsum("mkd,md->mk", obstacles[None, :, :] - a[:, None, :], ab) \
        / np.einsum("md,md->m", ab, ab)[:, None]                        # (m, n)
    closest = a[:, None, :] + t[..., None] * ab[:, None, :]
    across = (np.hypot(*(obstacles[None, :, :] - closest).transpose(2, 0, 1)) < radii[None, :]) \
        & (t > 0.0) & (t < 1.0)
    across[np.arange(i.size), i] = False
    across[np.arange(i.size), j] = False
    keep = ~across.any(axis=1)
    middle = 0.5 * (a[keep] + b[keep]) - position
    return np.arctan2(middle[:, 1], middle[:, 0])
