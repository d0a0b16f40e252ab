"""Avoidance in 3D: over, under or around, and back down to the cruise altitude after.

The horizontal law stays what it is (core/union.py and the others). This module decides which
obstacles it must fly round, by offering it altitude plans:

- ``level``: the cruise altitude, or higher while the vehicle is horizontally within d of an
  obstacle it is passing over (it never sinks onto one);
- ``over``: climbing, at the vertical speed limit, to just clear (d plus a margin plus the top's
  uncertainty) every obstacle in reach whose top is known and below the altitude ceiling;
- ``under``: sinking below an overhang (a bridge deck) whose bottom is known, above the floor;
- ``over-slow``, ``under-slow`` (with ``max_accel_mps2``, issue 46): the same altitude, the
  horizontal speed capped (or stopped) so that the climb or descent clears, before the vehicle is
  within d of them, the obstacles in reach it does not clear at the cruise speed
  (core/avoidance/climb_time.py); it costs the time it loses, ``delay_cost_m_per_s``.

Under a plan, an obstacle is left out of the horizontal law if the planned altitude profile (from
the altitude now toward the plan's at the vertical speed limit) keeps the vehicle out of its
capped cylinder (core/avoidance/cone3d.py) from the earliest time it could get horizontally within d of
the axis, flying straight at it at the cruise speed: the worst direction, so whatever the
horizontal law then chooses, the 3D path clears the obstacles left out by d (vertically).

Each plan's horizontal command is scored by the detour it implies (via the point abeam the
farthest obstacle it flies round; with ``barrier_cost``, at least the way round every mapped
barrier it flies round, core/avoidance/barrier.py) plus the vertical way still to fly (up to the
plan's altitude, and back down to the cruise altitude), metre for metre; the least wins, the plan flown before
keeping it unless another saves ``switch_margin_m``. A vehicle below the minimum altitude (taking
off, landing) flies over nothing. The vertical command: a climb rate toward the chosen
altitude, within the vertical speed limit and [min_altitude_m, max_altitude_m].
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from companion.core.avoidance.barrier import blocking_rows
from companion.core.avoidance.climb_time import STOP_SPEED_MPS, altitude_time_s, fitting_speed_mps

BIG_COST_M = 1e4        # a hold or an escape: worse than any detour or climb


@dataclass(frozen=True)
class VerticalParams:
    safety_distance_m: float
    cruise_altitude_m: float
    max_vertical_speed_mps: float
    min_altitude_m: float
    max_altitude_m: float
    cruise_speed_mps: float
    reach_m: float                      # obstacles this far (horizontally) are planned for
    margin_m: float = 1.0               # above top + d (and below base - d)
    top_sigmas: float = 3.0             # ... plus this many sigmas of the top's estimate
    climb_lag_s: float = 1.0            # the vertical speed's build-up (accel) and the loop's delay
    altitude_gain_per_s: float = 0.8    # climb rate = gain x altitude error, within the limit
    switch_margin_m: float = 3.0        # another plan must save this much to be flown instead
    hold_band_m: float = 0.3            # within this of the plan's altitude (< margin_m / 2): no climb (the
                                        # autopilot holds its altitude; the reported one is noisy)
    climb_weight: float = 1.0           # a metre up or down costs this many metres along
    # Slowing so that a climb fits (core/avoidance/climb_time.py): the vehicle's acceleration
    # (None: no slowed plans), and what a second of delay costs, in metres along
    max_accel_mps2: float | None = None
    delay_cost_m_per_s: float = 1.0
    barrier_cost: bool = False          # a plan's detour counts the mapped barriers it flies
                                        # round (core/avoidance/barrier.py), not only its reach


@dataclass(frozen=True)
class Extent:
    """What the planner knows of one guidance row: the top (None: unbounded or unknown), its
    sigma, the bottom (0: on the ground) and whether that bottom was seen."""
    top_m: float | None
    top_sigma_m: float = 0.0
    bottom_m: float = 0.0
    bottom_seen: bool = False


UNBOUNDED = Extent(None)


@dataclass(frozen=True)
class Plan:
    kind: str                       # 'level' | 'over' | 'under' | 'over-slow' | 'under-slow'
    altitude_m: float
    skip: frozenset = field(default_factory=frozenset)     # guidance rows flown over or under
    speed_mps: float | None = None  # a slowed plan's cap on the horizontal speed (None: none)
    delay_s: float = 0.0            # ... and the time it loses to the climb (beyond the cruise's)


@dataclass(frozen=True)
class VerticalChoice:
    plan: Plan
    climb_mps: float                # the vertical setpoint, up positive
    costs: tuple                    # (kind, cost) of every plan scored


def _profile_low_high(alt_m: float, target_m: float, t_s: float, rate_mps: float,
                      lag_s: float) -> tuple[float, float]:
    """The lowest and highest altitude of the profile from t_s on: it moves from ``alt_m`` toward
    ``target_m`` at ``rate_mps`` after ``lag_s``, then holds."""
    moved = min(abs(target_m - alt_m), rate_mps * max(0.0, t_s - lag_s))
    at_t = alt_m + math.copysign(moved, target_m - alt_m)
    return min(at_t, target_m), max(at_t, target_m)


def clears(extent: Extent, horizontal_m: float, alt_m: float, target_m: float,
           params: VerticalParams) -> str | None:
    """'over' or 'under' if the profile toward ``target_m`` keeps out of the obstacle's grown
    cylinder from the earliest horizontal entry on (flying straight at its axis); else None."""
    d = params.safety_distance_m
    t_entry = max(0.0, horizontal_m - d) / max(params.cruise_speed_mps, 1e-6)
    low, high = _profile_low_high(alt_m, target_m, t_entry, params.max_vertical_speed_mps,
                                  params.climb_lag_s)
    # half the margin: a vehicle holding a plan's altitude within hold_band_m still clears
    slack = 0.5 * params.margin_m
    if extent.top_m is not None and \
            low >= extent.top_m + d + slack + params.top_sigmas * extent.top_sigma_m - 1e-9:
        return "over"
    if extent.bottom_seen and extent.bottom_m > 0.0 and \
            high <= extent.bottom_m - d - slack + 1e-9:
        return "under"
    return None


def over_altitude_m(extent: Extent, params: VerticalParams) -> float | None:
    if extent.top_m is None:
        return None
    return extent.top_m + params.safety_distance_m + params.margin_m \
        + params.top_sigmas * extent.top_sigma_m


def _need_m(kind: str, extent: Extent, params: VerticalParams) -> float | None:
    """The altitude at which clears() passes over (at or above) or under (at or below) it."""
    slack = 0.5 * params.margin_m
    if kind == "over":
        return None if extent.top_m is None else \
            extent.top_m + params.safety_distance_m + slack + params.top_sigmas * extent.top_sigma_m
    return extent.bottom_m - params.safety_distance_m - slack \
        if extent.bottom_seen and extent.bottom_m > 0.0 else None


def slowed(kind: str, target_m: float, skip: frozenset, near: list[int], gaps: np.ndarray,
           alt_m: float, extents: list[Extent], params: VerticalParams,
           speed_now_mps: float) -> Plan | None:
    """The plan toward ``target_m`` flown slower (or stopped) so that the climb ('over') or the
    descent ('under') clears the obstacles ``near`` (those in the way) it does not clear at the
    cruise speed (core/avoidance/climb_time.py); None if slowing clears none of them. Its cap:
    the highest speed clearing every such obstacle that slowing can clear; its delay: the longest
    wait, over those obstacles, beyond the time the cruise speed takes to them."""
    d = params.safety_distance_m
    error = abs(target_m - alt_m)
    speeds, waits = {}, {}
    for i in range(len(extents)):
        need = _need_m(kind, extents[i], params)
        if i in skip or need is None or (need > target_m + 1e-9 if kind == "over"
                                         else need < target_m - 1e-9):
            continue
        time_s = altitude_time_s(error, abs(target_m - need), params.max_vertical_speed_mps,
                                 params.altitude_gain_per_s, params.climb_lag_s)
        way = float(gaps[i]) - d
        speed = fitting_speed_mps(way, time_s, speed_now_mps, params.max_accel_mps2)
        if speed is not None:
            speeds[i] = speed
            waits[i] = max(0.0, time_s - max(way, 0.0) / max(params.cruise_speed_mps, 1e-6))
    capped = [speeds[i] for i in near if i in speeds]
    if not capped or min(capped) >= params.cruise_speed_mps:
        return None
    cap = min(capped)
    added = frozenset(i for i, speed in speeds.items() if speed >= cap)
    if not added:
        return None
    return Plan(f"{kind}-slow", target_m, skip | added,
                0.0 if cap < STOP_SPEED_MPS else cap, max(waits[i] for i in added))


def plans(position_ne_m: np.ndarray, alt_m: float, obstacles_ne_m: np.ndarray,
          extents: list[Extent], params: VerticalParams,
          ahead_ne: np.ndarray | None = None, speed_now_mps: float | None = None) -> list[Plan]:
    """The altitude plans to score (see the module's docstring); ``extents`` by guidance row.
    ``ahead_ne`` (a unit vector, the goal's direction): only obstacles not yet passed along it
    are climbed over or sunk under (one passed is left behind at the cruise altitude).
    With ``params.max_accel_mps2`` and ``speed_now_mps`` (the vehicle's horizontal speed), an
    over or under plan that does not clear everything in reach at the cruise speed is offered
    slowed too (``slowed``), for the barriers standing in the way ahead (barrier.blocking_rows;
    all in reach without ``ahead_ne``)."""
    n = len(extents)
    rel = np.asarray(obstacles_ne_m, dtype=float).reshape(-1, 2) - position_ne_m
    gaps = np.hypot(*rel.T) if n else np.zeros(0)
    ahead = np.ones(n, dtype=bool) if ahead_ne is None or not n else rel @ ahead_ne > 0.0
    d = params.safety_distance_m
    cruise = min(max(params.cruise_altitude_m, params.min_altitude_m), params.max_altitude_m)
    if alt_m < params.min_altitude_m:
        return [Plan("level", cruise)]
    # never sink onto what is below: hold the clearance of anything within d (and a margin)
    floor = cruise
    for gap, extent in zip(gaps, extents):
        over = over_altitude_m(extent, params)
        if over is not None and gap < d + params.margin_m and alt_m >= over - params.margin_m:
            floor = max(floor, min(over, params.max_altitude_m))
    level_alt = floor
    near = [i for i in range(n) if gaps[i] <= params.reach_m and ahead[i]]

    def skipped(target: float) -> frozenset:
        return frozenset(i for i in range(n)
                         if clears(extents[i], gaps[i], alt_m, target, params) is not None)

    out = [Plan("level", level_alt, skipped(level_alt))]
    level_skip = out[0].skip
    tops = [over_altitude_m(extents[i], params) for i in near if i not in level_skip]
    tops = [t for t in tops if t is not None and level_alt < t <= params.max_altitude_m]
    slowing = params.max_accel_mps2 is not None and speed_now_mps is not None
    if slowing and ahead_ne is not None:
        # slowed only for what stands in the way ahead: a barrier across the way to the goal
        in_way = blocking_rows(position_ne_m, obstacles_ne_m, ahead_ne, d)
        in_way = [i for i in near if i in in_way]
    else:
        in_way = near
    if tops:
        target = max(tops)
        plan = Plan("over", target, skipped(target))
        if plan.skip != level_skip:
            out.append(plan)
        slow = slowed("over", target, plan.skip, in_way, gaps, alt_m, extents, params,
                      speed_now_mps) if slowing else None
        if slow is not None:
            out.append(slow)
    unders = [extents[i].bottom_m - d - params.margin_m for i in near if i not in level_skip
              and extents[i].bottom_seen and extents[i].bottom_m > 0.0]
    unders = [u for u in unders if params.min_altitude_m <= u < level_alt]
    if unders:
        target = min(unders)
        plan = Plan("under", target, skipped(target))
        if plan.skip != level_skip:
            out.append(plan)
        slow = slowed("under", target, plan.skip, in_way, gaps, alt_m, extents, params,
                      speed_now_mps) if slowing else None
        if slow is not None:
            out.append(slow)
    return out


def detour_m(position_ne_m: np.ndarray, goal_ne_m: np.ndarray, heading_rad: float,
             obstacles_ne_m: np.ndarray, rows: list[int]) -> float:
    """The extra horizontal way of flying ``heading_rad`` to the point abeam the farthest of the
    obstacles ``rows`` (those it flies round) and on to the goal, over the straight line."""
    to_goal = float(np.hypot(*(goal_ne_m - position_ne_m)))
    if not rows:
        return 0.0
    u = np.array([math.cos(heading_rad), math.sin(heading_rad)])
    along = (np.asarray(obstacles_ne_m, dtype=float)[rows] - position_ne_m) @ u
    s = float(np.clip(along.max(), 0.0, to_goal))
    q = position_ne_m + s * u
    return s + float(np.hypot(*(goal_ne_m - q))) - to_goal


def plan_cost_m(plan: Plan, alt_m: float, detour: float, hold: bool,
                params: VerticalParams) -> float:
    vertical = abs(plan.altitude_m - alt_m) + abs(plan.altitude_m - params.cruise_altitude_m)
    return detour + params.climb_weight * vertical + (BIG_COST_M if hold else 0.0) \
        + params.delay_cost_m_per_s * plan.delay_s


def choose(scored: list[tuple[Plan, float]], last_kind: str | None, alt_m: float,
           params: VerticalParams) -> VerticalChoice:
    """The least costly plan (the one flown before kept unless another saves switch_margin_m),
    and the climb rate toward its altitude."""
    best, best_cost = min(scored, key=lambda pc: pc[1])
    for plan, cost in scored:
        if plan.kind == last_kind and cost <= best_cost + params.switch_margin_m:
            best, best_cost = plan, cost
            break
    return VerticalChoice(best, climb_rate_mps(alt_m, best.altitude_m, params),
                          tuple((p.kind, c) for p, c in scored))


def climb_rate_mps(alt_m: float, target_m: float, params: VerticalParams) -> float:
    """Toward ``target_m`` (kept within the altitude limits), within the vertical speed limit."""
    target = min(max(target_m, params.min_altitude_m), params.max_altitude_m)
    if abs(target - alt_m) <= params.hold_band_m:
        return 0.0
    rate = params.altitude_gain_per_s * (target - alt_m)
    limit = params.max_vertical_speed_mps
    return float(min(limit, max(-limit, rate)))
