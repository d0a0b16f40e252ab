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

Pure numpy; positions north/east metres, headings LOCAL_NED yaw (rad).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from companion.core.geometry import wrap_angles


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
