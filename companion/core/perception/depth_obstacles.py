"""A depth frame's obstacle points (floor removed) as landmark observations with heights.

The points are binned by bearing from the heading (``bins`` over the camera's horizontal view).
Per bin, the nearest surface: the nearest point with ``min_support`` points of the bin within a
depth band behind it (``surface_band_m`` plus three stereo sigmas; a choice, 8 decimated pixels:
a stray patch of noise, a few pixels of one false match, does not pull a bin in, while a post of
a few metres' height fills dozens at 20 m), placed at the median of the points about it, and its
heights: the highest and lowest of the bin's points within a band about that surface (half
``surface_band_m`` plus three stereo sigmas either side; the largest run of them without a
vertical gap above ``max_gap_m``), with whether any of them lies on the image's top or bottom row (the surface goes on out of the view: that bound is not its own). A
hole in the image is a missing point, nothing more: the bin's other points speak for it.

The bins are then a depth camera's sectors, and core/perception/blobs.py turns them into
observations as it does for the ``sectors`` form: compact blobs (posts) as centres, wider ones
(walls, buildings' faces) as chains of surface points. Each observation then takes the heights
of the bins it stands for: a post's, all of its blob's; a chain point's, its blob's bins within
``chain_spacing_m`` of it along the surface. A post is also reported as centre, radius and
vertical extent (``Post``), for the logs and the comparison with other pipelines.
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from companion.core.estimation.slam_types import Observation
from companion.core.perception.blobs import (BlobParams, SurfacePoint, blob_observations,
                                             group_bins, sector_centres_rad)

KEY_STRIDE_M = 1e4     # a bin's sort key: index x this + horizontal range (ranges below half)


@dataclass(frozen=True)
class BinnedSurface:
    """Per bearing bin (n,): nearest horizontal range (NaN: nothing), its highest and lowest
    point as depths below the vehicle (FRD z), whether those reached the image's top / bottom
    row, and the bin's point count. Bins are centred on ``bearings_rad`` (from the heading,
    right positive), ``increment_rad`` wide."""
    ranges_m: np.ndarray = field(repr=False)
    bearings_rad: np.ndarray = field(repr=False)
    increment_rad: float
    top_down_m: np.ndarray = field(repr=False)
    bottom_down_m: np.ndarray = field(repr=False)
    top_clipped: np.ndarray = field(repr=False)
    bottom_clipped: np.ndarray = field(repr=False)
    counts: np.ndarray = field(repr=False)


@dataclass(frozen=True)
class Post:
    """A compact obstacle: its centre (range, bearing from the heading), radius, and the depths
    below the vehicle of its highest and lowest points seen."""
    range_m: float
    bearing_rad: float
    radius_m: float
    top_down_m: float
    bottom_down_m: float
    top_clipped: bool
    bottom_clipped: bool


def bin_surfaces(xyz_m: np.ndarray, row: np.ndarray, rows: int, centre_rad: float,
                 fov_rad: float, bins: int, params: BlobParams, min_support: int = 8,
                 surface_band_m: float = 0.5, max_gap_m: float = 1.0) -> BinnedSurface:
    """Level points (n, 3) with their image rows (n,) -> the nearest supported surface per
    bearing bin over ``fov_rad`` centred on ``centre_rad`` (the camera's yaw on the body)."""
    increment = fov_rad / bins
    bearings = centre_rad + sector_centres_rad(bins, fov_rad)
    horiz = np.hypot(xyz_m[:, 0], xyz_m[:, 1])
    offset = np.angle(np.exp(1j * (np.arctan2(xyz_m[:, 1], xyz_m[:, 0]) - centre_rad)))
    index = np.floor((offset + 0.5 * fov_rad) / increment).astype(np.int64)
    keep = (index >= 0) & (index < bins) & (horiz > 0.0) & (horiz < KEY_STRIDE_M / 2.0)
    index, horiz, z, row = index[keep], horiz[keep], xyz_m[keep, 2], row[keep]
    key = index * KEY_STRIDE_M + horiz
    order = np.argsort(key, kind="stable")
    key, index, horiz, z, row = key[order], index[order], horiz[order], z[order], row[order]
    band = surface_band_m + 3.0 * np.sqrt(params.range_var(horiz))
    # how many of the bin's points lie within the band behind each point: the first point of a
    # bin with min_support of them is its nearest surface (a speckle before it is passed over)
    support = np.searchsorted(key, key + band, side="right") - np.arange(len(key))
    counts = np.bincount(index, minlength=bins)
    starts = np.concatenate(([0], np.cumsum(counts)[:-1]))
    ranges = np.full(bins, np.nan)
    top, bottom = np.full(bins, np.nan), np.full(bins, np.nan)
    top_cut, bottom_cut = np.zeros(bins, bool), np.zeros(bins, bool)
    nonempty = np.flatnonzero(counts > 0)
    if len(nonempty) == 0:
        return BinnedSurface(ranges, bearings, increment, top, bottom, top_cut, bottom_cut, counts)
    at = starts[nonempty]
    first = np.minimum.reduceat(np.where(support >= min_support, np.arange(len(key)), len(key)),
                                at)
    held = first < at + counts[nonempty]
    bins_held = nonempty[held]
    # The surface's range: the median of the points in its band, twice (the band behind the
    # first supported point, then one centred on that median). The nearest point itself is the
    # low tail of the stereo noise: biased short by one or two sigmas (measured on rendered
    # forests: 0.66 m short at 10 to 15 m), the median of the surface's points is not.
    surface_m = horiz[first[held]]
    base = bins_held * KEY_STRIDE_M
    for lo_sigmas, hi_sigmas in ((0.0, 6.0), (3.0, 3.0)):
        sigma = np.sqrt(params.range_var(surface_m))
        lo = surface_m - lo_sigmas * sigma - (0.5 * surface_band_m if lo_sigmas else 0.0)
        hi = surface_m + hi_sigmas * sigma + (0.5 * surface_band_m if lo_sigmas else surface_band_m)
        i0 = np.searchsorted(key, base + lo, side="left")
        i1 = np.searchsorted(key, base + hi, side="right")
        surface_m = horiz[(i0 + i1 - 1) // 2]
    ranges[bins_held] = surface_m
    near = ranges[index]
    reach = 0.5 * surface_band_m + 3.0 * np.sqrt(params.range_var(near))
    surface = np.abs(horiz - near) <= reach                                  # NaN: False
    _heights(index[surface], z[surface], row[surface], rows, max_gap_m, top, bottom, top_cut,
             bottom_cut)
    empty = np.isnan(ranges)
    top[empty] = bottom[empty] = np.nan
    top_cut[empty] = bottom_cut[empty] = False
    return BinnedSurface(ranges, bearings, increment, top, bottom, top_cut, bottom_cut, counts)


def _heights(index: np.ndarray, z: np.ndarray, row: np.ndarray, rows: int, max_gap_m: float,
             top: np.ndarray, bottom: np.ndarray, top_cut: np.ndarray,
             bottom_cut: np.ndarray) -> None:
    """Each bin's surface points (bin ``index``, depth below ``z``, image ``row``, (m,) each)
    split where two heights next to each other lie more than ``max_gap_m`` apart; the largest
    run is the surface: its highest and lowest point and whether it reaches the image's top or
    bottom row fill the bins' arrays in place. A stray point above a wall's top (a false match
    of a far floor at the wall's range) is a run of its own: it does not lift the wall."""
    if len(z) == 0:
        return
    order = np.argsort(index * KEY_STRIDE_M + z, kind="stable")    # by bin, then height
    index, z, row = index[order], z[order], row[order]
    cut = np.concatenate(([True], (np.diff(index) != 0) | (np.diff(z) > max_gap_m)))
    starts = np.flatnonzero(cut)
    sizes = np.diff(np.append(starts, len(z)))
    run_bin = index[starts]
    best = np.lexsort((-sizes, run_bin))                 # per bin, its largest run first
    first = np.concatenate(([True], np.diff(run_bin[best]) != 0))
    chosen = best[first]
    lo, hi = starts[chosen], starts[chosen] + sizes[chosen] - 1
    bins = run_bin[chosen]
    top[bins], bottom[bins] = z[lo], z[hi]
    top_cut[bins] = np.maximum.reduceat(row == 0, starts)[chosen]
    bottom_cut[bins] = np.maximum.reduceat(row == rows - 1, starts)[chosen]


def surface_observations(binned: BinnedSurface, params: BlobParams
                         ) -> tuple[list[Observation], list[Post]]:
    """The bins' blobs as observations (blobs.py), each with the heights of the bins it stands
    for; and the compact ones as posts."""
    ranges, bearings = binned.ranges_m, binned.bearings_rad
    observations = blob_observations(ranges, bearings, binned.increment_rad, params)
    if not observations:
        return [], []
    blob_of = np.full(len(ranges), -1)
    blobs = group_bins(ranges, params.max_jump_m)
    for k, blob in enumerate(blobs):
        blob_of[blob.first:blob.last + 1] = k
    xy = np.column_stack((ranges * np.cos(bearings), ranges * np.sin(bearings)))
    out, posts = [], []
    for obs in observations:
        i = _nearest_held_bin(obs.bearing_rad, bearings, blob_of)
        blob = blobs[blob_of[i]]
        span = np.arange(blob.first, blob.last + 1)
        if isinstance(obs, SurfacePoint):
            gap = np.hypot(*(xy[span] - xy[i]).T)
            span = span[gap <= max(params.chain_spacing_m, 1e-9)]
        top = float(np.nanmin(binned.top_down_m[span]))
        bottom = float(np.nanmax(binned.bottom_down_m[span]))
        top_cut = bool(binned.top_clipped[span].any())
        bottom_cut = bool(binned.bottom_clipped[span].any())
        obs = replace(obs, top_down_m=top, bottom_down_m=bottom, top_clipped=top_cut,
                      bottom_clipped=bottom_cut)
        out.append(obs)
        if not isinstance(obs, SurfacePoint):
            posts.append(Post(obs.range_m, obs.bearing_rad,
                              max(obs.range_m - float(np.nanmin(ranges[span])), 0.0),
                              top, bottom, top_cut, bottom_cut))
    return out, posts


def _nearest_held_bin(bearing_rad: float, bearings_rad: np.ndarray, blob_of: np.ndarray) -> int:
    """The bin of a blob nearest ``bearing_rad`` (an observation's bearing lies within its own
    blob's span: a chain point on a bin centre, a post's centre between its edges)."""
    held = np.flatnonzero(blob_of >= 0)
    return int(held[np.argmin(np.abs(bearings_rad[held] - bearing_rad))])
