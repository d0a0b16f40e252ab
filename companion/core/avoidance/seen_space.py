"""The space the camera has looked at: a coarse grid, for stopping inside what has been seen.

The velocity choice caps the speed so that the vehicle stops d short of the camera's range
(union.sensed_speed_limit), which holds flying straight. Turning hard at speed, the path swings
into space the 90 degree camera has not looked at yet: an obstacle there shows up 15 to 20 m
off, with no room left to stop (dense worlds at 10 and 15 m/s passed posts at 8.3 and 9.4 m
so). Here every camera frame marks the cells of its field of view (range and angle, occlusion
ignored) as seen, and ``margin`` tells how far points are from the nearest cell never seen:
a command is flyable only if, flown for the time a new obstacle takes to enter the decision and
then braked to a stop, it keeps d from unseen space (velocity_choice.py).

Seen is not yet mapped: an obstacle first in view at a frame stays out of the decision for the
perception delay (tentative until confirmed). With ``recent_s`` (that delay) the grid keeps its
state as of each frame of the last ``recent_s`` (``views``), and a command must also keep d, flown
for the latency less the frame's age, from what had not been seen by then (speed_limit.py): a
trunk in space swept a frame before, not yet mapped, was passed at 0.94 d (forest-near at 10 m/s,
seed 7).

Pure numpy and scipy; positions north/east metres, angles radians.
"""
from __future__ import annotations

import math
from collections import deque

import numpy as np
from scipy.ndimage import distance_transform_edt

from companion.core.geometry import wrap_angle

CELL_M = 2.0
GROW_CELLS = 64                  # the grid grows by at least this many cells when it must


class SeenGrid:
    """The grid as of one frame: ``margin`` of points from the cells not seen by then."""

    def __init__(self, origin: np.ndarray, seen: np.ndarray, cell_m: float,
                 field: np.ndarray | None) -> None:
        self.origin, self.seen, self.cell_m, self.field = origin, seen, cell_m, field

    def margin(self, points_ne_m: np.ndarray) -> np.ndarray:
        """(...,) each point's distance (m) to the nearest cell not seen; 0 in unseen cells and
        outside the grid."""
        if self.seen.size == 0:
            return np.zeros(points_ne_m.shape[:-1])
        if self.field is None:
            # distance from each seen cell's centre to the nearest unseen cell's edge
            padded = np.pad(self.seen, 1)
            self.field = distance_transform_edt(padded)[1:-1, 1:-1] * self.cell_m \
                - 0.5 * self.cell_m
        index = np.floor((points_ne_m - self.origin) / self.cell_m).astype(int)
        inside = (index >= 0).all(axis=-1) & (index < np.array(self.seen.shape)).all(axis=-1)
        clipped = np.clip(index, 0, np.array(self.seen.shape) - 1)
        values = self.field[clipped[..., 0], clipped[..., 1]]
        return np.where(inside, np.maximum(values, 0.0), 0.0)


