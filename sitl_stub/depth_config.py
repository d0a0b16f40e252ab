"""The stub's own reading of a scenario's depth camera (``sensor.form: depth``, ``sensor.depth``,
``sensor.cameras``; docs/depth.md). The defaults are a RealSense D455's at 848x480 (the same
figures as the companion's config/depth.py, cited there; the stub keeps its own copy).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

DISPARITY_SEARCH_PX = 126.0      # D4xx: min depth ~ fx x baseline / 126 px
DEPTH_SCALE_M = 0.001
D455_HFOV_DEG, D455_VFOV_DEG = 87.0, 58.0


@dataclass(frozen=True)
class DepthSpec:
    """The image (pinhole: fx, fy, cx, cy in pixels), its rate, valid span and errors."""
    width_px: int = 848
    height_px: int = 480
    fx_px: float = 0.0
    fy_px: float = 0.0
    cx_px: float = 0.0
    cy_px: float = 0.0
    rate_hz: float = 15.0
    min_depth_m: float = 0.0
    max_depth_m: float = 20.0
    depth_scale_m: float = DEPTH_SCALE_M
    baseline_m: float = 0.095
    subpixel: float = 0.08
    depth_noise: bool = True
    noise_patch_px: int = 6
    edge_shadow: bool = True
    shadow_band_px: int | None = None
    dropout_fraction: float = 0.01


@dataclass(frozen=True)
class Mount:
    """A camera on the vehicle: offset (body FRD, m) and roll, pitch, yaw (rad) from the body."""
    offset_frd_m: tuple[float, float, float] = (0.0, 0.0, 0.0)
    roll_rad: float = 0.0
    pitch_rad: float = 0.0
    yaw_rad: float = 0.0


def parse_depth(r, reader_cls) -> DepthSpec:
    """sensor.depth (``r``: the sensor's _Reader); absent: the defaults."""
    d = r.child("depth", required=False)
    if d is None:
        d = reader_cls(r.path, {}, "sensor.depth")
    width = d.integer("width_px", minimum=1, maximum=4096) if "width_px" in d.data else 848
    height = d.integer("height_px", minimum=1, maximum=4096) if "height_px" in d.data else 480
    focal = [k for k in ("fx_px", "fy_px", "cx_px", "cy_px") if k in d.data]
    fov = [k for k in ("hfov_deg", "vfov_deg") if k in d.data and d.data[k] is not None]
    if focal and fov:
        raise d.error("give either hfov_deg / vfov_deg or fx_px / fy_px (cx_px, cy_px), not both",
                      "fx_px")
    if focal:
        fx = d.number("fx_px", minimum=0, strict_min=True)
        fy = d.number("fy_px", minimum=0, strict_min=True)
        cx = d.number("cx_px", (width - 1) / 2.0, minimum=-0.5, maximum=width - 0.5)
        cy = d.number("cy_px", (height - 1) / 2.0, minimum=-0.5, maximum=height - 0.5)
    else:
        hfov = _optional(d, "hfov_deg", D455_HFOV_DEG)
        vfov = _optional(d, "vfov_deg", D455_VFOV_DEG)
        fx = (width / 2.0) / math.tan(math.radians(hfov) / 2.0)
        fy = (height / 2.0) / math.tan(math.radians(vfov) / 2.0)
        cx, cy = (width - 1) / 2.0, (height - 1) / 2.0
    max_depth = d.number("max_depth_m", 20.0, minimum=0, strict_min=True, maximum=65.0)
    baseline = d.number("baseline_m", 0.095, minimum=0, strict_min=True, maximum=1.0)
    spec = DepthSpec(
        width_px=width, height_px=height, fx_px=fx, fy_px=fy, cx_px=cx, cy_px=cy,
        rate_hz=d.number("rate_hz", 15.0, minimum=0, strict_min=True, maximum=300.0),
        max_depth_m=max_depth, baseline_m=baseline,
        subpixel=d.number("subpixel", 0.08, minimum=0, strict_min=True, maximum=1.0),
        depth_noise=d.boolean("depth_noise", True),
        noise_patch_px=d.integer("noise_patch_px", minimum=1, maximum=64)
        if "noise_patch_px" in d.data else 6,
        edge_shadow=d.boolean("edge_shadow", True),
        shadow_band_px=(d.integer("shadow_band_px", minimum=0, maximum=256)
                        if d.data.get("shadow_band_px") is not None else None),
        dropout_fraction=d.number("dropout_fraction", 0.01, minimum=0, maximum=0.999999))
    d.used.add("shadow_band_px")
    min_depth = d.data.get("min_depth_m")
    if min_depth is not None:
        min_depth = d.number("min_depth_m", minimum=0)
        if min_depth >= max_depth:
            raise d.error(f"must be below max_depth_m ({max_depth:g}), got {min_depth:g}",
                          "min_depth_m")
    d.used.add("min_depth_m")
    d.finish()
    if min_depth is None:
        min_depth = min(fx * baseline / DISPARITY_SEARCH_PX, 0.5 * max_depth)
    return DepthSpec(**{**spec.__dict__, "min_depth_m": min_depth})


def _optional(d, key: str, default: float) -> float:
    if d.data.get(key) is None:
        d.used.add(key)
        return default
    return d.number(key, minimum=0, strict_min=True, maximum=169.999)


def parse_cameras(r, reader_cls, form: str) -> tuple[Mount, ...]:
    """sensor.cameras: a list of mounts (form depth; form centres: a rig of level cameras at the
    centre, by yaw_deg alone); absent: one level forward camera."""
    items = r._get("cameras", None)
    if items is None:
        return (Mount(),) if form == "depth" else ()
    if form not in ("depth", "centres"):
        raise r.error(f"per-camera mounts are rendered by the depth form only (or seen by yaw in the "
                      f"centres form), got form {form!r}", "cameras")
    if not isinstance(items, list) or not 1 <= len(items) <= 8:
        raise r.error("expected a list of 1 to 8 camera mounts", "cameras")
    mounts = []
    for i, item in enumerate(items):
        c = reader_cls(r.path, item, f"sensor.cameras[{i}]")
        offset = c._get("offset_frd_m", [0.0, 0.0, 0.0])
        if not (isinstance(offset, list) and len(offset) == 3
                and all(isinstance(v, (int, float)) and not isinstance(v, bool)
                        and math.isfinite(v) and abs(v) <= 10.0 for v in offset)):
            raise c.error(f"expected [forward, right, down] in metres within 10 m, got {offset!r}",
                          "offset_frd_m")
        mounts.append(Mount(tuple(float(v) for v in offset),
                            math.radians(c.number("roll_deg", 0.0, minimum=-180, maximum=180)),
                            math.radians(c.number("pitch_deg", 0.0, minimum=-90, maximum=90)),
                            math.radians(c.number("yaw_deg", 0.0, minimum=-180, maximum=180))))
        c.finish()
        if form == "centres" and (any(mounts[-1].offset_frd_m) or mounts[-1].roll_rad
                                  or mounts[-1].pitch_rad):
            raise c.error("the centres form's cameras are level, at the vehicle's centre, and "
                          "differ by yaw_deg only", "yaw_deg")
    return tuple(mounts)
