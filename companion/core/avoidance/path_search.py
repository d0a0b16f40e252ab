"""A path through a field of mapped obstacles (forests): a grid search whose first leg is flown.

The velocity choice (velocity_choice.py) picks a heading outside every cone from where the
vehicle is. In a forest no straight heading is free over its look-ahead, and the choice of the
moment stalls: it flies away from the goal at cruise, comes back, and does so again (a two-point
cycle, docs/forest.md). Here the decision looks further: a shortest path over the mapped
obstacles to the goal, and the vehicle flies its first leg.

- The grid: square cells of ``cell_m`` in the goal's frame (u along start -> goal, v across), from
  ``back_m`` behind the vehicle to ``ahead_m`` toward the goal (the goal itself if nearer), plus
  ``side_m`` either side. Each cell's clearance is its distance to the nearest obstacle's centre
  minus that obstacle's radius (the safety distance as the velocity choice uses it).
- A cell is free if its clearance is at least ``margin_m``; within ``escape_m`` of a vehicle
  that is inside the margin, cells about as deep as it (a way out). Unmapped space is free: the
  velocity choice's roll-out keeps d from space the camera has not seen.
- Moves to the eight neighbours cost their length times 1 + ``comfort_weight`` x how far the
  cells lie inside ``comfort_m`` of clearance: the path keeps to the middle of a gap.
- Moves within ``turn_reach_m`` of the vehicle cost more the farther they turn from the last
  heading: of two near-equal ways round a tree, the one taken stays taken.
- The goal beyond the grid: every cell on the grid's edge leads to it at the straight-line
  distance (an optimistic guess for the unmapped rest). Dijkstra (scipy.sparse.csgraph) from
  the vehicle's cell.
- The first leg: the farthest point of the path, at most ``carrot_m`` along it, that the vehicle
  sees in a straight line with every sample at least the free clearance; its direction is the
  heading to fly.
- Tight gaps, and not back out (forest-dense, docs/forest.md): cells keeping only
  ``tight_floor_m`` (< margin_m) are free too, their moves costed up to ``tight_weight`` more;
  the clearance the path keeps over its first leg (``PlannedPath.margin_m``) is what the first
  leg and the follower's roll-out must keep then. Beyond the grid, the goal is reached first
  only from edge cells not behind the vehicle (unmapped space is free, behind it too, and in a
  dense forest every cell ahead is costed by the comfort band: the cheapest "path" left the
  grid behind the vehicle, which flew back out of the forest and in again for 200 s); no such
  path: from every edge cell, as before (a dead end is left the way it was entered).
- The cell slack (``cell_slack_m``): a cell short of the need by less than it is free too
  (a gap's middle between the cells' centres), unless the segment between two circles whose
  gap keeps less than the need crosses it: every point of that segment is short of the need.

Why over 400 lines: the kept path's off-path test is written twice, plainly for any points
(``off_path``) and windowed per segment for the grid's cells (``off_path_grid``: a forest
frame's p50 57 -> 15 ms), and the test holds the second to the first bit for bit; side by
side, a change to one is seen in the other.

Pure numpy/scipy; positions north/east metres, headings LOCAL_NED yaw (rad).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import dijkstra

WINDOW_SLACK_M = 1e-3    # off_path_grid's window: far wider than the rounding between a cell's
                         # grid coordinates and its north/east point
ESCAPE_SLACK_M = 0.15    # a way out may cross cells this much deeper than the vehicle is (its
                         # cell's centre is not where it is); the follower's roll-out decides
# the eight neighbours (row, column) and their lengths in cells
_MOVES = ((0, 1), (1, 0), (0, -1), (-1, 0), (1, 1), (1, -1), (-1, 1), (-1, -1))


@dataclass(frozen=True)
class PathParams:
    """How the path is searched (SI units)."""
    cell_m: float = 0.5
    margin_m: float = 0.3         # a free cell keeps d + this from every mapped centre
    comfort_m: float = 1.5        # ... and costs more within d + this
    comfort_weight: float = 2.0
    ahead_m: float = 40.0         # the grid reaches this far toward the goal (the camera's 20 m
    back_m: float = 8.0           # and as much of unmapped space), this far behind the vehicle
    side_m: float = 20.0          # and this far either side of the line to the goal (or up to
    side_max_m: float = 20.0      # this far, to take in the mapped circles beside the grid:
                                  # an edge cell must not lead "straight to the goal" through
                                  # trees already mapped beyond it; forest-dense, seed 0: the
                                  # side edge moved with the vehicle, which shuttled 120 s)
    turn_weight: float = 1.0      # a move within turn_reach_m of the vehicle costs its length
    turn_reach_m: float = 3.0     # times 1 + this x (1 - cos) of its angle to the last heading:
                                  # the path keeps to the side it chose while the map shifts
    escape_m: float = 1.5         # within this of a vehicle inside the margin, cells as deep
                                  # as it may be crossed (the way out)
    tight_floor_m: float | None = 0.1   # cells keeping d + this (< margin_m) are free too, at
    tight_weight: float = 3.0     # a cost: their moves' length times 1 + up to this more (None:
                                  # free only at margin_m). forest-dense's gaps: 1.62-1.76 m
                                  # at best from the trees' centres (seeds 0-9), d + 0.3 = 1.8 m
    keep_weight: float = 0.0      # moves through cells more than keep_width_m from the path
    keep_width_m: float = 1.0     # last followed cost their length times 1 + this more: a new
                                  # way must be that much cheaper over the grid to be taken
                                  # (0: off). Without it, forest-dense's way in flipped between
                                  # two sides as each side's trees were mapped (seed 0: 120 s
                                  # in the clearing, docs/results/speed-limit.md)
    cell_slack_m: float = 0.0     # a cell is free if a point within this of its centre may keep
                                  # the need (its centre keeps need - this): a gap whose middle
                                  # falls between cell centres is not lost to the grid's
                                  # resolution; the first leg and the follower's roll-out keep
                                  # the need itself
    crawl_mps: float | None = None   # path_follow.py: after a quarter of cruise, this slow
    squeeze_m: float | None = None   # along the leg, keeping d + this (None: as fast ones)
    carrot_m: float = 8.0         # the first leg is at most this long (along the path)
    hold_m: float = 0.3           # path_follow.py: ... and must keep d + this (the flight's
                                  # tracking error, a trunk at the view's edge seen late)
    follow_s: float = 1.0         # path_follow.py: a command along the leg is rolled out this
                                  # long, then braked (the path, not the roll-out, looks ahead)


# avoidance.path_steady (choice, measured on forest-dense at 5 m/s, docs/results/speed-limit.md):
# half as much again is more than a newly mapped tree's detour, less than a mapped wall's; 40 m
# takes in what a 20 m camera maps either side of a flight along a barrier; a slack of half a
# cell finds the gaps whose middle falls between the cells' centres (20 worlds: 0.40 -> 0.60
# without it, 0.75 with it), but not a gap between two circles narrower than the need; a crawl
# of 0.5 m/s rolled out 0.55 m in 1 s (a quarter of 5 m/s, 1.6 m: past a tight path's short
# first leg), keeping d + 0.05 m (the search's gaps keep d + 0.1 m at their middle; the straight
# leg crosses them off it). docs/results/speed-limit.md, "Dense forest, stuck in tight gaps".
# A command is rolled out half a second before its stop, not a whole one: five decision
# periods, the next decision brakes for a mapped trunk long before; a trunk not yet mapped is
# the unseen check's, with the perception delay. Held 1 s, 2.5 m/s rolled out 3.75 m, rarely a
# straight line among trunks 2.9 m apart (forest-dense at 5 m/s: 0.85 -> 1.00 on seeds 0-19,
# 0.96 on 100; "Dense forest, the follower's roll-out")
STEADY_PATH = PathParams(keep_weight=0.5, side_max_m=40.0, cell_slack_m=0.25, crawl_mps=0.5,
                         squeeze_m=0.05, follow_s=0.5)


@dataclass(frozen=True)
class PlannedPath:
    """The search's answer. ``points_ne_m`` (k, 2) from the vehicle's cell on (empty: no path);
    ``heading_rad``: toward ``carrot_ne_m``, the first leg's end; ``length_m``: the path's length
    within the grid, ``cost_m`` the search's cost to the goal (edge to goal included)."""
    found: bool
    points_ne_m: np.ndarray
    carrot_ne_m: np.ndarray | None
    heading_rad: float | None
    length_m: float
    cost_m: float
    margin_m: float = 0.0         # the clearance it keeps over its first leg (margin_m, or
                                  # less through tight cells; the follower keeps as much)


