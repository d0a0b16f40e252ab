"""The stub's own depth renderer (sensor.form depth): its own geometry, never the companion's.

Rays are unit vectors in north-east-up; each object gives the range along the ray, and the
depth (Z16: along the optical axis) is range x cos(angle off the axis). Posts (vertical
cylinders, with base and top): the side solved in the horizontal plane (distance along the
horizontal direction, then divided by the ray's horizontal share), the top and bottom discs as
planes. Walls and buildings (convex outlines): every side a vertical rectangle (plane, position
along the side, height), the roof and floor of the footprint as planes with a point-in-polygon
test. The ground: altitude 0. Each object is cast in the image columns and rows its bounding box
projects to (all of the image when the box reaches behind the camera).

Then the stereo camera's errors (docs/depth.md): Intel's RMS sigma_z = z^2 subpixel / (fx
baseline) as one offset per patch of pixels, the occlusion shadow left of near edges, holes,
the valid span; every draw made whatever is switched on.
"""
from __future__ import annotations

import math

import numpy as np

from .depth_config import DepthSpec, Mount

HIDDEN_BEHIND_M = 1e-6


def _rx(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def _ry(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def _rz(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


NED_TO_NEU = np.diag([1.0, 1.0, -1.0])


def camera_axes(roll: float, pitch: float, yaw: float, mount: Mount) -> np.ndarray:
    """3x3 whose columns are the camera's forward, right and down axes in north-east-up."""
    body = _rz(yaw) @ _ry(pitch) @ _rx(roll)                        # body FRD -> NED
    cam = _rz(mount.yaw_rad) @ _ry(mount.pitch_rad) @ _rx(mount.roll_rad)   # camera -> body
    return NED_TO_NEU @ body @ cam


BLOCK_PX = 8192      # objects are cast in blocks of at most this many pixels (in the cache)


class StubRenderer:
    """One camera's pixel rays (kept) and its frame buffers."""

    def __init__(self, spec: DepthSpec) -> None:
        self.spec = spec
        self.cols = (np.arange(spec.width_px) - spec.cx_px) / spec.fx_px
        self.rows = (np.arange(spec.height_px) - spec.cy_px) / spec.fy_px
        norm = np.sqrt(1.0 + self.cols[None, :] ** 2 + self.rows[:, None] ** 2)   # (H, W)
        self.cos_off = 1.0 / norm
        self.reach_per_m = float(norm.max())
        shape = (spec.height_px, spec.width_px)
        self.ray = [np.empty(shape) for _ in range(3)]
        self.horiz = [np.empty(shape) for _ in range(3)]     # north, east, 1 / share
        self.best = np.empty(shape)
        self.out = np.empty(shape)

    def ranges(self, north_m: float, east_m: float, up_m: float, roll: float, pitch: float,
               yaw: float, mount: Mount, posts, outlines) -> np.ndarray:
        """(H, W) depth along the optical axis in metres (inf: nothing within reach), in the
        renderer's own array (the next frame overwrites it). posts: [(north_m, east_m, radius_m, base_m, top_m)]; outlines: [(outline
        counter-clockwise [(n, e)], base_m, top_m)]; tops may be inf."""
        spec = self.spec
        axes = camera_axes(roll, pitch, yaw, mount)
        body = _rz(yaw) @ _ry(pitch) @ _rx(roll)
        o = np.array([north_m, east_m, up_m]) + NED_TO_NEU @ body @ np.array(mount.offset_frd_m)
        for k in range(3):                                                 # unit, NEU
            ray = self.ray[k]
            np.add(axes[k, 0], self.cols[None, :] * axes[k, 1], out=ray)
            ray += self.rows[:, None] * axes[k, 2]
            ray *= self.cos_off
        with np.errstate(divide="ignore", invalid="ignore"):     # (a ray straight down)
            np.divide(1.0, np.hypot(self.ray[0], self.ray[1]), out=self.horiz[2])
            np.multiply(self.ray[0], self.horiz[2], out=self.horiz[0])
            np.multiply(self.ray[1], self.horiz[2], out=self.horiz[1])
        reach = spec.max_depth_m * self.reach_per_m
        best = self.best
        best.fill(np.inf)
        if o[2] > 0.0:
            with np.errstate(divide="ignore"):
                np.divide(-o[2], self.ray[2], out=best)
            np.putmask(best, self.ray[2] >= 0.0, np.inf)
        # nearest first, so that a farther trunk's block wholly behind nearer ranges (no range
        # to it can be shorter than its horizontal gap) is skipped
        for gap, (n, e, r, base, top) in sorted(
                (math.hypot(p[0] - o[0], p[1] - o[1]) - p[2], p) for p in posts):
            box = (n - r, n + r, e - r, e + r, max(base, o[2] - reach), min(top, o[2] + reach))
            window = _columns_rows(spec, axes, o, box, reach)
            for r0, r1, c0, c1 in _blocks(window):
                if best[r0:r1, c0:c1].max() < gap:
                    continue
                _post(best, self.ray, (r0, r1, c0, c1), o, n, e, r, base, top, self.horiz)
        for outline, base, top in outlines:
            ns = [p[0] for p in outline]
            es = [p[1] for p in outline]
            box = (min(ns), max(ns), min(es), max(es), max(base, o[2] - reach),
                   min(top, o[2] + reach))
            window = _columns_rows(spec, axes, o, box, reach)
            for block in _blocks(window):
                _outline(best, self.ray, block, o, outline, base, top)
        np.multiply(best, self.cos_off, out=self.out)
        return self.out


def _blocks(window):
    """The window (r0, r1, c0, c1) cut into blocks of whole rows of <= BLOCK_PX pixels."""
    if window is None:
        return
    r0, r1, c0, c1 = window
    step = max(1, BLOCK_PX // (c1 - c0))
    for row in range(r0, r1, step):
        yield (row, min(row + step, r1), c0, c1)


def render_ranges(spec: DepthSpec, north_m: float, east_m: float, up_m: float, roll: float,
                  pitch: float, yaw: float, mount: Mount, posts, outlines) -> np.ndarray:
    """StubRenderer(spec).ranges(...): one frame with a renderer of its own."""
    return StubRenderer(spec).ranges(north_m, east_m, up_m, roll, pitch, yaw, mount, posts,
                                     outlines)


def _columns_rows(spec: DepthSpec, axes: np.ndarray, o: np.ndarray, box, reach: float):
    n0, n1, e0, e1, z0, z1 = box
    if z0 > z1:
        return None
    dx = max(n0 - o[0], 0.0, o[0] - n1)
    dy = max(e0 - o[1], 0.0, o[1] - e1)
    dz = max(z0 - o[2], 0.0, o[2] - z1)
    if math.sqrt(dx * dx + dy * dy + dz * dz) > reach:
        return None
    pts = np.array([[a, b, c] for a in (n0, n1) for b in (e0, e1) for c in (z0, z1)]) - o
    fwd, right, down = pts @ axes[:, 0], pts @ axes[:, 1], pts @ axes[:, 2]
    if np.all(fwd <= HIDDEN_BEHIND_M):
        return None
    if np.any(fwd <= HIDDEN_BEHIND_M):
        return (0, spec.height_px, 0, spec.width_px)
    u = spec.cx_px + spec.fx_px * right / fwd
    v = spec.cy_px + spec.fy_px * down / fwd
    c0, c1 = max(0, int(math.floor(u.min()))), min(spec.width_px, int(math.ceil(u.max())) + 1)
    r0, r1 = max(0, int(math.floor(v.min()))), min(spec.height_px, int(math.ceil(v.max())) + 1)
    return None if c0 >= c1 or r0 >= r1 else (r0, r1, c0, c1)


def _post(best, ray, window, o, n, e, r, base, top, horiz) -> None:
    """horiz: the rays' horizontal unit directions (north, east) and 1 / their horizontal share,
    kept per frame."""
    r0, r1, c0, c1 = window
    ux, uy, uz = (k[r0:r1, c0:c1] for k in ray)
    view = best[r0:r1, c0:c1]
    wx, wy = n - o[0], e - o[1]
    with np.errstate(divide="ignore", invalid="ignore"):
        if wx * wx + wy * wy > r * r:
            hx, hy, ih = (k[r0:r1, c0:c1] for k in horiz)
            along = hx * wx                          # along the horizontal direction
            along += hy * wy
            s = along * along
            s -= wx * wx + wy * wy - r * r
            np.sqrt(s, out=s)                        # NaN: a miss
            np.subtract(along, s, out=s)             # horizontal distance to the side
            dist = np.multiply(s, ih, out=along)
            side = s > 0.0
            if math.isfinite(top) or base > 0.0:
                z = dist * uz
                if math.isfinite(top):
                    side &= z <= top - o[2]
                if base > 0.0:
                    side &= z >= base - o[2]
            np.putmask(dist, ~side, np.inf)
            np.minimum(view, dist, out=view)
        for level in (top, base):
            if not (math.isfinite(level) and level > 0.0):
                continue
            dist = (level - o[2]) / uz
            px, py = o[0] + dist * ux - n, o[1] + dist * uy - e
            cap = (dist > 0.0) & (px * px + py * py <= r * r)
            np.minimum(view, np.where(cap, dist, np.inf), out=view)


def _outline(best, ray, window, o, outline, base, top) -> None:
    r0, r1, c0, c1 = window
    ux, uy, uz = (k[r0:r1, c0:c1] for k in ray)
    found = np.full(ux.shape, np.inf)
    count = len(outline)
    with np.errstate(divide="ignore", invalid="ignore"):
        for i in range(count):
            (ax, ay), (bx, by) = outline[i], outline[(i + 1) % count]
            ex, ey = bx - ax, by - ay
            det = uy * ex - ux * ey
            rx, ry = ax - o[0], ay - o[1]
            dist = (ry * ex - rx * ey) / det
            s = (ux * ry - uy * rx) / det
            z = o[2] + dist * uz
            face = (dist > 0.0) & (s >= 0.0) & (s <= 1.0) & (z >= base) & (z <= top)
            found = np.where(face & (dist < found), dist, found)
        for level in (top, base):
            if not (math.isfinite(level) and level > 0.0):
                continue
            dist = (level - o[2]) / uz
            px, py = o[0] + dist * ux, o[1] + dist * uy
            inside = dist > 0.0
            for i in range(count):
                (ax, ay), (bx, by) = outline[i], outline[(i + 1) % count]
                inside &= (bx - ax) * (py - ay) - (by - ay) * (px - ax) >= 0.0
            found = np.where(inside & (dist < found), dist, found)
    view = best[r0:r1, c0:c1]
    np.minimum(view, found, out=view)


def shadow_mask(depth_m: np.ndarray, spec: DepthSpec) -> np.ndarray:
    """Pixels the right imager cannot see: hidden behind a nearer pixel to their right in its
    image (its column minus its disparity falls left of theirs), or out of its view."""
    height, width = depth_m.shape
    u = np.arange(width, dtype=float)
    if spec.shadow_band_px is not None:
        band = spec.shadow_band_px
        hidden = np.zeros(depth_m.shape, dtype=bool)
        edge = np.zeros(depth_m.shape, dtype=bool)
        edge[:, 1:] = depth_m[:, :-1] > 1.01 * depth_m[:, 1:]
        for k in range(1, band + 1):                       # a fixed band: k pixels left
            hidden[:, :-k] |= edge[:, k:]
        return hidden
    with np.errstate(divide="ignore"):
        landing = u[None, :] - spec.fx_px * spec.baseline_m / depth_m
    # the lowest landing of the pixels to each one's right (a running minimum, right to left)
    right = np.full((height, width), np.inf)
    right[:, :-1] = np.minimum.accumulate(landing[:, :0:-1], axis=1)[:, ::-1]
    return (landing < 0.0) | (right < landing)


def to_z16(depth_m: np.ndarray, spec: DepthSpec, rng: np.random.Generator) -> np.ndarray:
    """True depth -> uint16 millimetres (0: no data) with the configured errors. Worked in
    bands of whole patch rows of about BLOCK_PX pixels (small arrays, in the cache)."""
    height, width = depth_m.shape
    p = spec.noise_patch_px
    gh, gw = (height + p - 1) // p, (width + p - 1) // p
    offsets = rng.standard_normal((gh, gw))
    holes = rng.random((gh, gw)) < spec.dropout_fraction
    out = np.empty((height, width), dtype=np.uint16)
    k = spec.subpixel / (spec.fx_px * spec.baseline_m)
    band = p * max(1, BLOCK_PX // (width * p))
    for r0 in range(0, height, band):
        r1 = min(r0 + band, height)
        cells = slice(r0 // p, (r1 + p - 1) // p)
        true_m = depth_m[r0:r1]
        finite = np.isfinite(true_m)
        z = np.where(finite, true_m, 0.0)
        if spec.depth_noise:
            per_pixel = np.repeat(np.repeat(offsets[cells], p, axis=0), p, axis=1)
            z += z * z * k * per_pixel[:r1 - r0, :width]
        keep = finite & (z >= spec.min_depth_m) & (z <= spec.max_depth_m)
        if spec.edge_shadow:
            keep &= ~shadow_mask(true_m, spec)
        if spec.dropout_fraction > 0.0:
            keep &= ~np.repeat(np.repeat(holes[cells], p, axis=0), p, axis=1)[:r1 - r0, :width]
        units = np.clip(np.round(z / spec.depth_scale_m), 1, 65535)
        out[r0:r1] = np.where(keep, units, 0)
    return out
