"""A depth camera's sectors (nearest surface per bin) as landmark observations.

Neighbouring bins that hold a surface, with no jump in range larger than ``max_jump_m`` between
them, form a blob. A blob narrower than ``compact_width_m`` and no deeper than half of it (a
circle's visible surface lies within its radius of its nearest point; a face seen at a grazing
angle is narrow in angle but metres deep) is one obstacle: its centre lies
behind the nearest surface by the radius its angular width implies (a circle of radius R seen from
r_s + R subtends 2 asin(R / (r_s + R)), so R = r_s sin(a) / (1 - sin(a)) for half width a). A
wider blob is a wall, a fence, a building's face: a chain of surface points no further apart than
``chain_spacing_m`` (under the safety distance, so the cones overlap and the wall blocks), each
a ``SurfacePoint`` that says what stretch of surface it stands for (the navigator asks which
landmark covers it, core/perception/surface_cover.py, rather than which one it gates on).

R comes from the bin geometry. Each edge of a blob lies somewhere inside its edge bin (uniform:
increment^2 / 12 each), so a compact blob's centre bearing has variance increment^2 / 24 and its
radius the matching spread; a chain point stands for ``chain_spacing_m`` of surface either side,
an isotropic spread of spacing^2 / 12. The sensor's own per-bin noise adds to both. The
quantisation error is not white: from nearly the same viewpoint the same bins are hit frame
after frame, so the filter would count one error many times. ``correlation_inflation``
multiplies the geometric variances (a choice, 4: sigma doubled; measured on dense sector
worlds, NEES in band on 80% of steps uninflated).
Bearings are bin centres, right positive, from the heading.

Refinements (issue 15, measured on dense and urban sector worlds):
- A compact blob seen across ``fit_min_bins`` bins or more is placed by a least-squares circle
  fit to its surface points, with R from the fit's own covariance: the per-bin range noise is
  white from frame to frame, the width's quantisation is not, so the filter can average the
  fit's error away. The width's estimate stays for narrower blobs and refused fits.
- A compact blob cut by the view's edge or by a nearer thing has a width that lies: it is placed
  by the fit if it fits (points on a circle need no full width), else given as its surface
  points with the chain's loose R (a wall's end beside a turning vehicle must stay in the map;
  leaving cut blobs out, or only those beyond 20 m, measured 0.64 and 0.84 on urban worlds).
- A chain keeps its corners (Douglas-Peucker, ``corner_tolerance_m``) and its real ends (not the
  view's edge, not where something nearer hides it) with the bin's own R, so the safety circles
  reach round a building's corner and a wall's end; the points between them keep the spread.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from companion.core.estimation.slam_types import Observation


@dataclass(frozen=True)
class BlobParams:
    range_sigma_m: float = 0.1            # the sensor's noise per bin (at zero range) ...
    bearing_sigma_rad: float = 0.0
    range_sigma_k_per_m: float = 0.0      # ... growing as k r^2 (stereo, core/estimation/range_noise.py)
    max_jump_m: float = 2.0               # a larger range step between neighbours splits a blob
    compact_width_m: float = 6.0          # the widest post (3 m radius in the random worlds)
    chain_spacing_m: float = 4.0          # a choice: 10 m from two neighbours is sqrt(10^2 - 2^2)
                                          # = 9.80 m from the surface between them (urban worlds,
                                          # 100 runs: 3 m gave the same 0.90, NEES in band 26%
                                          # against 41%, and more landmarks)
    correlation_inflation: float = 4.0
    corner_tolerance_m: float = 0.5      # a choice: 5 sigma of the 0.1 m range noise
    fit_min_bins: int = 5                # a circle fit needs this many bins (3 unknowns + 2 to spare)
    fit_inflation: float = 1.0
    stretch_within_blob: bool = False    # a chain point's spread is no wider than its blob
                                         # (depth perception; the sectors form keeps False)

    def __post_init__(self) -> None:
        if self.chain_spacing_m <= 0 or self.compact_width_m <= 0 or self.max_jump_m <= 0:
            raise ValueError("blob parameters must be > 0")

    def range_var(self, range_m):
        """A bin's range variance at ``range_m`` (floor + k r^2, squared)."""
        return (self.range_sigma_m + self.range_sigma_k_per_m * np.square(range_m)) ** 2