def clearance_at(points_ne_m: np.ndarray, obstacles: np.ndarray, radii: np.ndarray) -> np.ndarray:
    """(m,) distance from each point to the nearest obstacle's circle (centre distance - radius);
    +inf without obstacles."""
    if len(obstacles) == 0:
        return np.full(len(points_ne_m), np.inf)
    north = points_ne_m[:, 0][:, None] - obstacles[None, :, 0]
    east = points_ne_m[:, 1][:, None] - obstacles[None, :, 1]
    return (np.hypot(north, east) - radii[None, :]).min(axis=1)


def _clearance_grid(us: np.ndarray, vs: np.ndarray, obstacle_u: np.ndarray,
                    obstacle_v: np.ndarray, radii: np.ndarray, band_m: float) -> np.ndarray:
    """(rows, cols) clearance of each cell (distance to the nearest circle), computed only within
    ``band_m`` of each circle: farther cells read +inf (they are free and cost nothing more)."""
    clear = np.full((len(us), len(vs)), np.inf)
    cell = us[1] - us[0] if len(us) > 1 else 1.0
    for u, v, r in zip(obstacle_u, obstacle_v, radii):
        reach = r + band_m
        r0 = max(int(math.floor((u - reach - us[0]) / cell)), 0)
        r1 = min(int(math.ceil((u + reach - us[0]) / cell)) + 1, len(us))
        c0 = max(int(math.floor((v - reach - vs[0]) / cell)), 0)
        c1 = min(int(math.ceil((v + reach - vs[0]) / cell)) + 1, len(vs))
        if r0 >= r1 or c0 >= c1:
            continue
        local = np.hypot((us[r0:r1] - u)[:, None], (vs[c0:c1] - v)[None, :]) - r
        np.minimum(clear[r0:r1, c0:c1], local, out=clear[r0:r1, c0:c1])
    return clear


