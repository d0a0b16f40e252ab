"""``rosbag:PATH:TOPIC``: a ROS 1 (.bag) or ROS 2 (directory, .db3 or .mcap) bag's depth images,
read with the ``rosbags`` library (optional extra ``depth``). The topic must carry
sensor_msgs/Image in 16UC1 (millimetres) or 32FC1 (metres), 0 or NaN = no data (REP 118); its
intrinsics come from the bag's CameraInfo beside it (``<namespace>/camera_info``, else the only
CameraInfo in the bag), or from ``intrinsics`` given by the caller. Frames are stamped with the
image header's time (the recording host's clock) in ``host_time_s``."""
from __future__ import annotations

from pathlib import Path
from typing import Iterator

from companion.core.perception.depth_frame import DepthFrame, DepthIntrinsics
from companion.depth.frames import (DepthSourceError, SourcedFrame, image_to_z16,
                                       intrinsics_from_k, missing_extra)

IMAGE = "sensor_msgs/msg/Image"
INFO = "sensor_msgs/msg/CameraInfo"


def read_rosbag(path: str, topic: str, intrinsics: DepthIntrinsics | None = None,
                min_depth_m: float = 0.1, max_depth_m: float = 20.0,
                camera_id: int = 0) -> Iterator[SourcedFrame]:
    """Every depth image of ``topic`` in the bag at ``path``, in the bag's order."""
    source = f"rosbag:{path}:{topic}"
    try:
        from rosbags.highlevel import AnyReader
    except ImportError:
        raise missing_extra("rosbags", source) from None
    if not Path(path).exists():
        raise DepthSourceError(f"depth source {source}: no bag at {path}")
    with AnyReader([Path(path)]) as reader:
        images = [c for c in reader.connections if c.topic == topic]
        if not images:
            found = sorted({f"{c.topic} ({c.msgtype})" for c in reader.connections
                            if c.msgtype == IMAGE})
            raise DepthSourceError(f"depth source {source}: the bag has no topic {topic}; its "
                                   f"images: {', '.join(found) or 'none'}")
        if images[0].msgtype != IMAGE:
            raise DepthSourceError(f"depth source {source}: {topic} carries "
                                   f"{images[0].msgtype}, not {IMAGE}")
        intr = intrinsics or _camera_info(reader, topic, source, min_depth_m, max_depth_m)
        for number, (conn, _, raw) in enumerate(reader.messages(connections=images)):
            msg = reader.deserialize(raw, conn.msgtype)
            if (msg.width, msg.height) != (intr.width_px, intr.height_px):
                raise DepthSourceError(f"depth source {source}: image {msg.width}x{msg.height} "
                                       f"but intrinsics {intr.width_px}x{intr.height_px}")
            z16 = image_to_z16(msg.data, msg.encoding, msg.width, msg.height, msg.step,
                               bool(msg.is_bigendian), source)
            yield SourcedFrame(DepthFrame(number, 0, camera_id, intr, z16),
                               _seconds(msg.header.stamp))


def _camera_info(reader, topic: str, source: str, min_depth_m: float,
                 max_depth_m: float) -> DepthIntrinsics:
    infos = [c for c in reader.connections if c.msgtype == INFO]
    beside = [c for c in infos if c.topic == topic.rpartition("/")[0] + "/camera_info"]
    chosen = beside or (infos if len(infos) == 1 else [])
    if not chosen:
        raise DepthSourceError(f"depth source {source}: no CameraInfo beside {topic} "
                               f"({len(infos)} CameraInfo topics in the bag): give the "
                               "intrinsics in the config")
    for conn, _, raw in reader.messages(connections=chosen[:1]):
        info = reader.deserialize(raw, conn.msgtype)
        k = getattr(info, "k", None)
        return intrinsics_from_k(info.width, info.height, info.K if k is None else k,
                                 min_depth_m, max_depth_m)
    raise DepthSourceError(f"depth source {source}: {chosen[0].topic} holds no message")


def _seconds(stamp) -> float:
    """A header stamp (ROS 2 sec / nanosec, ROS 1 secs / nsecs) in seconds."""
    sec = getattr(stamp, "sec", None)
    if sec is None:
        return stamp.secs + stamp.nsecs * 1e-9
    return sec + stamp.nanosec * 1e-9
