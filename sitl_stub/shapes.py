"""The stub's own plane geometry of walls and buildings (it never imports ``companion``).

Both are convex polygons: a wall is the rectangle ``thickness_m`` thick around its centre line
(square ends), a building its corners. Outlines are lists of (north_m, east_m), counter-clockwise
with north as x and east as y. Ray casting is Cyrus-Beck clipping against the polygon's
half-planes; the distance to the surface is the nearest point on the outline.
"""
from __future__ import annotations

import math

Outline = list[tuple[float, float]]

DEGENERATE_M = 1e-6


def _cross(ax: float, ay: float, bx: float, by: float) -> float:
    return ax * by - ay * bx


def area_m2(outline: Outline) -> float:
    """Signed (shoelace) area, > 0 counter-clockwise."""
    total = 0.0
    for i, (x0, y0) in enumerate(outline):
        x1, y1 = outline[(i + 1) % len(outline)]
        total += x0 * y1 - x1 * y0
    return 0.5 * total


def counter_clockwise(outline: Outline) -> Outline:
    return list(outline) if area_m2(outline) >= 0.0 else list(reversed(outline))


def outline_problem(outline: Outline) -> str | None:
    """Why ``outline`` (either way round) is no convex polygon, naming the corner (0-based) where
    it shows; None if it is one. Too few corners, a repeated corner, no area, a turn the wrong
    way, or an outline that winds round twice."""
    n = len(outline)
    if n < 3:
        return f"a polygon needs at least 3 corners, got {n}"
    edges = [(outline[(i + 1) % n][0] - outline[i][0], outline[(i + 1) % n][1] - outline[i][1])
             for i in range(n)]
    lengths = [math.hypot(ex, ey) for ex, ey in edges]
    for i, length in enumerate(lengths):
        if length <= DEGENERATE_M:
            return f"corners {i} and {(i + 1) % n} are the same point"
    area = area_m2(outline)
    if abs(area) <= DEGENERATE_M * max(1.0, max(lengths)):
        return "the corners lie on one line (zero area)"
    way = 1.0 if area > 0.0 else -1.0
    winding = 0.0
    for i in range(n):
        (px, py), (ex, ey) = edges[i - 1], edges[i]
        turn = way * _cross(px, py, ex, ey)
        if turn < -DEGENERATE_M * lengths[i - 1] * lengths[i]:
            return f"not convex: the outline turns the other way at corner {i}"
        winding += math.atan2(turn, px * ex + py * ey)
    if abs(winding - 2.0 * math.pi) > 1e-6:
        return "not convex: the outline crosses itself"
    return None


def wall_outline(start: tuple[float, float], end: tuple[float, float],
                 thickness_m: float) -> Outline:
    """The rectangle of a wall from ``start`` to ``end`` (north_m, east_m), counter-clockwise."""
    dx, dy = end[0] - start[0], end[1] - start[1]
    length = math.hypot(dx, dy)
    ox, oy = -dy / length * thickness_m / 2.0, dx / length * thickness_m / 2.0
    return counter_clockwise([(start[0] - ox, start[1] - oy), (end[0] - ox, end[1] - oy),
                              (end[0] + ox, end[1] + oy), (start[0] + ox, start[1] + oy)])


def ray_distance_m(north_m: float, east_m: float, ux: float, uy: float,
                   outline: Outline) -> float:
    """How far along the unit ray (ux, uy) from (north_m, east_m) it first meets the polygon's
    surface (inf: never). From inside, the distance to the way out."""
    t_in, t_out = -math.inf, math.inf
    n = len(outline)
    for i in range(n):
        ax, ay = outline[i]
        bx, by = outline[(i + 1) % n]
        ex, ey = bx - ax, by - ay
        # inside the edge's half-plane: cross(edge, p - a) >= 0; along the ray it changes by
        # cross(edge, u) per metre
        height = _cross(ex, ey, north_m - ax, east_m - ay)
        rate = _cross(ex, ey, ux, uy)
        if rate == 0.0:
            if height < 0.0:
                return math.inf              # parallel and outside this edge: never inside
            continue
        t = -height / rate
        if rate > 0.0:
            t_in = max(t_in, t)              # entering this half-plane
        else:
            t_out = min(t_out, t)            # leaving it
    if t_in > t_out or t_out <= 0.0:
        return math.inf
    return t_in if t_in > 0.0 else t_out


def surface_distance_m(north_m: float, east_m: float, outline: Outline) -> float:
    """Distance from the point to the polygon's surface, negative inside."""
    nearest = math.inf
    inside = True
    n = len(outline)
    for i in range(n):
        ax, ay = outline[i]
        bx, by = outline[(i + 1) % n]
        ex, ey = bx - ax, by - ay
        px, py = north_m - ax, east_m - ay
        if _cross(ex, ey, px, py) < 0.0:
            inside = False
        s = max(0.0, min(1.0, (px * ex + py * ey) / (ex * ex + ey * ey)))
        nearest = min(nearest, math.hypot(px - s * ex, py - s * ey))
    return -nearest if inside else nearest
