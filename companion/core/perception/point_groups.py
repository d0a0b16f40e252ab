"""One camera frame's 3D points, gathered into one observation per obstacle (pure).

A camera sending OBSTACLE_DISTANCE_3D gives points, one a message. The landmark lifecycle and
the vertical extent (vertical_extent.py) want one observation per obstacle per frame with its
highest and lowest point, so the points of one frame are grouped:

- points with the same obstacle id are one obstacle: the first point's range and bearing (the
  stub sends them all at the obstacle's centre), the top the least depth of them, the bottom
  the greatest;
- id-less points at one horizontal place (within ``SAME_PLACE_M``) are one obstacle likewise
  (a camera that sends one obstacle's points at one x, y without an id); other id-less points
  stay single (a floor return, a false alarm);
- observations without a z (a 2D camera, depth sectors) pass as they are.

The order is the order of each group's first point, so a frame of one point per obstacle comes
out as it went in.
"""
from __future__ import annotations

import math
from dataclasses import replace

from companion.core.estimation.slam_types import Observation

SAME_PLACE_M = 0.05


def group_points(observations: list[Observation]) -> tuple[list[Observation], int]:
    """The frame's observations with each obstacle's points merged; and how many points were
    merged into another (0: every observation was its own)."""
    out: list[Observation] = []
    by_id: dict[int, int] = {}
    merged = 0
    for obs in observations:
        if obs.top_down_m is None or obs.bottom_down_m is None:
            out.append(obs)
            continue
        if obs.obstacle_id is not None:
            at = by_id.get(obs.obstacle_id)
        else:
            at = _same_place(out, obs)
        if at is None:
            if obs.obstacle_id is not None:
                by_id[obs.obstacle_id] = len(out)
            out.append(obs)
            continue
        first = out[at]
        out[at] = replace(first, top_down_m=min(first.top_down_m, obs.top_down_m),
                          bottom_down_m=max(first.bottom_down_m, obs.bottom_down_m),
                          top_clipped=first.top_clipped or obs.top_clipped,
                          bottom_clipped=first.bottom_clipped or obs.bottom_clipped)
        merged += 1
    return out, merged


def _same_place(out: list[Observation], obs: Observation) -> int | None:
    x, y = obs.range_m * math.cos(obs.bearing_rad), obs.range_m * math.sin(obs.bearing_rad)
    for i, other in enumerate(out):
        if other.obstacle_id is not None or other.top_down_m is None:
            continue
        ox = other.range_m * math.cos(other.bearing_rad)
        oy = other.range_m * math.sin(other.bearing_rad)
        if math.hypot(x - ox, y - oy) <= SAME_PLACE_M:
            return i
    return None
