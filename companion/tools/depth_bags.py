"""Depth frames to recorded bags (``companion depth-record``, docs/depth.md). Optional extras:
``pip install 'companion-avoid[depth]'`` (rosbags, pyrealsense2; the latter's wheel needs
Debian's libusb-1.0-0).

- ``RosBagWriter``: a ROS 2 bag (a directory with a sqlite3 ``.db3``, rosbags' Writer) with, per
  camera i, ``/camera{i}/depth/image_rect_raw`` as sensor_msgs/msg/Image 16UC1 (millimetres,
  0 = no data, REP 118) and ``/camera{i}/depth/camera_info`` as sensor_msgs/msg/CameraInfo
  (plumb_bob, no distortion), both stamped with the frame's time_boot_ms (the vehicle's clock).
- ``RealSenseBagWriter``: what the RealSense SDK itself writes and plays back: a software device
  with one Z16 depth stream (the frame's intrinsics, depth units = its depth scale) recorded by
  ``rs.recorder`` (SDK 2.59: a ROS 2 ``.db3``), one file per camera. Played back with
  ``ctx.load_device(path)``, ``set_real_time(False)`` and the sensor started on a frame_queue
  every frame comes back (a pipeline may skip frames when not real time).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from companion.core.perception.depth_frame import DepthFrame
from companion.errors import CompanionError

EXTRA = "pip install 'companion-avoid[depth]'"


def _need(module: str):
    try:
        return __import__(module)
    except ImportError as exc:
        raise CompanionError(f"{module} is not installed ({exc}); it is an optional extra: "
                             f"{EXTRA}") from None


def image_topic(camera_id: int) -> str:
    return f"/camera{camera_id}/depth/image_rect_raw"


def info_topic(camera_id: int) -> str:
    return f"/camera{camera_id}/depth/camera_info"


class RosBagWriter:
    """A ROS 2 bag of Image 16UC1 + CameraInfo per camera (``path``: a directory, new)."""

    def __init__(self, path: str | Path) -> None:
        _need("rosbags")
        from rosbags.rosbag2 import Writer
        from rosbags.typesys import Stores, get_typestore
        self.typestore = get_typestore(Stores.ROS2_HUMBLE)
        self._writer = Writer(Path(path), version=8)
        self._writer.open()
        self._connections: dict[int, tuple] = {}
        self.frames = 0

    def _topics(self, camera_id: int):
        if camera_id not in self._connections:
            add = self._writer.add_connection
            self._connections[camera_id] = (
                add(image_topic(camera_id), "sensor_msgs/msg/Image", typestore=self.typestore),
                add(info_topic(camera_id), "sensor_msgs/msg/CameraInfo",
                    typestore=self.typestore))
        return self._connections[camera_id]

    def write(self, frame: DepthFrame) -> None:
        types = self.typestore.types
        intr = frame.intrinsics
        stamp_ns = int(frame.time_boot_ms) * 1_000_000
        header = types["std_msgs/msg/Header"](
            stamp=types["builtin_interfaces/msg/Time"](sec=stamp_ns // 1_000_000_000,
                                                       nanosec=stamp_ns % 1_000_000_000),
            frame_id=f"camera{frame.camera_id}_depth_optical_frame")
        pixels = np.ascontiguousarray(frame.depth, dtype="<u2")
        image = types["sensor_msgs/msg/Image"](
            header=header, height=intr.height_px, width=intr.width_px, encoding="16UC1",
            is_bigendian=0, step=intr.width_px * 2, data=pixels.view(np.uint8).reshape(-1))
        k = np.array([intr.fx_px, 0.0, intr.cx_px, 0.0, intr.fy_px, intr.cy_px, 0.0, 0.0, 1.0])
        p = np.array([intr.fx_px, 0.0, intr.cx_px, 0.0, 0.0, intr.fy_px, intr.cy_px, 0.0,
                      0.0, 0.0, 1.0, 0.0])
        info = types["sensor_msgs/msg/CameraInfo"](
            header=header, height=intr.height_px, width=intr.width_px,
            distortion_model="plumb_bob", d=np.zeros(5), k=k, r=np.eye(3).reshape(-1), p=p,
            binning_x=0, binning_y=0,
            roi=types["sensor_msgs/msg/RegionOfInterest"](x_offset=0, y_offset=0, height=0,
                                                          width=0, do_rectify=False))
        image_conn, info_conn = self._topics(frame.camera_id)
        serialize = self.typestore.serialize_cdr
        self._writer.write(image_conn, stamp_ns, serialize(image, "sensor_msgs/msg/Image"))
        self._writer.write(info_conn, stamp_ns, serialize(info, "sensor_msgs/msg/CameraInfo"))
        self.frames += 1

    def close(self) -> None:
        self._writer.close()


class RealSenseBagWriter:
    """RealSense's own recording of one camera: a software device's Z16 stream, rs.recorder."""

    def __init__(self, path: str | Path, fps: int = 15) -> None:
        self.rs = _need("pyrealsense2")
        self.path = Path(path)
        self.fps = max(1, int(round(fps)))
        self._device = self._sensor = self._profile = self._recorder = None
        self.frames = 0
        self._keep: list[np.ndarray] = []     # pixels the SDK may still read

    def _open(self, frame: DepthFrame) -> None:
        rs, intr = self.rs, frame.intrinsics
        self._device = rs.software_device()
        self._sensor = self._device.add_sensor("Depth")
        model = rs.intrinsics()
        model.width, model.height = intr.width_px, intr.height_px
        model.fx, model.fy, model.ppx, model.ppy = intr.fx_px, intr.fy_px, intr.cx_px, intr.cy_px
        model.model, model.coeffs = rs.distortion.none, [0.0] * 5
        stream = rs.video_stream()
        stream.type, stream.index, stream.uid = rs.stream.depth, 0, 0
        stream.width, stream.height, stream.bpp, stream.fmt = intr.width_px, intr.height_px, 2, \
            rs.format.z16
        stream.fps, stream.intrinsics = self.fps, model
        self._profile = self._sensor.add_video_stream(stream)
        self._sensor.add_read_only_option(rs.option.depth_units, float(intr.depth_scale_m))
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._recorder = rs.recorder(str(self.path), self._device)
        self._sensor.open(self._profile)
        self._sensor.start(lambda _frame: None)

    def write(self, frame: DepthFrame) -> None:
        if self._device is None:
            self._open(frame)
        rs = self.rs
        pixels = np.ascontiguousarray(frame.depth, dtype=np.uint16)
        self._keep = [pixels]
        soft = rs.software_video_frame()
        soft.pixels, soft.stride, soft.bpp = pixels, frame.intrinsics.width_px * 2, 2
        soft.timestamp, soft.domain = float(frame.time_boot_ms), rs.timestamp_domain.hardware_clock
        soft.frame_number, soft.profile = frame.frame_number, self._profile.as_video_stream_profile()
        self._sensor.on_video_frame(soft)
        self.frames += 1

    def close(self) -> None:
        if self._sensor is not None:
            self._sensor.stop()
            self._sensor.close()
        self._recorder = self._sensor = self._device = None     # the recorder writes on release


def camera_path(path: str | Path, camera_id: int) -> Path:
    """The RealSense bag of camera ``camera_id``: ``path`` itself for camera 0, else
    ``<stem>-camera<i><suffix>`` beside it."""
    path = Path(path)
    return path if camera_id == 0 else path.with_name(f"{path.stem}-camera{camera_id}{path.suffix}")


class BagSink:
    """Writes every frame handed to it (simulate's depth_sink, or the stub stream's frames) to
    the bags asked for."""

    def __init__(self, rosbag: str | Path | None, realsense: str | Path | None,
                 fps: float = 15.0) -> None:
        self.fps = fps
        self.ros = RosBagWriter(rosbag) if rosbag is not None else None
        self.realsense_path = realsense
        self.realsense: dict[int, RealSenseBagWriter] = {}
        if realsense is not None:
            _need("pyrealsense2")
        self.frames = 0

    def __call__(self, frames: list[DepthFrame]) -> None:
        for frame in frames:
            if self.ros is not None:
                self.ros.write(frame)
            if self.realsense_path is not None:
                writer = self.realsense.get(frame.camera_id)
                if writer is None:
                    writer = self.realsense[frame.camera_id] = RealSenseBagWriter(
                        camera_path(self.realsense_path, frame.camera_id), self.fps)
                writer.write(frame)
            self.frames += 1

    def close(self) -> None:
        if self.ros is not None:
            self.ros.close()
        for writer in self.realsense.values():
            writer.close()
