"""companion simulate's depth camera: vectorised ray casting of the 3D world, and a stereo
camera's errors.

``DepthRenderer.render_m`` casts one ray per pixel from the camera's true pose against vertical
cylinders (posts, trees, movers: a centre, a radius, a base and a top), convex prisms (walls and
buildings: a counter-clockwise footprint, a base and a top) and the ground plane (altitude 0);
the sky gives nothing (inf). It returns the depth along the optical axis (a RealSense's Z16, not
the range along the ray): each pixel's ray is scaled so that its optical z is 1, so the ray
parameter at a hit is the depth itself.

Each object is cast only in the image window its bounding box projects to (the full image when
the box straddles the camera's plane), so the cost follows the pixels objects cover; posts go
nearest first, and a block of a post's window already nearer than the post can be is skipped.

``sensor_errors`` turns true depth into Z16 pixels (uint16 millimetres, 0 = no data) with
Intel's stereo error as noise correlated over patches, the occlusion shadow left of every near
edge (the second imager, to the right, cannot see there), holes, and the valid depth span. Every
error is switchable; the random draws per frame are the same whichever are on, so switching one
does not change another's.

Frames: NED world (north, east, down), the camera's optical frame (x right, y down, z forward);
``world_from_optical`` is the 3x3 rotation taking optical vectors into NED.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from companion.core.perception.depth_frame import DepthIntrinsics
from companion.core.perception.stereo_error import stereo_sigma_z_m

BEHIND_M = 1e-6      # a box corner nearer than this to the camera's plane counts as behind it
CHUNK_PX = 8192      # a post is cast in blocks of whole columns of at most this many pixels


@dataclass(frozen=True)
class Prism:
    """A wall or building: a convex footprint (m, 2) north/east, counter-clockwise, between the
    altitudes base_m and top_m (inf: unbounded)."""
    corners_ne_m: np.ndarray
    base_m: float
    top_m: float


@dataclass(frozen=True)
class DepthScene:
    """What a depth camera can see at one instant. Posts: centres (n, 2) north/east, radii,
    bases and tops (n,) (tops inf: unbounded). The ground is always there, at altitude 0."""
    post_ne_m: np.ndarray
    post_radius_m: np.ndarray
    post_base_m: np.ndarray
    post_top_m: np.ndarray
    prisms: tuple[Prism, ...] = ()

    @classmethod
    def empty(cls) -> "DepthScene":
        z = np.zeros(0)
        return cls(np.zeros((0, 2)), z, z, z)


@dataclass(frozen=True)
class StereoErrors:
    """The errors ``sensor_errors`` applies (config/depth.py's DepthConfig says each one)."""
    baseline_m: float = 0.095
    subpixel: float = 0.08
    depth_noise: bool = True
    noise_patch_px: int = 6
    edge_shadow: bool = True
    shadow_band_px: int | None = None
    dropout_fraction: float = 0.0

    @classmethod
    def none(cls) -> "StereoErrors":
        return cls(depth_noise=False, edge_shadow=False, dropout_fraction=0.0)

    @classmethod
    def of(cls, depth) -> "StereoErrors":
        """From a DepthConfig (sensor.depth)."""
        return cls(depth.baseline_m, depth.subpixel, depth.depth_noise, depth.noise_patch_px,
                   depth.edge_shadow, depth.shadow_band_px, depth.dropout_fraction)


class DepthRenderer:
    """Ray casting for one camera's intrinsics. The pixel grid and every full-image array are
    kept between frames: allocating megabyte arrays anew each frame costs more than the
    arithmetic (the allocator hands the pages back and faults them in again, measured: a
    3 MB sum 0.3 ms in place, 3 to 11 ms allocated)."""

    def __init__(self, intrinsics: DepthIntrinsics) -> None:
        self.intrinsics = intrinsics
        self._x = (np.arange(intrinsics.width_px) - intrinsics.cx_px) / intrinsics.fx_px  # (W,)
        self._y = (np.arange(intrinsics.height_px) - intrinsics.cy_px) / intrinsics.fy_px  # (H,)
        # the longest ray (optical z = 1): a point farther than max depth x this is out of reach
        self._max_ray = math.sqrt(1.0 + max(self._x[0] ** 2, self._x[-1] ** 2)
                                  + max(self._y[0] ** 2, self._y[-1] ** 2))
        # Column-major: every array is (W, H), the image transposed, so the window of a tall
        # thin object (a post: a band of columns, every row) is one contiguous block.
        shape = (intrinsics.width_px, intrinsics.height_px)
        self._depth_t = np.empty(shape)
        # the rays (north, east, up) and scratch
        self._rays = tuple(np.empty(shape) for _ in range(3))
        self._scratch = tuple(np.empty(shape) for _ in range(2))
        self._below = np.empty(shape, dtype=bool)
        # a post's blocks (flat, CHUNK_PX or one whole column if longer)
        chunk = max(CHUNK_PX, intrinsics.height_px)
        self._chunk = tuple(np.empty(chunk) for _ in range(4))
        self._chunk_mask = np.empty(chunk, dtype=bool)

    def render_m(self, world_from_optical: np.ndarray, origin_ned_m: np.ndarray,
                 scene: DepthScene, out: np.ndarray | None = None) -> np.ndarray:
        """(H, W) depth along the optical axis, metres; inf where the ray meets nothing within
        reach (max depth x the longest ray). ``out``: an (H, W) float array to fill (kept by
        the caller between frames: faster), else a new one."""
        intr = self.intrinsics
        m = np.asarray(world_from_optical, dtype=float)
        o = np.asarray(origin_ned_m, dtype=float)
        x, y = self._x[:, None], self._y[None, :]
        dn, de, du = self._rays[:3]
        s1, s2 = self._scratch
        # (W, H) rays, NED: the up component for the floor, north and east for the prisms
        # only (a post makes its own, block by block)
        for k, ray in enumerate((dn, de, du)):
            if k < 2 and not scene.prisms:
                continue
            np.multiply(x, m[k, 0], out=ray)
            np.multiply(y, m[k, 1], out=s1[:1, :])
            ray += s1[:1, :]
            ray += m[k, 2]
        np.negative(du, out=du)                                      # up
        h = -o[2]                                                    # the camera's altitude
        reach = intr.max_depth_m * self._max_ray
        depth = self._depth_t
        depth.fill(np.inf)
        if h > 0.0:
            below = np.less(du, 0.0, out=self._below)
            with np.errstate(divide="ignore", invalid="ignore"):
                np.divide(-h, du, out=s2)
            np.copyto(depth, s2, where=below)
        # nearest first: a block of a farther post wholly behind what is drawn is skipped
        gaps = np.hypot(scene.post_ne_m[:, 0] - o[0], scene.post_ne_m[:, 1] - o[1]) \
            - scene.post_radius_m
        for i in np.argsort(gaps, kind="stable"):
            c = scene.post_ne_m[i]
            r = float(scene.post_radius_m[i])
            base, top = float(scene.post_base_m[i]), float(scene.post_top_m[i])
            lo, hi = max(base, h - reach), min(top, h + reach)
            if lo > hi:
                continue
            box = (c[0] - r, c[0] + r, c[1] - r, c[1] + r, lo, hi)
            win = self._window(m, o, box, reach)
            if win is not None:
                self._cast_post(depth, (win[1], win[0]), m, o, h, c, r, base, top,
                                max(float(gaps[i]), 0.0) / self._max_ray)
        for prism in scene.prisms:
            lo, hi = max(prism.base_m, h - reach), min(prism.top_m, h + reach)
            if lo > hi:
                continue
            cn, ce = prism.corners_ne_m[:, 0], prism.corners_ne_m[:, 1]
            box = (cn.min(), cn.max(), ce.min(), ce.max(), lo, hi)
            win = self._window(m, o, box, reach)
            if win is not None:
                self._cast_prism(depth, self._rays, (win[1], win[0]), o, h, prism)
        if out is None:
            return depth.T.copy()
        np.copyto(out, depth.T)
        return out

    def _window(self, m: np.ndarray, o: np.ndarray, box: tuple, reach: float):
        """The image window (row slice, column slice) the box (n0, n1, e0, e1, up0, up1) can
        cover, or None when it is behind the camera, out of reach or out of the image."""
        n0, n1, e0, e1, u0, u1 = box
        gap = np.array([max(n0 - o[0], 0.0, o[0] - n1), max(e0 - o[1], 0.0, o[1] - e1),
                        max(u0 + o[2], 0.0, -o[2] - u1)])
        if float(np.sqrt(gap @ gap)) > reach:
            return None
        corners = np.array([[n, e, -u] for n in (n0, n1) for e in (e0, e1) for u in (u0, u1)])
        q = (corners - o) @ m                       # optical coordinates of the corners (8, 3)
        intr = self.intrinsics
        if (q[:, 2] <= BEHIND_M).all():
            return None
        if (q[:, 2] <= BEHIND_M).any():
            return slice(0, intr.height_px), slice(0, intr.width_px)
        u = intr.fx_px * q[:, 0] / q[:, 2] + intr.cx_px
        v = intr.fy_px * q[:, 1] / q[:, 2] + intr.cy_px
        c0, c1 = max(int(math.floor(u.min())), 0), min(int(math.ceil(u.max())) + 1, intr.width_px)
        r0, r1 = max(int(math.floor(v.min())), 0), min(int(math.ceil(v.max())) + 1, intr.height_px)
        if c0 >= c1 or r0 >= r1:
            return None
        return slice(r0, r1), slice(c0, c1)

    def _cast_post(self, depth, win, m, o, h, c, r, base, top, nearest_m: float) -> None:
        """A vertical cylinder: its side (from outside) and its top and bottom discs.

        This is the loop that costs (a forest's trees cover the image several times over), so
        it runs on blocks of whole columns of at most CHUNK_PX pixels, every array of a block in
        the cache. The side's entry is t = (b + sqrt(b^2 + A c)) / A with A = -(dn^2 + de^2)
        and b = px dn + py de; the ray (dn, de) is linear in the pixel's (x, y), so b is
        bx(x) + by(y) and A is ax(x) + ay(y) + axy x y, sums of a column and a row term: three
        full-block operations make both. ``nearest_m``: no pixel can see the post nearer than
        this (its horizontal gap over the longest ray): a block already nearer everywhere is
        skipped (occlusion culling; the posts come nearest first)."""
        cols, rows = win
        n = rows.stop - rows.start
        step = max(1, CHUNK_PX // n)
        px, py = o[0] - c[0], o[1] - c[1]
        c2 = px * px + py * py - r * r
        caps = [level for level, facing in ((top, h > top), (base, h < base and base > 0.0))
                if facing and math.isfinite(level)]
        bounded = math.isfinite(top) or base > 0.0
        y = self._y[None, rows]
        (al, be, ga), (de_, ep, ze) = m[0], m[1]          # dn = al x + be y + ga, de likewise
        b_row = (px * be + py * ep) * y
        a_row = -((be * be + ep * ep) * y * y + 2.0 * (be * ga + ep * ze) * y)
        u_row = -m[2, 1] * y                                 # up = -(m20 x + m21 y + m22)
        with np.errstate(divide="ignore", invalid="ignore"):
            for c0 in range(cols.start, cols.stop, step):
                c1 = min(c0 + step, cols.stop)
                view = depth[c0:c1, rows]
                if view.max() < nearest_m:
                    continue
                size = (c1 - c0) * n
                b, big_a, disc, scratch = (buf[:size].reshape(c1 - c0, n)
                                           for buf in self._chunk)
                ok = self._chunk_mask[:size].reshape(c1 - c0, n)
                x = self._x[c0:c1, None]
                if c2 > 0.0:                        # outside the circle: the side, entering
                    np.add((px * al + py * de_) * x + (px * ga + py * ze), b_row, out=b)
                    np.multiply(-2.0 * (al * be + de_ * ep) * x, y, out=big_a)
                    big_a += -((al * al + de_ * de_) * x * x + 2.0 * (al * ga + de_ * ze) * x
                               + (ga * ga + ze * ze))
                    big_a += a_row
                    np.multiply(b, b, out=disc)
                    np.multiply(big_a, c2, out=scratch)
                    disc += scratch
                    b += np.sqrt(disc, out=disc)    # NaN: the ray misses
                    # t > 0 only (b < 0); misses and rejected hits are NaN, which np.fmin skips
                    np.greater_equal(b, 0.0, out=ok)
                    np.divide(b, big_a, out=disc)   # t
                    if bounded:
                        np.add(-(m[2, 0] * x + m[2, 2]), u_row, out=scratch)     # up
                        scratch *= disc             # the hit's height over the camera
                        if math.isfinite(top):
                            ok |= scratch > top - h
                        if base > 0.0:              # (a base on the ground: the ground is nearer)
                            ok |= scratch < base - h
                    np.putmask(disc, ok, np.nan)
                    np.fmin(view, disc, out=view)
                if caps:
                    dn, de, du = (m[k, 0] * x + m[k, 1] * y + m[k, 2] for k in range(3))
                    for level in caps:
                        t = (level - h) / -du
                        qn, qe = px + t * dn, py + t * de
                        cap = (t > 0.0) & (qn * qn + qe * qe <= r * r)
                        np.minimum(view, t, out=view, where=cap)

    @staticmethod
    def _cast_prism(depth, rays, win, o, h, prism: Prism) -> None:
        """A convex prism (Cyrus-Beck): the ray's entry into every side's half-space and the
        slab between base and top; seen from outside only."""
        dn, de, du = (ray[win] for ray in rays[:3])
        t_in = np.zeros(dn.shape)
        t_out = np.full(dn.shape, np.inf)
        corners = prism.corners_ne_m
        with np.errstate(divide="ignore", invalid="ignore"):
            for k in range(len(corners)):
                a, b = corners[k], corners[(k + 1) % len(corners)]
                en, ee = b[0] - a[0], b[1] - a[1]
                height = en * (o[1] - a[1]) - ee * (o[0] - a[0])   # >= 0: inside this side
                rate = en * de - ee * dn
                t = -height / rate
                t_in = np.where(rate > 0.0, np.maximum(t_in, t), t_in)
                t_out = np.where(rate < 0.0, np.minimum(t_out, t), t_out)
                if height < 0.0:
                    t_out = np.where(rate == 0.0, -np.inf, t_out)
            t_base, t_top = (prism.base_m - h) / du, (prism.top_m - h) / du
            t_in = np.maximum(t_in, np.where(du > 0.0, t_base, np.where(du < 0.0, t_top, -np.inf)))
            t_out = np.minimum(t_out, np.where(du > 0.0, t_top, np.where(du < 0.0, t_base, np.inf)))
            if du.size and not prism.base_m <= h <= prism.top_m:
                t_out = np.where(du == 0.0, -np.inf, t_out)
        hit = np.where((t_in <= t_out) & (t_in > 0.0), t_in, np.inf)
        np.minimum(depth[win], hit, out=depth[win])


def occlusion_shadow(depth_m: np.ndarray, fx_px: float, baseline_m: float,
                     band_px: int | None = None, out: np.ndarray | None = None,
                     scratch: tuple[np.ndarray, np.ndarray] | None = None) -> np.ndarray:
    """(H, W) bool: pixels the second imager (baseline_m to the right) cannot see.

    band_px None: the stereo geometry. A pixel u of disparity d_u lands at u - d_u in the second
    image; pixel p is hidden there by a nearer pixel to its right that lands left of it:
    min over u > p of (u - d_u) < p - d_p; and p - d_p < 0 is outside the second image (the
    invalid band down the image's left side). band_px: the band_px pixels left of every step
    toward the camera (depth falling by more than 1% from one pixel to the next).
    ``out``, ``scratch``: (H, W) bool and two (H, W) float arrays to reuse."""
    h, w = depth_m.shape
    cols = np.arange(w, dtype=float)[None, :]
    hidden = np.empty((h, w), dtype=bool) if out is None else out
    s, lowest = scratch if scratch is not None else (np.empty((h, w)), np.empty((h, w)))
    if band_px == 0:
        hidden.fill(False)
        return hidden
    if band_px is None:
        with np.errstate(divide="ignore"):
            np.divide(-fx_px * baseline_m, depth_m, out=s)
        s += cols                                                     # landing column
        np.less(s, 0.0, out=hidden)
    else:
        hidden.fill(False)
        s.fill(np.inf)                                  # a band's start at each step, else inf
        step = depth_m[:, :-1] > depth_m[:, 1:] * 1.01
        np.copyto(s[:, 1:], np.broadcast_to(cols[:, 1:] - band_px, step.shape), where=step)
    # lowest[:, p] = min over u > p of s[:, u]
    np.minimum.accumulate(s[:, :0:-1], axis=1, out=lowest[:, -2::-1])
    lowest[:, -1] = np.inf
    if band_px is None:
        hidden |= lowest < s
    else:
        hidden |= lowest <= cols
    return hidden


class ErrorModel:
    """``sensor_errors`` for one camera, its full-image arrays kept between frames."""

    def __init__(self, intr: DepthIntrinsics, errors: StereoErrors) -> None:
        self.intr, self.errors = intr, errors
        h, w = intr.height_px, intr.width_px
        p = errors.noise_patch_px
        self._grid = (-(-h // p), -(-w // p))
        self._patches = np.empty((self._grid[0] * p, self._grid[1] * p))   # padded
        self._z, self._s1, self._s2 = (np.empty((h, w)) for _ in range(3))
        self._valid, self._mask, self._shadow = (np.empty((h, w), dtype=bool) for _ in range(3))

    def _spread(self, grid: np.ndarray) -> np.ndarray:
        """Each cell of the patch grid over its p x p pixels (a view of the padded buffer)."""
        p = self.errors.noise_patch_px
        gh, gw = self._grid
        np.copyto(self._patches.reshape(gh, p, gw, p), grid[:, None, :, None])
        return self._patches[:self.intr.height_px, :self.intr.width_px]

    def __call__(self, depth_m: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        intr, errors = self.intr, self.errors
        unit = rng.standard_normal(self._grid)
        holes = rng.random(self._grid) < errors.dropout_fraction
        z, valid, mask = self._z, self._valid, self._mask
        np.copyto(z, depth_m)
        with np.errstate(invalid="ignore", over="ignore"):
            if errors.depth_noise:
                sigma = np.multiply(depth_m, depth_m, out=self._s1)
                sigma *= errors.subpixel / (intr.fx_px * errors.baseline_m)
                sigma *= self._spread(unit)
                np.isfinite(depth_m, out=mask)
                np.putmask(sigma, ~mask, 0.0)
                z += sigma
            np.isfinite(z, out=valid)
            valid &= np.greater_equal(z, intr.min_depth_m, out=mask)
            valid &= np.less_equal(z, intr.max_depth_m, out=mask)
        if errors.edge_shadow:
            shadow = occlusion_shadow(depth_m, intr.fx_px, errors.baseline_m,
                                      errors.shadow_band_px, self._shadow, (self._s1, self._s2))
            valid &= ~shadow
        if errors.dropout_fraction > 0.0:
            valid &= self._spread(holes) == 0.0
        np.multiply(z, 1.0 / intr.depth_scale_m, out=z)
        np.putmask(z, ~valid, 0.0)
        np.rint(z, out=z)
        np.clip(z, 0.0, 65535.0, out=z)
        out = z.astype(np.uint16)
        out[valid & (out == 0)] = 1                       # a valid pixel is never "no data"
        return out


def sensor_errors(depth_m: np.ndarray, intr: DepthIntrinsics, errors: StereoErrors,
                  rng: np.random.Generator) -> np.ndarray:
    """True depth (H, W) metres (inf: nothing) -> Z16 pixels (uint16, depth_scale units, 0: no
    data). Draws two patch grids from ``rng`` every frame, whatever is switched on."""
    return ErrorModel(intr, errors)(depth_m, rng)