@dataclass(frozen=True)
class SurfacePoint(Observation):
    """A chain point between a long blob's anchors: a sample of a wall's or a face's surface that
    stands for ``stretch_m`` of it (its R, ``meas_cov``, carries that spread); ``own_cov`` is the
    R of the point itself, its bin's. The navigator asks which landmark covers it
    (core/perception/surface_cover.py), not which one it gates on."""
    stretch_m: float = 0.0
    own_cov: tuple | None = None


@dataclass(frozen=True)
class Blob:
    """Bins ``first`` to ``last`` inclusive."""
    first: int
    last: int

    @property
    def bins(self) -> int:
        return self.last - self.first + 1


def sector_centres_rad(count: int, fov_rad: float) -> np.ndarray:
    """Bearings of ``count`` bins across the field of view, each at its centre, (count,)."""
    increment = fov_rad / count
    return -0.5 * fov_rad + increment * (np.arange(count) + 0.5)


def group_bins(ranges_m: np.ndarray, max_jump_m: float) -> list[Blob]:
    """Blobs of neighbouring valid (finite) bins without a range jump above ``max_jump_m``."""
    blobs, start = [], None
    for i, r in enumerate(ranges_m.tolist()):
        if not math.isfinite(r):
            if start is not None:
                blobs.append(Blob(start, i - 1))
                start = None
            continue
        if start is not None and abs(r - ranges_m[i - 1]) > max_jump_m:
            blobs.append(Blob(start, i - 1))
            start = None
        if start is None:
            start = i
    if start is not None:
        blobs.append(Blob(start, len(ranges_m) - 1))
    return blobs


def blob_observations(ranges_m: np.ndarray, bearings_rad: np.ndarray, increment_rad: float,
                      params: BlobParams) -> list[Observation]:
    """Id-less observations, each with its own R, for one frame of sectors: ranges (n,) in metres
    (NaN where nothing was seen) at bin-centre bearings (n,)."""
    out: list[Observation] = []
    for blob in group_bins(ranges_m, params.max_jump_m):
        span = slice(blob.first, blob.last + 1)
        rng, brg = ranges_m[span], bearings_rad[span]
        surface = float(rng.min())
        half = 0.5 * blob.bins * increment_rad
        # compact: narrow, and no deeper than the widest post's radius (a circle's visible
        # surface lies within R of its nearest point; a face seen at a grazing angle is narrow
        # in angle but metres deep: a chain, whose real end gets its own point)
        if 2.0 * surface * math.sin(half) <= params.compact_width_m and half < 0.5 * math.pi \
                and float(rng.max()) - surface <= 0.5 * params.compact_width_m:
            cut = not (_real_end(ranges_m, blob.first, -1) and _real_end(ranges_m, blob.last, 1))
            # A circle fit needs only points on the circle, cut or not; the width does not: a
            # blob cut by the view's edge or a nearer thing has a width (and so a centre) that
            # lies. Without a fit, a cut blob gives its surface points, loose (no corner, no
            # end): they keep a new obstacle in the map without dragging a centre to them.
            fitted = _fitted_circle(rng, brg, surface, half, params, cut)
            if fitted is not None:
                out.append(fitted)
            elif cut:
                out.extend(_chain(rng, brg, increment_rad, params, loose=True))
            else:
                out.append(_compact(surface, float(0.5 * (brg[0] + brg[-1])), half, blob.bins,
                                    increment_rad, params))
        else:
            out.extend(_chain(rng, brg, increment_rad, params,
                              (_real_end(ranges_m, blob.first, -1), _real_end(ranges_m, blob.last, 1))))
    return out


def _compact(surface_m: float, bearing_rad: float, half_rad: float, bins: int,
             increment_rad: float, params: BlobParams) -> Observation:
    sin_a = math.sin(half_rad)
    radius = surface_m * sin_a / (1.0 - sin_a)
    d_radius = surface_m * math.cos(half_rad) / (1.0 - sin_a) ** 2     # dR / da
    edge_var = params.correlation_inflation * increment_rad ** 2 / 24.0   # var of a = width / 2 too
    var_r = float(params.range_var(surface_m)) + d_radius ** 2 * edge_var
    var_b = edge_var + params.bearing_sigma_rad ** 2 / bins
    return Observation(surface_m + radius, bearing_rad, None, ((var_r, 0.0), (0.0, var_b)))


