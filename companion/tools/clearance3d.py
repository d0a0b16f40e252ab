"""The demo's clearance in 3D (issue 27): a truth record's distance to an obstacle's axis and
to its surface, capped at its top and base, from the scenario's heights.

An obstacle without a height (unbounded) at base 0 gives the 2D figures, bit for bit, so a 2D
world's score is what it was.
"""
from __future__ import annotations

import math

from companion.config.scenario import Scenario


def extents_by_id(scenario: Scenario) -> dict:
    """{id: (base_m, top_m)} of the scenario's obstacles (top inf: unbounded)."""
    return {o.id: (o.base_m, math.inf if o.height_m is None else o.height_m)
            for o in scenario.world.obstacles}


def row_altitude_m(row: dict) -> float | None:
    """The truth record's altitude: the stub's up_m, the autopilot demo's alt_m (None: none)."""
    alt = row.get("up_m", row.get("alt_m"))
    return None if alt is None else float(alt)


def gaps_m(centre_gap_m: float, radius_m: float, altitude_m: float | None,
           extent: tuple[float, float]) -> tuple[float, float]:
    """(to the axis, to the surface) of an obstacle ``centre_gap_m`` away horizontally: over
    its top or under its base the vertical gap joins in (hypot), else the 2D figures."""
    surface = centre_gap_m - radius_m
    if altitude_m is None:
        return centre_gap_m, surface
    base, top = extent
    # no base (on the ground): never under it, whatever a slightly negative altitude says
    over = max(altitude_m - top, base - altitude_m if base > 0.0 else 0.0, 0.0)
    if over <= 0.0:
        return centre_gap_m, surface
    return math.hypot(centre_gap_m, over), math.hypot(max(surface, 0.0), over)