def plan_path(start_ne_m: np.ndarray, goal_ne_m: np.ndarray, obstacles: np.ndarray,
              radii: np.ndarray, params: PathParams = PathParams(),
              previous_heading_rad: float | None = None,
              kept_ne_m: np.ndarray | None = None) -> PlannedPath:
    """The cheapest grid path from ``start_ne_m`` toward ``goal_ne_m`` around the ``obstacles``
    (n, 2) with safety radii ``radii`` (n,); see the module docstring. ``previous_heading_rad``:
    the last decision's heading, which moves near the vehicle are charged for turning from;
    ``kept_ne_m`` (k, 2): the path last followed, which moves away from are charged
    ``keep_weight`` more."""
    floor = params.margin_m if params.tight_floor_m is None else params.tight_floor_m
    if params.keep_weight <= 0.0 or kept_ne_m is None or len(kept_ne_m) == 0:
        kept_ne_m = None
    plan = _search(start_ne_m, goal_ne_m, obstacles, radii, params, previous_heading_rad, floor,
                   ahead_only=not goal_inside_grid(start_ne_m, goal_ne_m, params), kept=kept_ne_m)
    if plan.found or goal_inside_grid(start_ne_m, goal_ne_m, params):
        return plan
    return _search(start_ne_m, goal_ne_m, obstacles, radii, params, previous_heading_rad, floor,
                   ahead_only=False, kept=kept_ne_m)