def fit_circle(points: np.ndarray, iterations: int = 8,
               weights: np.ndarray | None = None) -> tuple[np.ndarray, float, np.ndarray]:
    """Least-squares circle through surface points (k, 2), k >= 3: the Kasa (algebraic) fit,
    refined by Gauss-Newton on the distances to the circle. Returns (centre (2,), radius,
    (J^T J)^-1 (3, 3) over [centre, radius], to be scaled by the points' variance). ``weights``
    (k,): each point's inverse variance; the covariance returned is then (J^T W J)^-1 itself."""
    a = np.column_stack((2.0 * points, np.ones(len(points))))
    sol = np.linalg.lstsq(a, np.sum(points * points, axis=1), rcond=None)[0]
    centre = sol[:2]
    radius = math.sqrt(max(float(sol[2] + centre @ centre), 1e-6))
    for _ in range(iterations + 1):
        d = points - centre
        dist = np.maximum(np.hypot(d[:, 0], d[:, 1]), 1e-9)
        jac = np.column_stack((-d / dist[:, None], -np.ones(len(points))))
        if _ == iterations:
            break
        if weights is None:
            step = np.linalg.lstsq(jac, radius - dist, rcond=None)[0]
        else:
            root = np.sqrt(weights)
            step = np.linalg.lstsq(jac * root[:, None], (radius - dist) * root, rcond=None)[0]
        centre, radius = centre + step[:2], radius + float(step[2])
    if weights is None:
        return centre, radius, np.linalg.pinv(jac.T @ jac)
    return centre, radius, np.linalg.pinv(jac.T @ (jac * weights[:, None]))


def _fitted_circle(ranges_m: np.ndarray, bearings_rad: np.ndarray, surface_m: float,
                   half_rad: float, params: BlobParams, cut: bool = False) -> Observation | None:
    """A compact blob's centre by a circle fit to its surface points, R from the fit's own
    covariance (per-bin range noise, white from frame to frame, unlike the width's quantisation);
    None when too few bins or the fit is implausible (not round: a face, a corner)."""
    if len(ranges_m) < params.fit_min_bins or params.range_sigma_m <= 0.0:
        return None
    points = np.column_stack((ranges_m * np.cos(bearings_rad), ranges_m * np.sin(bearings_rad)))
    # a stereo camera's bins are noisier the farther they are: each weighs by its own variance
    weights = 1.0 / params.range_var(ranges_m) if params.range_sigma_k_per_m > 0.0 else None
    try:
        centre, radius, inv = fit_circle(points, weights=weights)
    except np.linalg.LinAlgError:
        return None
    sin_a = math.sin(half_rad)
    # the radius is no more than the width implies (less a cut blob's, whose width is short),
    # and never a flat face's (a huge circle far behind the surface)
    largest = 0.5 * params.compact_width_m
    width_radius = surface_m * sin_a / (1.0 - sin_a)
    bound = largest if cut else min(largest, 2.0 * width_radius + 0.5)
    r = float(np.hypot(*centre))
    if not (math.isfinite(radius) and 0.0 < radius <= bound
            and surface_m < r <= surface_m + 2.0 * radius + 0.5):
        return None
    scale = params.range_sigma_m ** 2 if weights is None else 1.0
    cov_xy = params.fit_inflation * scale * inv[:2, :2]
    jac = np.array([[centre[0] / r, centre[1] / r], [-centre[1] / r ** 2, centre[0] / r ** 2]])
    cov = jac @ cov_xy @ jac.T
    cov[1, 1] += params.bearing_sigma_rad ** 2 / len(ranges_m)
    return Observation(r, float(math.atan2(centre[1], centre[0])), None,
                       ((float(cov[0, 0]), float(cov[0, 1])), (float(cov[1, 0]), float(cov[1, 1]))))


def corner_indices(points: np.ndarray, tolerance_m: float) -> list[int]:
    """The ends and corners of a polyline of surface points (k, 2): Douglas-Peucker, splitting
    where a point lies farther than ``tolerance_m`` from the chord of its run. Sorted indices."""
    keep = {0, len(points) - 1}
    runs = [(0, len(points) - 1)]
    while runs:
        a, b = runs.pop()
        if b - a < 2:
            continue
        chord = points[b] - points[a]
        length = float(np.hypot(*chord))
        rel = points[a + 1:b] - points[a]
        off = (np.abs(rel[:, 0] * chord[1] - rel[:, 1] * chord[0]) / length if length > 0.0
               else np.hypot(rel[:, 0], rel[:, 1]))
        i = int(np.argmax(off))
        if off[i] > tolerance_m:
            keep.add(a + 1 + i)
            runs += [(a, a + 1 + i), (a + 1 + i, b)]
    return sorted(keep)


