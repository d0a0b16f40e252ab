"""``perception.depth``: how the companion turns depth pixels into obstacles, and where its frames
come from (``source``, also ``companion run --depth SOURCE``).

Sources (companion/depth/ reads them; each but the stub's needs the optional extra ``depth``):
- ``stub:HOST:PORT``       the SITL stub's depth stream (docs/sitl_stub.md);
- ``rosbag:PATH:TOPIC``    a ROS 1 or ROS 2 bag's sensor_msgs/Image (16UC1 mm or 32FC1 m);
- ``realsense-bag:FILE``   a RealSense recording played through pyrealsense2, not in real time;
- ``realsense[:SERIAL]``   a live RealSense camera (the first one, or that serial number).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

from companion.config.depth import MAX_CAMERAS, CameraMountConfig
from companion.config.loader import FieldError, require
from companion.core.perception.blobs import BlobParams
from companion.core.perception.depth_perception import DepthPerceptionParams

SOURCE_KINDS = ("stub", "rosbag", "realsense-bag", "realsense")


@dataclass(frozen=True)
class DepthSource:
    """A parsed ``perception.depth.source``: its kind and its parts (host and port; path and
    topic; file; serial)."""
    kind: str
    host: str = ""
    port: int = 0
    path: str = ""
    topic: str = ""
    serial: str = ""


def parse_source(text: str) -> DepthSource:
    """``stub:HOST:PORT`` | ``rosbag:PATH:TOPIC`` | ``realsense-bag:FILE`` |
    ``realsense[:SERIAL]``; FieldError('source') naming what is wrong."""
    kind, _, rest = text.partition(":")
    if kind == "stub":
        host, _, port = rest.rpartition(":")
        if not host or not port.isdigit() or not 0 < int(port) < 65536:
            raise FieldError("source", f"expected stub:HOST:PORT (a port in 1..65535), got {text!r}")
        return DepthSource("stub", host=host, port=int(port))
    if kind == "rosbag":
        path, _, topic = rest.rpartition(":")
        if not path or not topic.startswith("/"):
            raise FieldError("source", f"expected rosbag:PATH:TOPIC (a topic starting with /), "
                             f"got {text!r}")
        return DepthSource("rosbag", path=path, topic=topic)
    if kind == "realsense-bag":
        if not rest:
            raise FieldError("source", f"expected realsense-bag:FILE, got {text!r}")
        return DepthSource("realsense-bag", path=rest)
    if kind == "realsense":
        return DepthSource("realsense", serial=rest)
    raise FieldError("source", f"expected one of {', '.join(SOURCE_KINDS)} "
                     f"(stub:HOST:PORT, rosbag:PATH:TOPIC, realsense-bag:FILE, "
                     f"realsense[:SERIAL]), got {text!r}")


@dataclass(frozen=True)
class DepthPerceptionConfig:
    """core/perception/depth_perception.py's choices (each explained there), and for a
    service's own frames (``source``): the camera's rate, mounts and stereo figures.

    ``rate_hz``: the camera's frame rate (a live RealSense is opened at it; in lock-step the
    frames of a sample's time are waited for: frame k is the stub's capture at k / rate_hz).
    ``cameras``: one mount per camera id (body FRD offset, roll, pitch, yaw; empty: one level
    camera at the centre, facing forward). ``baseline_m``, ``subpixel``: the stereo error's
    figures (a D455's: 95 mm, 0.08 px; config/depth.py cites them)."""
    source: str | None = None
    rate_hz: float = 15.0
    cameras: tuple[CameraMountConfig, ...] = ()
    baseline_m: float = 0.095
    subpixel: float = 0.08
    decimation: int = 4
    bin_deg: float = 1.0
    min_support: int = 8
    surface_band_m: float = 0.5
    floor: Literal["auto", "altitude", "plane"] = "auto"
    range_floor_sigma_m: float = 0.05
    attitude_sigma_deg: float = 0.2     # ATTITUDE's roll and pitch error (a choice; simulate draws it)

    def __post_init__(self) -> None:
        if self.source is not None:
            parse_source(self.source)
        require(0.5 <= self.rate_hz <= 120.0, "rate_hz", self.rate_hz, "a rate in [0.5, 120] Hz")
        require(len(self.cameras) <= MAX_CAMERAS, "cameras", len(self.cameras),
                f"at most {MAX_CAMERAS} cameras")
        require(0.0 < self.baseline_m <= 1.0, "baseline_m", self.baseline_m,
                "a stereo baseline in (0, 1] m")
        require(0.0 < self.subpixel <= 1.0, "subpixel", self.subpixel,
                "a subpixel RMS in (0, 1] px")
        require(1 <= self.decimation <= 16, "decimation", self.decimation, "an integer in [1, 16]")
        require(0.0 < self.bin_deg <= 10.0, "bin_deg", self.bin_deg, "a bin in (0, 10] degrees")
        require(1 <= self.min_support <= 1000, "min_support", self.min_support,
                "an integer in [1, 1000]")
        require(0.0 <= self.surface_band_m <= 10.0, "surface_band_m", self.surface_band_m,
                "a band in [0, 10] m")
        require(0.0 < self.range_floor_sigma_m <= 5.0, "range_floor_sigma_m",
                self.range_floor_sigma_m, "a sigma in (0, 5] m")
        require(0.0 <= self.attitude_sigma_deg <= 10.0, "attitude_sigma_deg",
                self.attitude_sigma_deg, "a sigma in [0, 10] degrees")

    def mounts(self) -> list:
        """The cameras' mounts by camera id (core.perception.depth_frame.CameraMount)."""
        return [camera.mount() for camera in (self.cameras or (CameraMountConfig(),))]

    def params(self, ground_margin_m: float, baseline_m: float = 0.095,
               subpixel_px: float = 0.08, blob: BlobParams = BlobParams()) -> DepthPerceptionParams:
        """The core's parameters, with the floor's margin and the camera's stereo figures."""
        return DepthPerceptionParams(self.decimation, self.bin_deg, self.min_support,
                                     self.surface_band_m, ground_margin_m, self.floor, baseline_m,
                                     subpixel_px, self.range_floor_sigma_m,
                                     math.radians(self.attitude_sigma_deg), blob)
