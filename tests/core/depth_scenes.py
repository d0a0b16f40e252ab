"""Synthetic depth frames for the perception's tests: an independent ray caster of vertical
cylinders, vertical wall panels and the floor, seen by a camera on a vehicle with roll and pitch.
Everything in the vehicle's local level frame (x forward along the heading, y right, z down),
heights above the floor; the vehicle at ``altitude_m``."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from companion.core.perception.depth_frame import (CameraMount, DepthFrame, DepthIntrinsics,
                                                   rotation_zyx)

D455 = DepthIntrinsics.from_fov(848, 480, 87.0, 58.0, 0.4, 20.0)


@dataclass(frozen=True)
class Cylinder:
    x_m: float
    y_m: float
    radius_m: float
    base_m: float = 0.0
    top_m: float = 1e3


@dataclass(frozen=True)
class Panel:
    """A vertical wall between (x0, y0) and (x1, y1), from base_m to top_m above the floor."""
    x0_m: float
    y0_m: float
    x1_m: float
    y1_m: float
    base_m: float = 0.0
    top_m: float = 1e3


def render(things, altitude_m: float = 5.0, mount: CameraMount = CameraMount(),
           roll_rad: float = 0.0, pitch_rad: float = 0.0, intr: DepthIntrinsics = D455,
           floor: bool = True) -> DepthFrame:
    """Z16 depth (0 = nothing within range) of the things and the floor."""
    rays = intr.rays_optical().reshape(-1, 3)               # optical z = 1
    to_level = rotation_zyx(roll_rad, pitch_rad, 0.0) @ mount.frd_from_optical()
    d = rays @ to_level.T
    origin = rotation_zyx(roll_rad, pitch_rad, 0.0) @ np.asarray(mount.offset_frd_m, float)
    t = np.full(len(d), np.inf)
    for thing in things:
        t = np.minimum(t, _cylinder(origin, d, thing, altitude_m) if isinstance(thing, Cylinder)
                       else _panel(origin, d, thing, altitude_m))
    if floor:
        down = d[:, 2]
        with np.errstate(divide="ignore"):
            tf = np.where(down > 1e-9, (altitude_m - origin[2]) / down, np.inf)
        t = np.minimum(t, tf)
    depth = np.where((t >= intr.min_depth_m) & (t <= intr.max_depth_m), np.round(t * 1000.0), 0)
    return DepthFrame(1, 0, 0, intr, depth.reshape(intr.height_px, intr.width_px)
                      .astype(np.uint16))


def _height_ok(origin, d, t, thing, altitude_m):
    height = altitude_m - (origin[2] + t * d[:, 2])
    return (height >= thing.base_m) & (height <= thing.top_m)


def _cylinder(origin, d, c: Cylinder, altitude_m):
    ox, oy = origin[0] - c.x_m, origin[1] - c.y_m
    a = d[:, 0] ** 2 + d[:, 1] ** 2
    b = 2.0 * (ox * d[:, 0] + oy * d[:, 1])
    cc = ox * ox + oy * oy - c.radius_m ** 2
    disc = b * b - 4.0 * a * cc
    root = np.sqrt(np.maximum(disc, 0.0))
    t = np.full(len(d), np.inf)
    for cand in ((-b - root) / (2.0 * a), (-b + root) / (2.0 * a)):
        ok = (disc >= 0.0) & (cand > 0.0) & np.isinf(t) & _height_ok(origin, d, cand, c, altitude_m)
        t = np.where(ok, cand, t)
    return t


def _panel(origin, d, p: Panel, altitude_m):
    ex, ey = p.x1_m - p.x0_m, p.y1_m - p.y0_m
    denom = d[:, 0] * ey - d[:, 1] * ex
    wx, wy = p.x0_m - origin[0], p.y0_m - origin[1]
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (wx * ey - wy * ex) / denom
        s = (wx * d[:, 1] - wy * d[:, 0]) / denom
    ok = (np.abs(denom) > 1e-12) & (t > 0.0) & (s >= 0.0) & (s <= 1.0)
    ok &= _height_ok(origin, d, np.where(ok, t, 0.0), p, altitude_m)
    return np.where(ok, t, np.inf)


def bearing_deg(x_m: float, y_m: float) -> float:
    return math.degrees(math.atan2(y_m, x_m))
