"""A depth image's pixels as points in the vehicle's local level frame. Pure, vectorised.

The local level frame: centred on the vehicle, x forward along the heading (level, not along the
tilted nose), y right, z down (FRD with roll and pitch taken out, the yaw kept: bearings measured
in it are bearings from the heading, as the EKF-SLAM's observations are). A pixel (u, v) of depth
z (along the optical axis) is the optical point ((u - cx) z / fx, (v - cy) z / fy, z), turned into
the body by the camera's mount, moved by the mount's offset, then levelled by the vehicle's roll
and pitch (ATTITUDE's, at capture): level = Ry(pitch) Rx(roll) body.

Decimation (a choice): each ``factor`` x ``factor`` block gives its nearest valid depth, at the
block's centre ray. The nearest, not the mean or the median: a mean across a depth edge invents a
surface between the two, a median of a block half hole half surface may drop the surface; the
nearest is never farther than what is there. The bearing error is at most half a block
(factor / 2 px: 0.26 deg at factor 4 on a D455's 848 px). A block with no valid pixel is a hole;
one hole pixel blanks nothing (the block's other pixels stand in for it).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from companion.core.perception.depth_frame import (CameraMount, DepthIntrinsics, FRD_FROM_OPTICAL,
                                                   rotation_zyx)

NO_DATA = np.uint16(0)
_FAR = np.uint16(0xFFFF)


@dataclass(frozen=True)
class LevelPoints:
    """A frame's valid points. ``xyz_m`` (n, 3): local level frame (x forward along the heading,
    y right, z down, metres, from the vehicle's centre); ``row`` (n,): each point's row in the
    (decimated) image, for the view's edges; ``rows``: the image's row count; ``holes``: blocks
    without a valid depth (or outside [min_depth, max_depth]); ``depth_m`` (n,): each point's
    depth along the optical axis (its stereo error's argument)."""
    xyz_m: np.ndarray = field(repr=False)
    row: np.ndarray = field(repr=False)
    rows: int
    holes: int
    depth_m: np.ndarray = field(repr=False)

    @property
    def count(self) -> int:
        return int(self.xyz_m.shape[0])

    def take(self, keep: np.ndarray) -> "LevelPoints":
        """The points where ``keep`` (n,) bool is set."""
        return LevelPoints(self.xyz_m[keep], self.row[keep], self.rows, self.holes,
                           self.depth_m[keep])


def decimate_nearest(depth: np.ndarray, factor: int) -> np.ndarray:
    """Z16 pixels (H, W) uint16 (0 = no data) -> (H // f, W // f) uint16: each block's nearest
    valid pixel, 0 where the block has none. The last rows and columns that do not fill a block
    are dropped. factor 1: the image as it is."""
    if factor < 1:
        raise ValueError(f"decimation factor must be >= 1, got {factor}")
    if factor == 1:
        return depth
    h, w = depth.shape[0] // factor, depth.shape[1] // factor
    blocks = depth[:h * factor, :w * factor]
    far = np.where(blocks == NO_DATA, _FAR, blocks)
    near = far.reshape(h, factor, w, factor).min(axis=3).min(axis=1)   # (faster than both at once)
    return np.where(near == _FAR, NO_DATA, near)


def decimated_intrinsics(intr: DepthIntrinsics, factor: int) -> DepthIntrinsics:
    """The intrinsics of ``decimate_nearest``'s image: block (i, j) at the original pixels'
    centre (f j + (f - 1) / 2, f i + (f - 1) / 2)."""
    if factor == 1:
        return intr
    half = 0.5 * (factor - 1)
    return DepthIntrinsics(intr.width_px // factor, intr.height_px // factor,
                           intr.fx_px / factor, intr.fy_px / factor, (intr.cx_px - half) / factor,
                           (intr.cy_px - half) / factor, intr.min_depth_m, intr.max_depth_m,
                           intr.depth_scale_m)


def level_from_frd(roll_rad: float, pitch_rad: float) -> np.ndarray:
    """3x3: a body FRD vector in the local level frame (the vehicle's yaw left out)."""
    return rotation_zyx(roll_rad, pitch_rad, 0.0)


def level_points(depth: np.ndarray, intr: DepthIntrinsics, mount: CameraMount,
                 roll_rad: float, pitch_rad: float) -> LevelPoints:
    """Z16 pixels (H, W) with their intrinsics (already decimated, if so) -> the valid points in
    the local level frame. Depths outside [min_depth_m, max_depth_m] count as holes."""
    z = depth.astype(np.float32) * np.float32(intr.depth_scale_m)
    valid = (depth != NO_DATA) & (z >= intr.min_depth_m) & (z <= intr.max_depth_m)
    rows, cols = np.nonzero(valid)
    zv = z[rows, cols]
    optical = np.empty((zv.size, 3), dtype=np.float64)
    optical[:, 0] = (cols - intr.cx_px) / intr.fx_px * zv
    optical[:, 1] = (rows - intr.cy_px) / intr.fy_px * zv
    optical[:, 2] = zv
    turn = level_from_frd(roll_rad, pitch_rad)
    to_level = turn @ rotation_zyx(mount.roll_rad, mount.pitch_rad, mount.yaw_rad) \
        @ FRD_FROM_OPTICAL
    offset = turn @ np.asarray(mount.offset_frd_m, dtype=float)
    xyz = optical @ to_level.T + offset
    return LevelPoints(xyz, rows.astype(np.int32), int(depth.shape[0]),
                       int(depth.size - zv.size), zv.astype(np.float64))


def view_span(intr: DepthIntrinsics, mount: CameraMount, samples: int = 16) -> tuple[float, float]:
    """(centre_rad, span_rad): the bearings (from the body's nose, right positive) the image's
    border covers through the mount. A level camera spans its horizontal field of view; a
    pitched one's lower corners reach wider, a camera rolled on its side spans its vertical
    field; one looking nearly straight down, the whole circle."""
    u = np.linspace(-0.5, intr.width_px - 0.5, samples)
    v = np.linspace(-0.5, intr.height_px - 0.5, samples)
    border = np.concatenate([np.column_stack((u, np.full(samples, v[0]))),
                             np.column_stack((u, np.full(samples, v[-1]))),
                             np.column_stack((np.full(samples, u[0]), v)),
                             np.column_stack((np.full(samples, u[-1]), v))])
    rays = np.column_stack(((border[:, 0] - intr.cx_px) / intr.fx_px,
                            (border[:, 1] - intr.cy_px) / intr.fy_px, np.ones(len(border))))
    frd = rays @ mount.frd_from_optical().T
    offset = np.angle(np.exp(1j * (np.arctan2(frd[:, 1], frd[:, 0]) - mount.yaw_rad)))
    low, high = float(offset.min()), float(offset.max())
    if high - low >= np.pi * 1.9 or np.hypot(frd[:, 0], frd[:, 1]).min() < 1e-6:
        return mount.yaw_rad, 2.0 * np.pi
    return mount.yaw_rad + 0.5 * (low + high), high - low
