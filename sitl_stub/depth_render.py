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


def render_ranges(spec: DepthSpec, north_m: float, east_m: float, up_m: float, roll: float,
                  pitch: float, yaw: float, mount: Mount, posts, outlines) -> np.ndarray:
    """(H, W) depth along the optical axis in metres (inf: nothing within reach).

    posts: [(north_m, east_m, radius_m, base_m, top_m)]; outlines: [(outline counter-clockwise
    [(n, e)], base_m, top_m)]; tops may be inf."""
    axes = camera_axes(roll, pitch, yaw, mount)
    body = _rz(yaw) @ _ry(pitch) @ _rx(roll)
    off = NED_TO_NEU @ body @ np.array(mount.offset_frd_m)
    o = np.array([north_m, east_m, up_m]) + off
    cols = (np.arange(spec.width_px) - spec.cx_px) / spec.fx_px
    rows = (np.arange(spec.height_px) - spec.cy_px) / spec.fy_px
    norm = np.sqrt(1.0 + cols[None, :] ** 2 + rows[:, None] ** 2)           # (H, W)
    cos_off = 1.0 / norm
    ray = [(axes[k, 0] + axes[k, 1] * cols[None, :] + axes[k, 2] * rows[:, None]) * cos_off
           for k in range(3)]                                              # unit, NEU
    reach = spec.max_depth_m * float(norm.max())
    best = np.full((spec.height_px, spec.width_px), np.inf)
    if o[2] > 0.0:
        with np.errstate(divide="ignore", invalid="ignore"):
            best = np.where(ray[2] < 0.0, o[2] / -ray[2], np.inf)
    for n, e, r, base, top in posts:
        box = (n - r, n + r, e - r, e + r, max(base, o[2] - reach), min(top, o[2] + reach))
        window = _columns_rows(spec, axes, o, box, reach)
        if window is not None:
            _post(best, ray, window, o, n, e, r, base, top)
    for outline, base, top in outlines:
        ns = [p[0] for p in outline]
        es = [p[1] for p in outline]
        box = (min(ns), max(ns), min(es), max(es), max(base, o[2] - reach), min(top, o[2] + reach))
        window = _columns_rows(spec, axes, o, box, reach)
        if window is not None:
            _outline(best, ray, window, o, outline, base, top)
    return best * cos_off


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


def _post(best, ray, window, o, n, e, r, base, top) -> None:
    r0, r1, c0, c1 = window
    ux, uy, uz = (k[r0:r1, c0:c1] for k in ray)
    found = np.full(ux.shape, np.inf)
    wx, wy = n - o[0], e - o[1]
    with np.errstate(divide="ignore", invalid="ignore"):
        if wx * wx + wy * wy > r * r:
            horiz = np.hypot(ux, uy)
            along = (wx * ux + wy * uy) / horiz
            miss2 = wx * wx + wy * wy - along * along
            s = along - np.sqrt(r * r - miss2)
            dist = s / horiz
            z = o[2] + dist * uz
            side = (miss2 <= r * r) & (s > 0.0) & (z >= base) & (z <= top)
            found = np.where(side, dist, found)
        for level in (top, base):
            if not (math.isfinite(level) and level > 0.0):
                continue
            dist = (level - o[2]) / uz
            px, py = o[0] + dist * ux - n, o[1] + dist * uy - e
            cap = (dist > 0.0) & (px * px + py * py <= r * r)
            found = np.where(cap & (dist < found), dist, found)
    view = best[r0:r1, c0:c1]
    np.minimum(view, found, out=view)


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
    hidden = landing < 0.0
    lowest = np.full(height, np.inf)
    for col in range(width - 1, -1, -1):                   # right to left, the lowest landing
        hidden[:, col] |= lowest < landing[:, col]
        np.minimum(lowest, landing[:, col], out=lowest)
    return hidden


def to_z16(depth_m: np.ndarray, spec: DepthSpec, rng: np.random.Generator) -> np.ndarray:
    """True depth -> uint16 millimetres (0: no data) with the configured errors."""
    height, width = depth_m.shape
    p = spec.noise_patch_px
    gh, gw = (height + p - 1) // p, (width + p - 1) // p
    offsets = rng.standard_normal((gh, gw))
    holes = rng.random((gh, gw)) < spec.dropout_fraction
    patch_rows = np.arange(height) // p
    patch_cols = np.arange(width) // p
    z = depth_m.copy()
    finite = np.isfinite(z)
    if spec.depth_noise:
        sigma = z[finite] ** 2 * spec.subpixel / (spec.fx_px * spec.baseline_m)
        z[finite] += sigma * offsets[patch_rows[:, None], patch_cols[None, :]][finite]
    keep = finite & (z >= spec.min_depth_m) & (z <= spec.max_depth_m)
    if spec.edge_shadow:
        keep &= ~shadow_mask(depth_m, spec)
    if spec.dropout_fraction > 0.0:
        keep &= ~holes[patch_rows[:, None], patch_cols[None, :]]
    out = np.zeros(depth_m.shape, dtype=np.uint16)
    out[keep] = np.clip(np.round(z[keep] / spec.depth_scale_m), 1, 65535).astype(np.uint16)
    return out
