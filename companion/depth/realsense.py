"""``realsense-bag:FILE`` and ``realsense[:SERIAL]``: depth frames through Intel's SDK
(pyrealsense2, optional extra ``depth``; its wheel needs libusb-1.0, Debian's libusb-1.0-0).

A recording is played back not in real time (``set_real_time(False)``, its depth sensor started
on a frame queue: every frame, as fast as it is read); its end is the end of the source. A live camera streams depth at the configured mode
through the librealsense post-processing filters Intel recommends for depth, in Intel's order:
decimation, threshold (the valid span), depth to disparity, spatial (edge-preserving smoothing,
hole filling off), temporal (persistence over frames), disparity to depth. Each is switchable.
Frames carry the SDK's timestamp (milliseconds; global time, the host's clock, where the camera
supports it) as ``host_time_s`` and the depth unit of the device (``depth_scale_m``).
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Iterator

import numpy as np

from companion.core.perception.depth_frame import DepthFrame, DepthIntrinsics
from companion.depth.frames import DepthSourceError, SourcedFrame, missing_extra

WAIT_MS = 1000
QUEUE_FRAMES = 1000


@dataclass(frozen=True)
class LiveOptions:
    """A live camera's depth mode and filters (D455 defaults: 848x480 at 15 Hz)."""
    width_px: int = 848
    height_px: int = 480
    rate_hz: int = 15
    decimation: int = 1            # the SDK's decimation filter (1: off; the pipeline decimates)
    min_depth_m: float = 0.3
    max_depth_m: float = 20.0
    spatial: bool = True
    temporal: bool = True


def _sdk(source: str):
    try:
        import pyrealsense2 as rs
    except ImportError:
        raise missing_extra("pyrealsense2", source) from None
    return rs


def read_realsense_bag(path: str, min_depth_m: float = 0.3,
                       max_depth_m: float = 20.0) -> Iterator[SourcedFrame]:
    """Every depth frame of a RealSense recording (.bag or .db3), in order, not in real time:
    the recording's depth sensor started on a frame queue (a pipeline may skip frames when not
    in real time; docs/depth.md)."""
    source = f"realsense-bag:{path}"
    rs = _sdk(source)
    if not Path(path).exists():
        raise DepthSourceError(f"depth source {source}: no recording at {path}")
    try:
        device = rs.context().load_device(str(path))
    except RuntimeError as exc:
        raise DepthSourceError(f"depth source {source}: the SDK cannot play it: {exc}") from None
    device.as_playback().set_real_time(False)
    found = [(sensor, profile) for sensor in device.query_sensors()
             for profile in sensor.get_stream_profiles()
             if profile.stream_type() == rs.stream.depth]
    if not found:
        kinds = sorted({str(p.stream_type()) for s in device.query_sensors()
                        for p in s.get_stream_profiles()})
        raise DepthSourceError(f"depth source {source}: the recording has no depth stream "
                               f"(streams: {', '.join(kinds) or 'none'})")
    sensor, profile = found[0]
    scale = float(sensor.get_option(rs.option.depth_units)) \
        if sensor.supports(rs.option.depth_units) else 0.001
    queue = rs.frame_queue(QUEUE_FRAMES, True)
    sensor.open(profile)
    sensor.start(queue)
    try:
        while True:
            ok, frame = queue.try_wait_for_frame(WAIT_MS)
            if not ok:
                return                   # the recording's end
            depth = frame.as_depth_frame()
            if depth:
                yield _sourced(depth, scale, min_depth_m, max_depth_m)
    finally:
        sensor.stop()
        sensor.close()


def read_realsense(serial: str = "", options: LiveOptions = LiveOptions()) -> Iterator[SourcedFrame]:
    """A live camera's depth frames (the first camera found, or the one with ``serial``)."""
    source = f"realsense:{serial}" if serial else "realsense"
    rs = _sdk(source)
    devices = [d.get_info(rs.camera_info.serial_number) for d in rs.context().query_devices()]
    if not devices:
        raise DepthSourceError(f"depth source {source}: no RealSense camera found (is it "
                               "plugged in, on a USB 3 port, and readable by this user?)")
    if serial and serial not in devices:
        raise DepthSourceError(f"depth source {source}: no camera with serial {serial} "
                               f"(found: {', '.join(devices)})")
    pipe, cfg = rs.pipeline(), rs.config()
    if serial:
        cfg.enable_device(serial)
    cfg.enable_stream(rs.stream.depth, options.width_px, options.height_px, rs.format.z16,
                      options.rate_hz)
    try:
        profile = pipe.start(cfg)
    except RuntimeError as exc:
        raise DepthSourceError(f"depth source {source}: cannot stream depth "
                               f"{options.width_px}x{options.height_px} at {options.rate_hz} Hz: "
                               f"{exc}") from None
    try:
        yield from _frames(rs, pipe, _depth_scale(profile), options.min_depth_m,
                           options.max_depth_m, _filters(rs, options))
    finally:
        pipe.stop()


def _filters(rs, options: LiveOptions) -> list:
    chain = []
    if options.decimation > 1:
        decimation = rs.decimation_filter()
        decimation.set_option(rs.option.filter_magnitude, options.decimation)
        chain.append(decimation)
    chain.append(rs.threshold_filter(options.min_depth_m, options.max_depth_m))
    if options.spatial or options.temporal:
        chain.append(rs.disparity_transform(True))
        if options.spatial:
            chain.append(rs.spatial_filter())
        if options.temporal:
            chain.append(rs.temporal_filter())
        chain.append(rs.disparity_transform(False))
    return chain


def _depth_scale(profile) -> float:
    try:
        return float(profile.get_device().first_depth_sensor().get_depth_scale())
    except RuntimeError:
        return 0.001                 # RealSense D4xx's default unit


def _frames(rs, pipe, scale: float, min_depth_m: float, max_depth_m: float,
            filters: list) -> Iterator[SourcedFrame]:
    while True:
        ok, frames = pipe.try_wait_for_frames(WAIT_MS)
        if not ok:
            raise DepthSourceError(f"depth source realsense: no frame for {WAIT_MS} ms "
                                   "(camera unplugged?)")
        depth = frames.get_depth_frame()
        if not depth:
            continue
        for step in filters:
            depth = step.process(depth)
        yield _sourced(depth.as_depth_frame(), scale, min_depth_m, max_depth_m)


def _sourced(depth, scale: float, min_depth_m: float, max_depth_m: float) -> SourcedFrame:
    intr = depth.profile.as_video_stream_profile().get_intrinsics()
    pixels = np.asanyarray(depth.get_data()).astype(np.uint16, copy=True)
    return SourcedFrame(
        DepthFrame(int(depth.get_frame_number()), 0, 0,
                   DepthIntrinsics(intr.width, intr.height, intr.fx, intr.fy, intr.ppx,
                                   intr.ppy, min_depth_m, max_depth_m, scale), pixels),
        float(depth.get_timestamp()) / 1000.0)