def _real_end(ranges_m: np.ndarray, edge: int, step: int) -> bool:
    """Whether a blob's edge bin is where the surface really stops: not the edge of the view,
    and the next bin out sees nothing or something farther (not a nearer thing hiding it)."""
    beyond = edge + step
    if not 0 <= beyond < len(ranges_m):
        return False
    return not math.isfinite(ranges_m[beyond]) or ranges_m[beyond] > ranges_m[edge]


def _chain(ranges_m: np.ndarray, bearings_rad: np.ndarray, increment_rad: float,
           params: BlobParams, real_ends: tuple[bool, bool] = (False, False),
           loose: bool = False) -> list[Observation]:
    points = np.column_stack((ranges_m * np.cos(bearings_rad), ranges_m * np.sin(bearings_rad)))
    # The ends (where the wall stops) and the corners (a building's, seen across two faces)
    # always, so the safety circles reach round them; between them, points no further apart
    # than chain_spacing_m along the surface.
    anchors = corner_indices(points, params.corner_tolerance_m)
    picked = [anchors[0]]
    for a, b in zip(anchors, anchors[1:]):
        for i in range(a + 1, b + 1):
            if np.hypot(*(points[i] - points[picked[-1]])) > params.chain_spacing_m:
                picked.append(i - 1 if i - 1 > picked[-1] else i)   # the last one within reach
        if picked[-1] != b:
            picked.append(b)
    # A point between anchors stands for chain_spacing_m of surface either side: spread over it.
    # A corner or a real end is a point of its own, known to its bin: within half a bin either
    # side (increment^2 / 12 in bearing; the range across that bin, (r increment)^2 / 12, as a
    # surface seen edge-on changes range fast). An end at the view's edge or behind something
    # nearer is no end of the surface: spread like the rest.
    fixed = set() if loose else set(anchors[1:-1]) | ({anchors[0]} if real_ends[0] else set()) \
        | ({anchors[-1]} if real_ends[1] else set())
    stretch = params.chain_spacing_m
    if params.stretch_within_blob:
        # a blob narrower than the spacing (a trunk, or its part beside a nearer one) is spread
        # over its own width, not chain_spacing_m of surface: its chord plus one bin at its
        # range (what a landmark covers, ``stretch_m``, stays the chain's: surface_cover.py)
        extent = float(np.hypot(*(points[-1] - points[0]))) \
            + float(np.max(ranges_m)) * increment_rad
        stretch = min(stretch, extent)
    spread = params.correlation_inflation * stretch ** 2 / 12.0
    bin_var = params.correlation_inflation * increment_rad ** 2 / 12.0
    out = []
    for i in picked:
        r = float(ranges_m[i])
        own_r = float(params.range_var(r)) + bin_var * r * r
        own_b = params.bearing_sigma_rad ** 2 + bin_var
        own = ((own_r, 0.0), (0.0, own_b))
        if i in fixed:
            out.append(SurfacePoint(r, float(bearings_rad[i]), None, own, stretch_m=0.0,
                                    own_cov=own))
            continue
        var_r = float(params.range_var(r)) + spread
        var_b = params.bearing_sigma_rad ** 2 + spread / (r * r) + bin_var
        out.append(SurfacePoint(r, float(bearings_rad[i]), None, ((var_r, 0.0), (0.0, var_b)),
                                stretch_m=params.chain_spacing_m,
                                own_cov=own))
    return out


def sector_observations(sectors: tuple, params: BlobParams = BlobParams()) -> list[Observation]:
    """``blob_observations`` of a decoded OBSTACLE_DISTANCE: (ranges_m with NaN where nothing,
    bin-centre bearings_rad, increment_rad), as codec.ObstacleFrame.sectors holds it."""
    ranges_m, bearings_rad, increment_rad = sectors
    return blob_observations(np.asarray(ranges_m, dtype=float), np.asarray(bearings_rad, dtype=float),
                             float(increment_rad), params)
