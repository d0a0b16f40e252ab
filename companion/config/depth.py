"""A scenario's depth camera (``sensor.form: depth``): ``sensor.depth`` (intrinsics, rate, range,
the stereo error model) and ``sensor.cameras`` (one mount each). Degrees only in ``_deg`` keys.

Defaults are an Intel RealSense D455 at its recommended depth mode (ALGORITHM-NOTES "Depth
cameras"); each value says where it comes from: (source) or (choice, why).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from companion.config.loader import FieldError, require
from companion.core.perception.depth_frame import CameraMount, DepthIntrinsics

# D4xx disparity search range in pixels (ALGORITHM-NOTES: min depth ~ f_px * baseline / 126)
DISPARITY_SEARCH_PX = 126.0
MAX_PIXELS = 4096 * 4096
DEPTH_SCALE_M = 0.001          # (source) RealSense Z16 depth unit on D4xx: 1 mm
MAX_CAMERAS = 8


@dataclass(frozen=True)
class DepthConfig:
    """The rendered depth image. Either the fields of view (``hfov_deg``, ``vfov_deg``; the
    principal point at the centre) or the focal lengths (``fx_px``, ``fy_px``, optional
    ``cx_px``, ``cy_px``), not both."""
    width_px: int = 848              # (source) Intel: 848x480 is the D4xx's recommended depth mode
    height_px: int = 480
    hfov_deg: float | None = None    # (source) D455 datasheet depth FOV 87 x 58 deg (null: 87)
    vfov_deg: float | None = None    # ... (null: 58)
    fx_px: float | None = None
    fy_px: float | None = None
    cx_px: float | None = None
    cy_px: float | None = None
    rate_hz: float = 15.0            # (choice) ArduPilot's d4xx_to_mavlink.py runs the D4xx at 15 Hz
    # (null: the disparity search range's, fx x baseline / 126 px: 0.34 m for a D455 at 848 px)
    min_depth_m: float | None = None
    max_depth_m: float = 20.0        # (choice) beyond it the D455's sigma_z exceeds 0.75 m
    # Intel's stereo RMS error sigma_z = z^2 x subpixel / (fx x baseline):
    baseline_m: float = 0.095        # (source) D455 stereo baseline 95 mm (datasheet, as quoted)
    subpixel: float = 0.08           # (source) Intel engineers' typical subpixel RMS (0.03 to 0.1)
    depth_noise: bool = True         # the error above, on (true) or off
    # (choice) the error is one offset over noise_patch_px x noise_patch_px pixels (stereo block
    # matching smears it over its window: a wavy surface, not white pixel noise)
    noise_patch_px: int = 6
    # the occlusion shadow: no data where the second imager cannot see (left of every near edge)
    edge_shadow: bool = True
    # null: the stereo geometry's own band, fx x baseline x (1/z_near - 1/z_far) px wide; a
    # number: a fixed band of that many pixels left of every step toward the camera
    shadow_band_px: int | None = None
    # (choice) holes on low texture: this fraction of noise patches gives no data
    dropout_fraction: float = 0.01

    def __post_init__(self) -> None:
        for key in ("width_px", "height_px"):
            require(1 <= getattr(self, key) <= 4096, key, getattr(self, key),
                    "an image size in [1, 4096] pixels")
        fov_given = self.hfov_deg is not None or self.vfov_deg is not None
        focal_given = any(v is not None for v in (self.fx_px, self.fy_px, self.cx_px, self.cy_px))
        if fov_given and focal_given:
            raise FieldError("fx_px", "give either hfov_deg / vfov_deg or fx_px / fy_px "
                             "(cx_px, cy_px), not both")
        if focal_given and (self.fx_px is None or self.fy_px is None):
            raise FieldError("fx_px" if self.fx_px is None else "fy_px",
                             "missing: focal lengths come as a pair, fx_px and fy_px")
        for key in ("hfov_deg", "vfov_deg"):
            value = getattr(self, key)
            if value is not None:
                require(0.0 < value < 170.0, key, value, "a field of view in (0, 170) degrees")
        for key in ("fx_px", "fy_px"):
            value = getattr(self, key)
            if value is not None:
                require(value > 0.0, key, value, "a focal length > 0 pixels")
        for key, size in (("cx_px", self.width_px), ("cy_px", self.height_px)):
            value = getattr(self, key)
            if value is not None:
                require(-0.5 <= value <= size - 0.5, key, value,
                        f"a principal point within the image [-0.5, {size - 0.5}]")
        require(0.0 < self.rate_hz <= 300.0, "rate_hz", self.rate_hz, "a rate in (0, 300] Hz")
        require(0.0 < self.max_depth_m <= 65.0, "max_depth_m", self.max_depth_m,
                "a depth in (0, 65] m (Z16 in millimetres ends at 65.535 m)")
        if self.min_depth_m is not None:
            require(0.0 <= self.min_depth_m < self.max_depth_m, "min_depth_m", self.min_depth_m,
                    f"a depth in [0, max_depth_m = {self.max_depth_m:g}) m")
        require(0.0 < self.baseline_m <= 1.0, "baseline_m", self.baseline_m,
                "a stereo baseline in (0, 1] m")
        require(0.0 < self.subpixel <= 1.0, "subpixel", self.subpixel,
                "a subpixel RMS in (0, 1] pixels")
        require(1 <= self.noise_patch_px <= 64, "noise_patch_px", self.noise_patch_px,
                "a patch size in [1, 64] pixels")
        if self.shadow_band_px is not None:
            require(0 <= self.shadow_band_px <= 256, "shadow_band_px", self.shadow_band_px,
                    "a band width in [0, 256] pixels or null (the stereo geometry's)")
        require(0.0 <= self.dropout_fraction < 1.0, "dropout_fraction", self.dropout_fraction,
                "a fraction in [0, 1)")

    def intrinsics(self) -> DepthIntrinsics:
        """The pinhole model of every camera of the rig (core/perception/depth_frame.py)."""
        if self.fx_px is None:
            hfov = 87.0 if self.hfov_deg is None else self.hfov_deg
            vfov = 58.0 if self.vfov_deg is None else self.vfov_deg
            fx = (self.width_px / 2.0) / math.tan(math.radians(hfov) / 2.0)
            intr = DepthIntrinsics.from_fov(self.width_px, self.height_px, hfov, vfov, 0.0,
                                            self.max_depth_m, DEPTH_SCALE_M)
        else:
            fx = self.fx_px
            intr = DepthIntrinsics(
                self.width_px, self.height_px, self.fx_px, self.fy_px,
                (self.width_px - 1) / 2.0 if self.cx_px is None else self.cx_px,
                (self.height_px - 1) / 2.0 if self.cy_px is None else self.cy_px,
                0.0, self.max_depth_m, DEPTH_SCALE_M)
        min_depth = fx * self.baseline_m / DISPARITY_SEARCH_PX if self.min_depth_m is None \
            else self.min_depth_m
        return DepthIntrinsics(intr.width_px, intr.height_px, intr.fx_px, intr.fy_px,
                               intr.cx_px, intr.cy_px, min(min_depth, 0.5 * self.max_depth_m),
                               self.max_depth_m, DEPTH_SCALE_M)


@dataclass(frozen=True)
class CameraMountConfig:
    """One camera on the vehicle: its offset from the vehicle's centre (body FRD, metres) and its
    roll, pitch and yaw relative to the body (degrees; pitch < 0 looks down, yaw > 0 right)."""
    offset_frd_m: tuple[float, ...] = (0.0, 0.0, 0.0)
    roll_deg: float = 0.0
    pitch_deg: float = 0.0
    yaw_deg: float = 0.0

    def __post_init__(self) -> None:
        require(len(self.offset_frd_m) == 3 and all(abs(v) <= 10.0 for v in self.offset_frd_m),
                "offset_frd_m", list(self.offset_frd_m),
                "[forward, right, down] in metres, each within 10 m of the centre")
        require(-180.0 <= self.roll_deg <= 180.0, "roll_deg", self.roll_deg,
                "an angle in [-180, 180] degrees")
        require(-90.0 <= self.pitch_deg <= 90.0, "pitch_deg", self.pitch_deg,
                "an angle in [-90, 90] degrees")
        require(-180.0 <= self.yaw_deg <= 180.0, "yaw_deg", self.yaw_deg,
                "an angle in [-180, 180] degrees")

    def mount(self) -> CameraMount:
        return CameraMount(tuple(float(v) for v in self.offset_frd_m),
                           math.radians(self.roll_deg), math.radians(self.pitch_deg),
                           math.radians(self.yaw_deg))


def check_cameras(form: str, cameras: tuple[CameraMountConfig, ...]) -> None:
    """sensor.cameras: one mount per camera, at most MAX_CAMERAS, for the depth form, and for the
    centres form as a rig of level cameras at the vehicle's centre that differ by their yaw only
    (each of sensor.fov_deg and max_range_m: a forward camera and two side ones, say)."""
    if cameras and form not in ("depth", "centres"):
        raise FieldError("cameras", f"per-camera mounts are rendered by the depth form only (or "
                         f"seen by yaw in the centres form), got form {form!r}")
    if form == "centres":
        for camera in cameras:
            if camera.roll_deg or camera.pitch_deg or any(camera.offset_frd_m):
                key = "offset_frd_m" if any(camera.offset_frd_m) else \
                    "roll_deg" if camera.roll_deg else "pitch_deg"
                raise FieldError("cameras", f"the centres form's cameras are level, at the "
                                 f"vehicle's centre, and differ by yaw_deg only: {key} must "
                                 f"be left out (or 0)")
    require(len(cameras) <= MAX_CAMERAS, "cameras", len(cameras),
            f"at most {MAX_CAMERAS} cameras")