def off_path(points_ne_m: np.ndarray, path_ne_m: np.ndarray, width_m: float) -> np.ndarray:
    """(m,) bool: each point farther than ``width_m`` from every segment of the polyline
    ``path_ne_m`` (k, 2); a single point is a segment of no length."""
    a, ab, length2 = _segments(path_ne_m)
    off = np.ones(len(points_ne_m), dtype=bool)
    for start in range(0, len(a), 64):                   # bounded memory: 64 segments at a time
        off &= _off_segments(points_ne_m, a[start:start + 64], ab[start:start + 64],
                             length2[start:start + 64], width_m)
    return off


def off_path_grid(us: np.ndarray, vs: np.ndarray, centres: np.ndarray, start_ne_m: np.ndarray,
                  axis_u: np.ndarray, axis_v: np.ndarray, path_ne_m: np.ndarray,
                  width_m: float) -> np.ndarray:
    """off_path of a grid's cell centres ``centres`` (rows, cols, 2) at the grid coordinates
    ``us`` x ``vs`` (ascending) along ``axis_u``, ``axis_v`` from ``start_ne_m``, raveled: the
    same answer, bit for bit, each segment tested only on the cells within ``width_m`` of its
    box. (All cells against all segments took 42 ms of a forest frame's 57: ~18000 cells and a
    kept path of ~100 points, benchmarks/forest_scale.py.)"""
    a, ab, length2 = _segments(path_ne_m)
    rel = a - start_ne_m
    ends_u, ends_v = rel @ axis_u, rel @ axis_v
    step_u, step_v = ab @ axis_u, ab @ axis_v
    # a cell centre's grid coordinates and its north/east point agree to rounding (~1e-12 m)
    reach = width_m + WINDOW_SLACK_M
    off = np.ones(centres.shape[:2], dtype=bool)
    for k in range(len(a)):
        u0, u1 = sorted((ends_u[k], ends_u[k] + step_u[k]))
        v0, v1 = sorted((ends_v[k], ends_v[k] + step_v[k]))
        r0, r1 = (int(i) for i in np.searchsorted(us, [u0 - reach, u1 + reach]))
        c0, c1 = (int(i) for i in np.searchsorted(vs, [v0 - reach, v1 + reach]))
        if r0 >= r1 or c0 >= c1:
            continue
        window = centres[r0:r1, c0:c1].reshape(-1, 2)
        off[r0:r1, c0:c1] &= _off_segments(window, a[k:k + 1], ab[k:k + 1], length2[k:k + 1],
                                           width_m).reshape(r1 - r0, c1 - c0)
    return off.ravel()


