"""What every depth source yields, and the pixel conversions they share.

A ``SourcedFrame``: the DepthFrame (Z16 pixels, intrinsics, camera id, frame number) and when
it was captured: ``host_time_s`` on the companion's (or the recording's) clock, which the
service maps to the vehicle's through its time sync, or ``time_boot_ms`` on the vehicle's own
clock (the stub's frames), copied into the DepthFrame.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from companion.core.perception.depth_frame import DepthFrame, DepthIntrinsics
from companion.errors import CompanionError

MAX_Z16_M = 65.535


class DepthSourceError(CompanionError):
    """A depth source cannot be opened or read: no camera, a bag without a depth stream, a
    wrong encoding, a missing optional extra. The message says which and what to do."""


@dataclass(frozen=True)
class SourcedFrame:
    frame: DepthFrame
    host_time_s: float | None = None      # None: the frame's time_boot_ms is the vehicle's


def missing_extra(module: str, source: str) -> DepthSourceError:
    return DepthSourceError(f"depth source {source}: the Python module {module!r} is not "
                            f"installed; install the optional extra: pip install "
                            f"'companion-avoid[depth]'")


def image_to_z16(data: bytes | np.ndarray, encoding: str, width: int, height: int, step: int,
                 bigendian: bool, source: str) -> np.ndarray:
    """A sensor_msgs/Image's pixels (REP 118) as Z16 (uint16 mm, 0 = no data), (height, width):
    16UC1 / mono16 are millimetres as they are; 32FC1 metres (NaN, inf, <= 0: no data, beyond
    65.535 m: no data). Any other encoding is refused naming it."""
    raw = np.frombuffer(bytes(data) if not isinstance(data, np.ndarray) else data.tobytes(),
                        dtype=np.uint8)
    if encoding in ("16UC1", "mono16"):
        dtype, size = np.dtype(">u2" if bigendian else "<u2"), 2
    elif encoding == "32FC1":
        dtype, size = np.dtype(">f4" if bigendian else "<f4"), 4
    else:
        raise DepthSourceError(f"depth source {source}: image encoding {encoding!r} is not a "
                               "depth image (expected 16UC1 in millimetres or 32FC1 in metres, "
                               "REP 118)")
    if step < width * size or len(raw) < step * height:
        raise DepthSourceError(f"depth source {source}: image of {len(raw)} bytes is too short "
                               f"for {width}x{height} {encoding} with step {step}")
    rows = raw[:step * height].reshape(height, step)[:, :width * size]
    pixels = np.ascontiguousarray(rows).view(dtype).reshape(height, width)
    if size == 2:
        return pixels.astype(np.uint16)
    metres = pixels.astype(np.float64)
    good = np.isfinite(metres) & (metres > 0.0) & (metres <= MAX_Z16_M)
    return np.where(good, np.round(np.where(good, metres, 0.0) * 1000.0), 0).astype(np.uint16)


def intrinsics_from_k(width: int, height: int, k, min_depth_m: float,
                      max_depth_m: float) -> DepthIntrinsics:
    """A CameraInfo's K (3x3 row-major, 9 numbers) as intrinsics (Z16 in millimetres)."""
    k = [float(v) for v in k]
    return DepthIntrinsics(int(width), int(height), k[0], k[4], k[2], k[5], min_depth_m,
                           max_depth_m, 0.001)
