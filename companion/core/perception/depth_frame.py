"""A depth camera's frame and geometry: intrinsics, mount, pixels to rays, frames to frames.

Pure maths on numpy arrays, shared by every depth source (a RealSense, a bag, the stub's stream,
simulate's own renderer) and by the perception that turns pixels into obstacles.

Frames (ALGORITHM-NOTES "Depth cameras"):
- optical: x right, y down, z forward (REP 103's ``_optical``, RealSense's and ROS's);
- body FRD: x forward, y right, z down (MAVLink's body frame);
- the mount rotates optical-aligned-with-body into the body: a camera with zero roll, pitch and
  yaw looks along the body's x axis, image right = body right, image down = body down.
Pixel (u, v) with depth z back-projects to optical ((u - cx) z / fx, (v - cy) z / fy, z).
Depth is z along the optical axis (a RealSense's Z16), not the range along the ray.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

# body FRD from a forward-looking optical frame: body x = optical z, body y = optical x,
# body z = optical y
FRD_FROM_OPTICAL = np.array([[0.0, 0.0, 1.0],
                             [1.0, 0.0, 0.0],
                             [0.0, 1.0, 0.0]])


def rotation_zyx(roll_rad: float, pitch_rad: float, yaw_rad: float) -> np.ndarray:
    """The 3x3 rotation R = Rz(yaw) Ry(pitch) Rx(roll) (aerospace ZYX Euler angles).

    R maps vectors of the rotated frame into the parent frame: for a vehicle's attitude it takes
    body FRD into NED; for a mount it takes the camera's (body-aligned) axes into the body.
    """
    cr, sr = math.cos(roll_rad), math.sin(roll_rad)
    cp, sp = math.cos(pitch_rad), math.sin(pitch_rad)
    cy, sy = math.cos(yaw_rad), math.sin(yaw_rad)
    return np.array([[cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
                     [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
                     [-sp, cp * sr, cp * cr]])


@dataclass(frozen=True)
class DepthIntrinsics:
    """A pinhole depth image's size, focal lengths and principal point (pixels), its valid depth
    span and the depth unit of its 16-bit pixels (Z16: 0.001 m on RealSense D4xx)."""
    width_px: int
    height_px: int
    fx_px: float
    fy_px: float
    cx_px: float
    cy_px: float
    min_depth_m: float
    max_depth_m: float
    depth_scale_m: float = 0.001

    @classmethod
    def from_fov(cls, width_px: int, height_px: int, hfov_deg: float, vfov_deg: float,
                 min_depth_m: float, max_depth_m: float,
                 depth_scale_m: float = 0.001) -> "DepthIntrinsics":
        """Focal lengths from the fields of view, principal point at the image centre."""
        fx = (width_px / 2.0) / math.tan(math.radians(hfov_deg) / 2.0)
        fy = (height_px / 2.0) / math.tan(math.radians(vfov_deg) / 2.0)
        return cls(width_px, height_px, fx, fy, (width_px - 1) / 2.0, (height_px - 1) / 2.0,
                   min_depth_m, max_depth_m, depth_scale_m)

    @property
    def hfov_rad(self) -> float:
        return 2.0 * math.atan2(self.width_px / 2.0, self.fx_px)

    @property
    def vfov_rad(self) -> float:
        return 2.0 * math.atan2(self.height_px / 2.0, self.fy_px)

    def rays_optical(self) -> np.ndarray:
        """(H, W, 3): each pixel's ray in the optical frame, scaled so that its z is 1."""
        u = np.arange(self.width_px, dtype=float)
        v = np.arange(self.height_px, dtype=float)
        uu, vv = np.meshgrid(u, v)
        return np.stack([(uu - self.cx_px) / self.fx_px, (vv - self.cy_px) / self.fy_px,
                         np.ones_like(uu)], axis=-1)


@dataclass(frozen=True)
class CameraMount:
    """Where a camera sits on the vehicle: its offset from the vehicle's centre (body FRD,
    metres) and its roll, pitch and yaw relative to the body (radians; pitch < 0 looks down)."""
    offset_frd_m: tuple[float, float, float] = (0.0, 0.0, 0.0)
    roll_rad: float = 0.0
    pitch_rad: float = 0.0
    yaw_rad: float = 0.0

    def frd_from_optical(self) -> np.ndarray:
        """3x3: a vector in the camera's optical frame, expressed in the body FRD frame."""
        return rotation_zyx(self.roll_rad, self.pitch_rad, self.yaw_rad) @ FRD_FROM_OPTICAL


@dataclass(frozen=True)
class DepthFrame:
    """One depth image: its number, its capture time on the vehicle's clock, which camera, that
    camera's intrinsics and the Z16 pixels (uint16, shape (height, width), 0 = no data)."""
    frame_number: int
    time_boot_ms: int
    camera_id: int
    intrinsics: DepthIntrinsics
    depth: np.ndarray = field(repr=False)

    def depth_m(self) -> np.ndarray:
        """(H, W) float metres, NaN where the pixel has no data."""
        z = self.depth.astype(float) * self.intrinsics.depth_scale_m
        z[self.depth == 0] = np.nan
        return z
