"""One interface over every depth source: ``open_depth_source(spec)`` -> an iterator of
SourcedFrames, from a ``perception.depth.source`` (config/depth_perception.py)."""
from __future__ import annotations

from typing import Iterator

from companion.config.depth_perception import DepthSource, parse_source
from companion.depthsrc.frames import DepthSourceError, SourcedFrame


def open_depth_source(spec: str | DepthSource, max_depth_m: float = 20.0) -> Iterator[SourcedFrame]:
    """The frames of a source, as its reader yields them (errors: DepthSourceError)."""
    if isinstance(spec, str):
        try:
            spec = parse_source(spec)
        except ValueError as exc:
            raise DepthSourceError(f"depth source: {exc}") from None
    if spec.kind == "rosbag":
        from companion.depthsrc.rosbag import read_rosbag
        return read_rosbag(spec.path, spec.topic, max_depth_m=max_depth_m)
    if spec.kind == "realsense-bag":
        from companion.depthsrc.realsense import read_realsense_bag
        return read_realsense_bag(spec.path, max_depth_m=max_depth_m)
    if spec.kind == "realsense":
        from companion.depthsrc.realsense import LiveOptions, read_realsense
        return read_realsense(spec.serial, LiveOptions(max_depth_m=max_depth_m))
    if spec.kind == "stub":
        try:
            from companion.depthsrc.stub import read_stub
        except ImportError:
            raise DepthSourceError("depth source stub: the stub's stream reader is not in this "
                                   "build (issue 43)") from None
        return read_stub(spec.host, spec.port)
    raise DepthSourceError(f"depth source: unknown kind {spec.kind!r}")
