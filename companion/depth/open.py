"""One interface over every depth source: ``open_depth_source(spec)`` -> an iterator of
SourcedFrames, from a ``perception.depth.source`` (config/depth_perception.py)."""
from __future__ import annotations

from typing import Iterator

from companion.config.depth_perception import DepthSource, parse_source
from companion.depth.frames import DepthSourceError, SourcedFrame


def open_depth_source(spec: str | DepthSource, max_depth_m: float = 20.0) -> Iterator[SourcedFrame]:
    """The frames of a source, as its reader yields them (errors: DepthSourceError)."""
    if isinstance(spec, str):
        try:
            spec = parse_source(spec)
        except ValueError as exc:
            raise DepthSourceError(f"depth source: {exc}") from None
    if spec.kind == "rosbag":
        from companion.depth.rosbag import read_rosbag
        return read_rosbag(spec.path, spec.topic, max_depth_m=max_depth_m)
    if spec.kind == "realsense-bag":
        from companion.depth.realsense import read_realsense_bag
        return read_realsense_bag(spec.path, max_depth_m=max_depth_m)
    if spec.kind == "realsense":
        from companion.depth.realsense import LiveOptions, read_realsense
        return read_realsense(spec.serial, LiveOptions(max_depth_m=max_depth_m))
    if spec.kind == "stub":
        return read_stub(spec.host, spec.port)
    raise DepthSourceError(f"depth source: unknown kind {spec.kind!r}")


def read_stub(host: str, port: int, timeout_s: float = 5.0) -> Iterator[SourcedFrame]:
    """The stub's depth stream (``sitl-stub --depth-tcp``, docs/depth.md), blocking, until the
    stub closes it. Its frames carry time_boot_ms, the vehicle's clock."""
    import socket
    from companion.depth.stub_stream import read_frame
    try:
        sock = socket.create_connection((host, port), timeout=timeout_s)
    except OSError as exc:
        raise DepthSourceError(f"depth source stub:{host}:{port}: cannot connect: {exc} (is the "
                               "stub running with --depth-tcp?)") from None
    sock.settimeout(None)      # the timeout was the connection's: a stub may pause for long
    with sock, sock.makefile("rb") as stream:      # (in lock-step, before its peer starts)
        while (frame := read_frame(stream)) is not None:
            yield SourcedFrame(frame)