def _segments(path_ne_m: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A polyline's segments: starts (k, 2), steps (k, 2), squared lengths (k,) (at least
    1e-12); a single point is a segment of no length."""
    a = path_ne_m[:-1] if len(path_ne_m) > 1 else path_ne_m
    b = path_ne_m[1:] if len(path_ne_m) > 1 else path_ne_m
    ab = b - a
    return a, ab, np.maximum((ab * ab).sum(axis=1), 1e-12)


def _off_segments(points: np.ndarray, a: np.ndarray, ab: np.ndarray, length2: np.ndarray,
                  width_m: float) -> np.ndarray:
    """(m,) bool: each point farther than ``width_m`` from each of the segments given."""
    rel = points[:, None, :] - a[None, :, :]
    t = np.clip((rel * ab[None]).sum(axis=2) / length2[None], 0.0, 1.0)
    gap = rel - t[..., None] * ab[None]
    return ((gap * gap).sum(axis=2) > width_m * width_m).all(axis=1)


def goal_inside_grid(start_ne_m: np.ndarray, goal_ne_m: np.ndarray, params: PathParams) -> bool:
    """Whether the grid reaches the goal (else the goal is reached from the grid's edge)."""
    return float(np.hypot(*(np.asarray(goal_ne_m, dtype=float)
                            - np.asarray(start_ne_m, dtype=float)))) <= params.ahead_m


def _search(start_ne_m: np.ndarray, goal_ne_m: np.ndarray, obstacles: np.ndarray,
            radii: np.ndarray, params: PathParams, previous_heading_rad: float | None,
            need: float, ahead_only: bool, kept: np.ndarray | None = None) -> PlannedPath:
    """plan_path with free cells keeping ``need`` (a margin) of clearance; ``ahead_only``: the
    grid's edge leads to the goal only from cells not behind the vehicle; ``kept``: the path
    last followed (cells off it cost ``keep_weight`` more)."""
    start = np.asarray(start_ne_m, dtype=float)
    goal = np.asarray(goal_ne_m, dtype=float)
    to_goal = goal - start
    distance = float(np.hypot(*to_goal))
    axis_u = to_goal / distance if distance > 1e-9 else np.array([1.0, 0.0])
    axis_v = np.array([-axis_u[1], axis_u[0]])
    cell = params.cell_m
    reach = min(distance, params.ahead_m)
    goal_inside = distance <= params.ahead_m
    us = np.arange(-params.back_m, reach + params.back_m * goal_inside + 0.5 * cell, cell)
    side_lo, side_hi = _sides(start, axis_u, axis_v, reach, obstacles, radii, params)
    vs = np.arange(-side_lo, side_hi + 0.5 * cell, cell)
    rows, cols = len(us), len(vs)
    grid_u, grid_v = np.meshgrid(us, vs, indexing="ij")
    centres = start + grid_u[..., None] * axis_u + grid_v[..., None] * axis_v     # (rows, cols, 2)
    flat = centres.reshape(-1, 2)
    # only obstacles whose circle reaches the grid (with the comfort band) count
    span = np.hypot(params.back_m + reach + params.back_m, max(side_lo, side_hi))
    if len(obstacles):
        near = np.hypot(*(obstacles - (start + 0.5 * reach * axis_u)).T) - radii \
            < span + params.comfort_m
        obstacles, radii = obstacles[near], radii[near]
    obstacle_u, obstacle_v = (obstacles - start) @ axis_u, (obstacles - start) @ axis_v
    clear = _clearance_grid(us, vs, obstacle_u, obstacle_v, radii,
                            params.margin_m + params.comfort_m + cell).ravel()
    own = float(clearance_at(start[None, :], obstacles, radii)[0])
    free = clear >= need
    if params.cell_slack_m > 0.0:
        # not across a gap narrower than the need (forest-dense seed 18 at 5 m/s: the slack
        # led through a gap keeping d - 0.04 m, which the follower, keeping d, never entered)
        free |= (clear + params.cell_slack_m >= need) & ~_closed_gaps(
            us, vs, obstacle_u, obstacle_v, radii, need)
    if own < need + cell:
        # a vehicle already inside the margin may leave: near it, cells no deeper than it is
        # (less the grid's resolution: its cell's centre is not where it is)
        around = np.hypot(grid_u, grid_v).ravel() <= params.escape_m
        free |= around & (clear >= min(own, need) - ESCAPE_SLACK_M)
    start_idx = int(np.argmin(np.abs(us))) * cols + int(np.argmin(np.abs(vs)))
    free[start_idx] = True
    inside = np.clip((params.comfort_m - (clear - params.margin_m)) / params.comfort_m, 0.0, 1.0)
    penalty = params.comfort_weight * inside
    if need < params.margin_m:
        # a tight cell (clearance between need and margin_m) costs more, the tighter the more
        penalty = penalty + params.tight_weight * np.clip(
            (params.margin_m - clear) / (params.margin_m - need), 0.0, 1.0)
    if kept is not None:
        penalty = penalty + params.keep_weight * off_path_grid(
            us, vs, centres, start, axis_u, axis_v, kept, params.keep_width_m)
    # the grid's edges: 8-neighbour moves between free cells
    index = np.arange(rows * cols).reshape(rows, cols)
    src, dst, wts = [], [], []
    for dr, dc in _MOVES:
        a = index[max(0, -dr):rows - max(0, dr), max(0, -dc):cols - max(0, dc)].ravel()
        b = index[max(0, dr):rows - max(0, -dr) or None, max(0, dc):cols - max(0, -dc) or None].ravel()
        ok = free[a] & free[b]
        a, b = a[ok], b[ok]
        src.append(a)
        dst.append(b)
        weight = cell * math.hypot(dr, dc) * (1.0 + 0.5 * (penalty[a] + penalty[b]))
        if previous_heading_rad is not None and params.turn_weight > 0.0:
            move = (dr * axis_u + dc * axis_v) / math.hypot(dr, dc)
            turn = 1.0 - (move[0] * math.cos(previous_heading_rad)
                          + move[1] * math.sin(previous_heading_rad))
            close = np.hypot(grid_u.ravel()[a], grid_v.ravel()[a]) <= params.turn_reach_m
            weight = weight * (1.0 + params.turn_weight * turn * close)
        wts.append(weight)
    n = rows * cols
    goal_node = n
    if goal_inside:
        goal_idx = int(np.argmin(np.hypot(*(flat - goal).T)))
        free[goal_idx] = True
        targets, to_goal_m = np.array([goal_idx]), np.array([1e-6])
    else:
        edge = np.zeros((rows, cols), dtype=bool)
        edge[0, :] = edge[-1, :] = edge[:, 0] = edge[:, -1] = True
        if ahead_only:
            edge &= grid_u >= 0.0
        targets = np.flatnonzero(edge.ravel() & free)
        to_goal_m = np.hypot(*(flat[targets] - goal).T) + 1e-6
    src.append(targets)
    dst.append(np.full(len(targets), goal_node))
    wts.append(to_goal_m)
    graph = csr_matrix((np.concatenate(wts), (np.concatenate(src), np.concatenate(dst))),
                       shape=(n + 1, n + 1))
    dist, pred = dijkstra(graph, directed=True, indices=start_idx, return_predecessors=True)
    if not np.isfinite(dist[goal_node]):
        return PlannedPath(False, np.empty((0, 2)), None, None, 0.0, math.inf, need)
    chain = []
    node = int(pred[goal_node])
    while node >= 0 and node != start_idx:
        chain.append(node)
        node = int(pred[node])
    chain.append(start_idx)
    points = flat[np.array(chain[::-1])]
    points[0] = start
    if goal_inside:
        points = np.vstack([points, goal])
    steps = np.hypot(*np.diff(points, axis=0).T)
    # the clearance the path keeps over its first carrot_m (margin_m, less through tight cells)
    cells = np.array(chain[::-1])[1:]
    along = np.cumsum(steps[:len(cells)])
    ahead = clear[cells[along <= params.carrot_m]]
    keeps = float(np.clip(ahead.min(initial=params.margin_m), need, params.margin_m)) \
        if need < params.margin_m else need
    carrot = first_leg(points, steps, obstacles, radii, keeps, min(own, keeps) - ESCAPE_SLACK_M,
                       params)
    heading = math.atan2(carrot[1] - start[1], carrot[0] - start[0]) \
        if np.hypot(*(carrot - start)) > 1e-9 else math.atan2(axis_u[1], axis_u[0])
    return PlannedPath(True, points, carrot, heading, float(steps.sum()), float(dist[goal_node]),
                       keeps)


def _closed_gaps(us: np.ndarray, vs: np.ndarray, obstacle_u: np.ndarray,
                 obstacle_v: np.ndarray, radii: np.ndarray, need: float) -> np.ndarray:
    """(rows x cols,) the cells that a segment between two circles whose gap keeps less than
    ``need`` crosses (sampled every tenth of a cell): every point of such a segment is short of
    the need, whatever the cells' centres read."""
    closed = np.zeros((len(us), len(vs)), dtype=bool)
    if len(radii) < 2:
        return closed.ravel()
    cell = us[1] - us[0] if len(us) > 1 else 1.0
    centres = np.stack([obstacle_u, obstacle_v], axis=1)
    apart = np.hypot(*(centres[:, None, :] - centres[None, :, :]).transpose(2, 0, 1))
    first, second = np.nonzero(np.triu(apart < radii[:, None] + radii[None, :] + 2.0 * need, 1))
    if first.size == 0:
        return closed.ravel()
    samples = int(math.ceil(float(apart[first, second].max()) / (0.1 * cell))) + 1
    t = np.linspace(0.0, 1.0, samples)[None, :, None]
    points = centres[first][:, None, :] + t * (centres[second] - centres[first])[:, None, :]
    rows = np.rint((points[..., 0] - us[0]) / cell).astype(int).ravel()
    cols = np.rint((points[..., 1] - vs[0]) / cell).astype(int).ravel()
    inside = (rows >= 0) & (rows < len(us)) & (cols >= 0) & (cols < len(vs))
    closed[rows[inside], cols[inside]] = True
    return closed.ravel()


def _sides(start: np.ndarray, axis_u: np.ndarray, axis_v: np.ndarray, reach: float,
           obstacles: np.ndarray, radii: np.ndarray, params: PathParams) -> tuple[float, float]:
    """How far the grid reaches either side of the line (right, left; whole cells): ``side_m``,
    or with ``side_max_m`` beyond it, up to that far to take in every mapped circle (and its
    comfort band) beside the grid's length, so that an edge cell's straight line to the goal
    never stands for a way through obstacles already mapped beyond the edge."""
    cell = params.cell_m
    low = high = params.side_m
    if params.side_max_m > params.side_m and len(obstacles):
        u = (obstacles - start) @ axis_u
        v = (obstacles - start) @ axis_v
        pad = radii + params.margin_m + params.comfort_m + cell
        beside = (u >= -params.back_m - pad) & (u <= reach + params.back_m + pad) \
            & (np.abs(v) - pad <= params.side_max_m)
        if beside.any():
            low = max(low, float((pad[beside] - v[beside]).max()))
            high = max(high, float((v[beside] + pad[beside]).max()))
        low, high = min(low, params.side_max_m), min(high, params.side_max_m)
    return cell * math.ceil(low / cell - 1e-9), cell * math.ceil(high / cell - 1e-9)


def first_leg(points: np.ndarray, steps: np.ndarray, obstacles: np.ndarray, radii: np.ndarray,
              need_m: float, escape_need_m: float, params: PathParams) -> np.ndarray:
    """The farthest path point within ``carrot_m`` along the path that the start sees in a
    straight line keeping ``need_m`` of clearance (``escape_need_m`` within ``escape_m`` of the
    start: the way out of a margin it is inside), sampled every half cell; the path's second
    point if none farther."""
    along = np.concatenate([[0.0], np.cumsum(steps)])
    start = points[0]
    best = points[min(1, len(points) - 1)]
    for k in range(1, len(points)):
        if along[k] > params.carrot_m:
            break
        length = float(np.hypot(*(points[k] - start)))
        samples = max(2, int(math.ceil(length / (0.5 * params.cell_m))) + 1)
        line = start + np.linspace(0.0, 1.0, samples)[1:, None] * (points[k] - start)
        near = np.hypot(*(line - start).T) <= params.escape_m
        if clearance_at(line, obstacles, radii).min(initial=np.inf,
                                                    where=~near) < need_m:
            continue
        if near.any() and clearance_at(line[near], obstacles, radii).min() < escape_need_m:
            continue
        best = points[k]
    return best
