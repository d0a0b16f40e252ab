"""Where a multicopter points its camera: at a tracked mover it cannot see, while it flies clear.

A multicopter's velocity and its yaw are separate setpoints (SET_POSITION_TARGET_LOCAL_NED
carries both); its camera points where its nose points. A mover that has left the field of view
stays in the decision while its track is alive, with a radius growing with its velocity's
uncertainty, and the velocity choice keeps clear of it. Looking at it again shrinks that
uncertainty back to a measurement's. So the nose may turn toward it, and only toward it:

- only movers (the static map needs no second look), closing in: their predicted closest
  approach to the vehicle flying the chosen velocity comes within ``horizon_s`` and nearer than
  ``distance_m``; or already within half that distance (inside the safety circle, at 2 d);
- only when a camera facing along the flight direction would not see it (outside half the field
  of view of that direction): judged against the flight direction, not the nose, so the choice
  does not flip once the nose has turned (the threat stays "unseen from the flight direction"
  until it is passed or no longer threatens);
- of several, the one whose closest approach comes first.

While it watches none, the nose may turn back toward the goal when the velocity swerves
(``goal_look_yaw``, below).

Pure numpy; positions north/east metres, headings LOCAL_NED yaw (rad).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from companion.core.geometry import wrap_angle, wrap_angles


@dataclass(frozen=True)
class LookAtParams:
    fov_rad: float              # the camera's horizontal field of view
    horizon_s: float            # a closest approach later than this is no threat yet
    distance_m: float           # ... nor one that passes farther than this


@dataclass(frozen=True)
class Watch:
    """The mover to look at: its row among the movers, the bearing to it now (the yaw to fly),
    and its predicted closest approach (time from now, distance)."""
    index: int
    bearing_rad: float
    time_to_closest_s: float
    closest_m: float


def threat_to_watch(position_ne_m: np.ndarray, course_rad: float, speed_mps: float,
                    mover_positions: np.ndarray, mover_velocities: np.ndarray,
                    params: LookAtParams) -> Watch | None:
    """The tracked mover the nose should turn to, or None (fly with the nose along the velocity).

    position_ne_m (2,) the vehicle; course_rad, speed_mps the velocity it flies (the chosen one);
    mover_positions, mover_velocities (m, 2) the tracks now.
    """
    if len(mover_positions) == 0:
        return None
    rel = np.asarray(mover_positions, dtype=float) - np.asarray(position_ne_m, dtype=float)
    own = speed_mps * np.array([math.cos(course_rad), math.sin(course_rad)])
    rel_vel = np.asarray(mover_velocities, dtype=float) - own[None, :]
    closing = np.einsum("md,md->m", rel_vel, rel_vel)
    t_ca = np.where(closing > 1e-12,
                    -np.einsum("md,md->m", rel, rel_vel) / np.maximum(closing, 1e-12), 0.0)
    t_ca = np.maximum(t_ca, 0.0)
    closest = np.hypot(*(rel + t_ca[:, None] * rel_vel).T)
    bearing = np.arctan2(rel[:, 1], rel[:, 0])
    unseen = np.abs(wrap_angles(bearing - course_rad)) > 0.5 * params.fov_rad
    distance = np.hypot(rel[:, 0], rel[:, 1])
    closing_in = (t_ca > 0.0) & (t_ca <= params.horizon_s) & (closest <= params.distance_m)
    threat = unseen & (closing_in | (distance <= 0.5 * params.distance_m))
    if not threat.any():
        return None
    candidates = np.flatnonzero(threat)
    k = int(candidates[np.lexsort((closest[candidates], t_ca[candidates]))[0]])
    return Watch(k, float(bearing[k]), float(t_ca[k]), float(closest[k]))


# ------------------------------------------------------------------ the look toward the goal
# Where the nose points while no mover is watched (avoidance.goal_look_deg, off by default). Movers
# that meet the vehicle on its way to the goal hold their bearing from that way; once the velocity
# choice swerves (round a post, a mover), the camera, looking along the flight direction, turns
# away from them by the swerve: a crossing mover 30 to 45 degrees off the way is then 45 to 75
# degrees off the nose, outside a 90 degree view, and passes a few metres behind unseen (issue 16,
# copter traffic seeds 9, 13, 27, 67, 99). So the nose turns back toward the goal's direction by
# ``gain`` times the swerve, at most ``max_offset_rad`` from the flight direction (less than half
# the view: the flight direction stays in view, and ``max_offset_rad`` to spare on the far side is
# what stays of it). Only the yaw: the velocity is the choice's.
# Measured (copter.yaml traffic, 100 runs, seeds 0-99 / 100-199 / 200-299, with the copter
# roll-out of arc.py): gain 1.5 at 20 degrees 0.97 / 0.98 / 0.95, no collision; at 30 degrees
# 0.99 / 0.97 / 0.96 with one collision (seed 281: a crosser 20 to 28 degrees off the course on the
# swerve's side, beyond the 15 degrees of view left past the course). Without the look (before
# the copter roll-out) 0.94 / 0.93 / 0.91; then too, gain 1 at 30 degrees gave one collision (seed 283, after
# a turn of 100 to 130 degrees off the goal that no look reaches). Dense 1.00 and moving 1.00 with
# it (20 degrees).
# What stays: head-on movers tracked but passed at 3 to 9 m (the choice, not the view), and
# crossers 45 to 60 degrees off a course that is straight at the goal (no swerve: no look).
#
# Tried first and left out (copter.yaml traffic, 100 runs, seeds 0-99 unless said; 0.94 without,
# 0.93 on 100-199): a periodic sweep of the nose to the flanks and back whenever a flank 20 to 30
# degrees beyond the view's edge had not been in view for 3 frames within 6 s (flank_scan.py's
# rule, the nose 30 degrees off): 0.76 with 2 collisions (0.86 on 100-199), 0.81 to 0.86 with
# longer looks, and 0.91 / 0.95 as a 15 / 20 degree sweep added to the goal look while on the way.
# Each look to one flank takes the far side of the view off the band (15 to 42 degrees) where
# crossing movers on a collision course are seen, and new ones come into range there.

GOAL_LOOK_MIN_RAD = math.radians(1.0)    # a turn of the nose smaller than this is none


@dataclass(frozen=True)
class GoalLookParams:
    max_offset_rad: float       # the nose at most this far from the flight direction
    gain: float = 1.0           # the nose turns by this times the swerve (the goal's bearing
                                # off the course)

    def __post_init__(self) -> None:
        if not 0.0 < self.max_offset_rad < math.pi:
            raise ValueError(f"max_offset_rad {self.max_offset_rad!r}: expected in (0, pi)")
        if not self.gain > 0.0:
            raise ValueError(f"gain {self.gain!r}: expected > 0")


def goal_look_yaw(course_rad: float, goal_bearing_rad: float,
                  params: GoalLookParams) -> float | None:
    """The yaw to point the nose at while flying ``course_rad`` with the goal at
    ``goal_bearing_rad``, or None (along the course: no swerve, or not finite)."""
    if not (math.isfinite(course_rad) and math.isfinite(goal_bearing_rad)):
        return None
    swerve = wrap_angle(goal_bearing_rad - course_rad)
    turn = max(-params.max_offset_rad, min(params.max_offset_rad, params.gain * swerve))
    if abs(turn) < GOAL_LOOK_MIN_RAD:
        return None
    return wrap_angle(course_rad + turn)