class SeenSpace:
    """Cells the camera has had in view. ``margin`` answers in metres."""

    def __init__(self, fov_rad: float, range_m: float, cell_m: float = CELL_M,
                 keep_m: float | None = None, recent_s: float | None = None) -> None:
        """``keep_m`` (None: keep everything): cells farther than this from the camera (along
        either axis) are forgotten, as never seen, whenever the grid has grown to twice that
        box: the grid, and the distance transform every frame, stay bounded on a long route (a
        forgotten cell only lowers the margin of points near it, never raises one).
        ``recent_s`` (None: none kept): the grid as of each frame, marked with its time, of the
        last recent_s before the latest frame is kept (``views``)."""
        self.fov_rad = fov_rad
        self.range_m = range_m
        self.cell_m = cell_m
        self.keep_m = keep_m
        self.recent_s = recent_s
        self._origin = np.zeros(2)                     # world position of cell (0, 0)'s corner
        self._seen = np.zeros((0, 0), dtype=bool)
        self._now: SeenGrid | None = None              # the grid as of the latest mark
        self._t_s: float | None = None                 # the latest frame's time
        self._frames: deque[tuple[float, SeenGrid]] = deque()   # older frames', oldest first

    def views(self) -> list[tuple[float, SeenGrid]]:
        """(age s, grid): the grid now (age 0), then as of each kept frame, newest first, with
        its age behind the latest frame."""
        older = [(self._t_s - t_s, grid) for t_s, grid in reversed(self._frames)]
        return [(0.0, self._grid())] + older

    def mark(self, pose: np.ndarray, t_s: float | None = None) -> None:
        """One camera frame from ``pose`` (north, east, yaw): its field of view is seen. ``t_s``:
        the frame's time (kept with ``recent_s``; the cameras of one frame share it)."""
        if self.recent_s is not None and t_s is not None:
            self._keep_frame(t_s)
        x, y, yaw = float(pose[0]), float(pose[1]), float(pose[2])
        r, cell = self.range_m, self.cell_m
        self._cover(np.array([x - r, y - r]), np.array([x + r, y + r]))
        # In Python floats, the same operations as on arrays of two (the same bits, less
        # dispatch); the cells' offsets as a column and a row, broadcast rather than meshed.
        ox, oy = float(self._origin[0]), float(self._origin[1])
        lo_i, lo_j = math.floor((x - r - ox) / cell), math.floor((y - r - oy) / cell)
        hi_i, hi_j = math.ceil((x + r - ox) / cell), math.ceil((y + r - oy) / cell)
        lo_i, hi_i, lo_j, hi_j = self._view_box(x, y, yaw, (lo_i, hi_i, lo_j, hi_j))
        dx = (ox + (np.arange(lo_i, hi_i) + 0.5) * cell - x)[:, None]
        dy = (oy + (np.arange(lo_j, hi_j) + 0.5) * cell - y)[None, :]
        dist = np.hypot(dx, dy)
        off = np.abs(np.remainder(np.arctan2(dy, dx) - yaw + math.pi, 2 * math.pi) - math.pi)
        # a cell counts once its centre is in view, or it holds the camera itself
        view = (dist <= r) & ((off <= 0.5 * self.fov_rad) | (dist <= cell))
        self._seen[lo_i:hi_i, lo_j:hi_j] |= view
        self._now = None
        if self.keep_m is not None:
            self._forget_far(np.array([x, y]))

    def _keep_frame(self, t_s: float) -> None:
        """Before a new frame's first mark: keep the grid as of the frame before (its cells
        are marked into a copy from now on), and forget frames recent_s older than this."""
        if self._t_s is not None and t_s != self._t_s:
            self._frames.append((self._t_s, self._grid()))
            self._seen = self._seen.copy()
            self._now = None
        self._t_s = t_s
        while self._frames and t_s - self._frames[0][0] >= self.recent_s:
            self._frames.popleft()

    def _view_box(self, x: float, y: float, yaw: float,
                  box: tuple[int, int, int, int]) -> tuple[int, int, int, int]:
        """The part of ``box`` (cell indices lo_i, hi_i, lo_j, hi_j: the square of the camera's
        range) where a cell can be in view from (x, y, yaw): the bounding box of the view's
        sector, the camera included, widened by a cell each way (the cells that hold the camera;
        rounding is many orders smaller). Every cell left out would be marked False, so the same
        cells are marked; at 90 degrees the arrays mark computes are under half the size."""
        half = 0.5 * self.fov_rad
        if half >= math.pi:
            return box
        low_n, high_n, low_e, high_e = _sector_extent(yaw, half)
        r, cell = self.range_m, self.cell_m
        ox, oy = float(self._origin[0]), float(self._origin[1])
        return (max(box[0], math.floor((x + r * low_n - cell - ox) / cell)),
                min(box[1], math.ceil((x + r * high_n + cell - ox) / cell)),
                max(box[2], math.floor((y + r * low_e - cell - oy) / cell)),
                min(box[3], math.ceil((y + r * high_e + cell - oy) / cell)))

    def _forget_far(self, position: np.ndarray) -> None:
        """Crop the grid to the cells within keep_m of ``position`` once it spans more than
        twice that (amortised: a crop per keep_m flown at most)."""
        limit = 2.0 * (2.0 * self.keep_m / self.cell_m) + 2 * GROW_CELLS
        if max(self._seen.shape) <= limit:
            return
        lo = np.floor((position - self.keep_m - self._origin) / self.cell_m).astype(int)
        hi = np.ceil((position + self.keep_m - self._origin) / self.cell_m).astype(int)
        lo = np.maximum(lo, 0)
        hi = np.minimum(hi, np.array(self._seen.shape))
        self._seen = self._seen[lo[0]:hi[0], lo[1]:hi[1]].copy()
        self._origin = self._origin + lo * self.cell_m

    def _cover(self, low: np.ndarray, high: np.ndarray) -> None:
        """Grow the grid so that it holds the box low..high (world metres)."""
        if self._seen.size == 0:
            self._origin = np.floor(low / self.cell_m) * self.cell_m - GROW_CELLS * self.cell_m
            n = int(math.ceil((high - low).max() / self.cell_m)) + 2 * GROW_CELLS
            self._seen = np.zeros((n, n), dtype=bool)
            return
        shape = np.array(self._seen.shape)
        lo = np.floor((low - self._origin) / self.cell_m).astype(int)
        hi = np.ceil((high - self._origin) / self.cell_m).astype(int)
        if lo[0] >= 0 and lo[1] >= 0 and hi[0] <= shape[0] and hi[1] <= shape[1]:
            return                        # inside already: most frames
        pad_lo = np.where(lo < 0, -lo + GROW_CELLS, 0)
        pad_hi = np.where(hi > shape, hi - shape + GROW_CELLS, 0)
        if pad_lo.any() or pad_hi.any():
            self._seen = np.pad(self._seen, ((pad_lo[0], pad_hi[0]), (pad_lo[1], pad_hi[1])))
            self._origin = self._origin - pad_lo * self.cell_m

    def margin(self, points_ne_m: np.ndarray) -> np.ndarray:
        """(...,) each point's distance (m) to the nearest cell never seen; 0 in unseen cells
        and outside the grid."""
        return self._grid().margin(points_ne_m)

    def _grid(self) -> SeenGrid:
        """The grid as of the latest mark (its distance field computed once, when asked)."""
        if self._now is None:
            self._now = SeenGrid(self._origin, self._seen, self.cell_m, None)
        return self._now


def _sector_extent(yaw_rad: float, half_rad: float) -> tuple[float, float, float, float]:
    """The bounding box of a unit-radius sector (its apex at the origin, its arc yaw +- half)
    as (low north, high north, low east, high east): the apex, the arc's ends, and the axis
    directions within the arc, where north or east peaks."""
    angles = [yaw_rad - half_rad, yaw_rad + half_rad]
    angles += [axis for axis in (0.0, 0.5 * math.pi, math.pi, -0.5 * math.pi)
               if abs(wrap_angle(axis - yaw_rad)) <= half_rad]
    norths = [0.0] + [math.cos(a) for a in angles]
    easts = [0.0] + [math.sin(a) for a in angles]
    return min(norths), max(norths), min(easts), max(easts)
