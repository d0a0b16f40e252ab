"""Never faster than the vehicle can stop in the space it has seen free (avoidance.speed_limit).

The velocity choice and the path follower already check what they can: every command is rolled
out (arc.py) and then braked, and must keep d from every mapped obstacle and mover prediction.
What they did not check fully is the space the camera has not yet seen, where an obstacle may
stand that is not in the map yet:

- the cruise cap (union.sensed_speed_limit) counted the perception delay only, and the whole
  camera range as seen, where the seen-space grid (seen_space.py) marks a cell only once its
  centre is in view;
- the seen-space check (velocity_choice._seen_margin) applied only where the stopping distance
  exceeds d, with d less a grid cell, and counted the perception delay only.

With the key on (``UnionParams.seen_speed_limit``) every command, at any speed, is flown for the
loop's whole latency (``latency_s``: the perception delay, the decision's period, and for a
jerk-shaped autopilot the half of the time its deceleration takes to build up, a/2j) and then
braked at the configured deceleration, and its path must keep d from space never seen (unseen
space counts as occupied where the camera's coverage ends); the cruise cap is the speed that
stops d short of the coverage's end straight ahead with that latency (``cruise_cap``). The last
resort of the velocity choice then also weighs braking with a sideways component (evade.py's
candidates: the velocity setpoint set at once, the nose held), scored by the same roll-out and
clearance as every candidate: a multicopter can brake away from a trunk rather than straight
along its velocity.

Seen is not mapped yet: an obstacle first in view at a frame enters the decision at most the
perception delay less a frame's period later (the lifecycle confirms it at the latest on the
confirm window's last frame; the delay counts the whole window, ``confirm_window / rate``). So
every space not seen as of a frame of the last delay (the seen grid's ``views``) is unseen space
for a command flown for the latency less that frame's age behind the latest (``unseen_margins``):
what stood in cells first seen at the next frame is braked for no later than that. Flying
straight this is the cap's rule again (the space seen a frame ago ends a frame's flight nearer,
and is braked for a frame's period sooner); turning, it keeps d from space swept but not mapped.

Pure maths; speeds m/s, distances m, times s.
"""
from __future__ import annotations

from typing import Callable

import numpy as np

from companion.core.avoidance.arc import Motion, stopping_distance_m
from companion.core.avoidance.seen_space import CELL_M, SeenSpace
from companion.core.avoidance.union import UnionParams, sensed_speed_limit


def latency_s(motion: Motion, union: UnionParams) -> float:
    """How long a command is flown before braking starts for an obstacle not yet in the map:
    the perception delay, and with the key the decision's period and a jerk-shaped
    deceleration's build-up (a/j to reach full deceleration, which loses the speed of a/2j at
    full deceleration)."""
    delay = union.perception_delay_s
    if not union.seen_speed_limit:
        return delay
    delay += union.control_period_s
    if motion.max_jerk_mps3:
        delay += motion.max_accel_mps2 / (2.0 * motion.max_jerk_mps3)
    return delay


def stopping_m(speed_mps: float, motion: Motion, union: UnionParams) -> float:
    """How far the vehicle goes before a new obstacle enters the decision and it has stopped."""
    return stopping_distance_m(speed_mps, latency_s(motion, union), motion.max_accel_mps2)


def cruise_cap(union: UnionParams, safety_distance_m: float, motion: Motion) -> float:
    """The fastest cruise from which the vehicle, flying straight, stops d short of where the
    camera's coverage ends (union.sensed_speed_limit). With the key, the coverage ends half a
    grid cell short of the range (the grid marks a cell once its centre is in view) and the
    whole latency counts."""
    if not union.seen_speed_limit:
        return sensed_speed_limit(union.sensor_range_m, safety_distance_m,
                                  motion.max_accel_mps2, union.perception_delay_s)
    return sensed_speed_limit(union.sensor_range_m - 0.5 * CELL_M, safety_distance_m,
                              motion.max_accel_mps2, latency_s(motion, union))


def seen_need_m(union: UnionParams, safety_distance_m: float, cell_m: float) -> float:
    """How far a braked path must stay from space never seen: d with the key; without, d less
    the grid's cell, as the seen-space check always took it (straight ahead at the camera's
    speed cap must pass)."""
    return safety_distance_m if union.seen_speed_limit else safety_distance_m - cell_m


def applies(speed_mps: float, motion: Motion, union: UnionParams,
            safety_distance_m: float) -> bool:
    """Whether a command at this speed is checked against space never seen: with the key always
    (a stop included: a vehicle still moving may coast into unseen space); without, only where
    the stopping distance exceeds d."""
    return union.seen_speed_limit or stopping_m(speed_mps, motion, union) > safety_distance_m


def unseen_margins(seen: SeenSpace, position: np.ndarray, roll: Callable[[float], np.ndarray],
                   fly_s: float, need_m: float) -> np.ndarray:
    """(J,) how far each command's braked path keeps beyond ``need_m`` from space not seen,
    less what the vehicle lacks of it already here; the worst over the seen grid's views: the
    space never seen with the command flown ``fly_s`` (the latency) before braking, and the
    space not seen as of each kept frame with it flown that frame's age less.
    ``roll(fly_s)``: the commands' positions (J, steps, 2), flown fly_s and then braked."""
    worst = None
    for age_s, grid in seen.views():
        positions = roll(max(fly_s - age_s, 0.0))
        now = float(grid.margin(position[None, :])[0]) - need_m
        margin = grid.margin(positions).min(axis=-1) - need_m - min(now, 0.0)
        worst = margin if worst is None else np.minimum(worst, margin)
    return worst
