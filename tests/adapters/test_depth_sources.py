"""Depth sources (companion/depth/): ROS bags (16UC1 mm, 32FC1 m with NaN, CameraInfo beside
the image), RealSense recordings played through the SDK, and the clear errors: no camera, a
recording without a depth stream, a wrong encoding, a missing topic. The recordings are written
here, by rosbags' writer and the SDK's own software device and recorder."""
from __future__ import annotations

import numpy as np
import pytest

from companion.config.depth_perception import parse_source
from companion.config.loader import FieldError
from companion.depth.frames import DepthSourceError, image_to_z16
from companion.depth.open import open_depth_source

W, H = 64, 48


def test_sources_parse_and_a_bad_one_is_named():
    assert parse_source("stub:127.0.0.1:14600").port == 14600
    assert parse_source("rosbag:/data/a.bag:/camera/depth/image_rect_raw").topic \
        == "/camera/depth/image_rect_raw"
    assert parse_source("realsense").serial == ""
    assert parse_source("realsense:123456").serial == "123456"
    assert parse_source("realsense-bag:/x/y.db3").path == "/x/y.db3"
    for bad in ("stub:host", "rosbag:/a.bag", "kinect", "realsense-bag:"):
        with pytest.raises(FieldError, match="source"):
            parse_source(bad)


def test_32fc1_metres_become_millimetres_and_nan_no_data():
    metres = np.array([[1.5, np.nan], [0.0, 70.0]], dtype="<f4")
    z16 = image_to_z16(metres.tobytes(), "32FC1", 2, 2, 8, False, "test")
    assert z16.tolist() == [[1500, 0], [0, 0]]
    with pytest.raises(DepthSourceError, match="rgb8"):
        image_to_z16(b"\0" * 12, "rgb8", 2, 2, 6, False, "test")


def _write_ros2_bag(path, encoding: str, images, with_info: bool = True):
    rosbags = pytest.importorskip("rosbags", reason="the rosbag extra (rosbags) is not installed")
    del rosbags
    from rosbags.rosbag2 import Writer
    from rosbags.typesys import Stores, get_typestore
    store = get_typestore(Stores.ROS2_HUMBLE)
    Image, Info = store.types["sensor_msgs/msg/Image"], store.types["sensor_msgs/msg/CameraInfo"]
    Header, Time = store.types["std_msgs/msg/Header"], store.types["builtin_interfaces/msg/Time"]
    Roi = store.types["sensor_msgs/msg/RegionOfInterest"]
    with Writer(path, version=8) as writer:
        img_conn = writer.add_connection("/camera/depth/image_rect_raw", Image.__msgtype__,
                                         typestore=store)
        info_conn = writer.add_connection("/camera/depth/camera_info", Info.__msgtype__,
                                          typestore=store) if with_info else None
        for i, pixels in enumerate(images):
            header = Header(stamp=Time(sec=100 + i, nanosec=500_000_000), frame_id="depth")
            data = np.ascontiguousarray(pixels).view(np.uint8).reshape(-1)
            size = pixels.dtype.itemsize
            msg = Image(header=header, height=H, width=W, encoding=encoding, is_bigendian=0,
                        step=W * size, data=data)
            t = (100 + i) * 10**9
            writer.write(img_conn, t, store.serialize_cdr(msg, Image.__msgtype__))
            if info_conn is not None:
                info = Info(header=header, height=H, width=W, distortion_model="plumb_bob",
                            d=np.zeros(5), k=np.array([40.0, 0, 31.5, 0, 41.0, 23.5, 0, 0, 1]),
                            r=np.eye(3).reshape(-1), p=np.zeros(12), binning_x=0, binning_y=0,
                            roi=Roi(x_offset=0, y_offset=0, height=0, width=0,
                                    do_rectify=False))
                writer.write(info_conn, t, store.serialize_cdr(info, Info.__msgtype__))


def test_a_ros2_bag_of_16uc1_reads_back_with_its_camera_info(tmp_path):
    frames_in = [np.full((H, W), 1000 * (i + 1), np.uint16) for i in range(3)]
    frames_in[1][5, 7] = 0
    path = tmp_path / "bag"
    _write_ros2_bag(path, "16UC1", frames_in)
    got = list(open_depth_source(f"rosbag:{path}:/camera/depth/image_rect_raw"))
    assert len(got) == 3
    for sourced, pixels in zip(got, frames_in):
        assert np.array_equal(sourced.frame.depth, pixels)
        assert sourced.frame.intrinsics.fx_px == 40.0 and sourced.frame.intrinsics.fy_px == 41.0
    assert got[2].host_time_s == pytest.approx(102.5)


def test_a_ros2_bag_of_32fc1_metres_reads_as_millimetres(tmp_path):
    metres = np.full((H, W), 2.25, np.float32)
    metres[0, 0] = np.nan
    path = tmp_path / "bag"
    _write_ros2_bag(path, "32FC1", [metres])
    (got,) = list(open_depth_source(f"rosbag:{path}:/camera/depth/image_rect_raw"))
    assert got.frame.depth[0, 0] == 0 and got.frame.depth[1, 1] == 2250


def test_a_bag_with_a_wrong_encoding_or_topic_says_so(tmp_path):
    path = tmp_path / "bag"
    _write_ros2_bag(path, "mono8", [np.zeros((H, W), np.uint8)])
    with pytest.raises(DepthSourceError, match="mono8"):
        list(open_depth_source(f"rosbag:{path}:/camera/depth/image_rect_raw"))
    with pytest.raises(DepthSourceError, match="no topic /nope"):
        list(open_depth_source(f"rosbag:{path}:/nope"))


def _record_realsense(path, depth: bool = True):
    rs = pytest.importorskip("pyrealsense2", reason="the realsense extra (pyrealsense2) is not "
                             "installed")
    sd = rs.software_device()
    sensor = sd.add_sensor("Depth" if depth else "Color")
    intr = rs.intrinsics()
    intr.width, intr.height, intr.fx, intr.fy, intr.ppx, intr.ppy = W, H, 40.0, 40.0, 31.5, 23.5
    intr.model, intr.coeffs = rs.distortion.none, [0.0] * 5
    vs = rs.video_stream()
    vs.type = rs.stream.depth if depth else rs.stream.color
    vs.index, vs.uid, vs.width, vs.height, vs.fps = 0, 1, W, H, 15
    vs.bpp, vs.fmt, vs.intrinsics = (2, rs.format.z16, intr) if depth else (3, rs.format.rgb8, intr)
    profile = sensor.add_video_stream(vs)
    if depth:
        sensor.add_read_only_option(rs.option.depth_units, 0.001)
    recorder = rs.recorder(str(path), sd)
    queue = rs.frame_queue(10)
    sensor.open(profile)
    sensor.start(queue)
    frames = []
    for i in range(3):
        pixels = (np.arange(W * H, dtype=np.uint16).reshape(H, W) + 1000 * i) if depth \
            else np.zeros((H, W, 3), np.uint8)
        frames.append(pixels)
        f = rs.software_video_frame()
        f.pixels, f.bpp, f.stride = pixels, vs.bpp, W * vs.bpp
        f.timestamp, f.domain, f.frame_number = 5000.0 + 100.0 * i, \
            rs.timestamp_domain.system_time, i
        f.profile = profile.as_video_stream_profile()
        sensor.on_video_frame(f)
    sensor.stop()
    sensor.close()
    del recorder
    return frames


def test_a_realsense_recording_plays_back_every_frame_through_the_sdk(tmp_path):
    pytest.importorskip("pyrealsense2", reason="the depth extra (pyrealsense2) is not installed")
    from companion.core.perception.depth_frame import DepthFrame, DepthIntrinsics
    from companion.tools.depth_bags import RealSenseBagWriter, camera_path
    intr = DepthIntrinsics(W, H, 40.0, 40.0, 31.5, 23.5, 0.3, 20.0)
    frames_in = [DepthFrame(i, 5000 + 100 * i, 0, intr,
                            np.arange(W * H, dtype=np.uint16).reshape(H, W) + 1000 * i)
                 for i in range(5)]
    writer = RealSenseBagWriter(tmp_path / "flight.db3")     # companion depth-record's writer
    for frame in frames_in:
        writer.write(frame)
    writer.close()
    got = list(open_depth_source(f"realsense-bag:{camera_path(tmp_path / 'flight.db3', 0)}"))
    assert [g.frame.frame_number for g in got] == [0, 1, 2, 3, 4]
    for sourced, frame in zip(got, frames_in):
        assert np.array_equal(sourced.frame.depth, frame.depth)
    assert got[1].host_time_s == pytest.approx(5.1)
    assert got[0].frame.intrinsics.fx_px == pytest.approx(40.0)
    assert got[0].frame.intrinsics.depth_scale_m == pytest.approx(0.001)


def test_a_recording_without_a_depth_stream_is_refused(tmp_path):
    path = tmp_path / "colour.db3"
    _record_realsense(path, depth=False)
    with pytest.raises(DepthSourceError, match="no depth stream"):
        list(open_depth_source(f"realsense-bag:{path}"))


def test_no_camera_is_a_clear_error():
    pytest.importorskip("pyrealsense2", reason="the realsense extra (pyrealsense2) is not installed")
    import pyrealsense2 as rs
    if len(rs.context().query_devices()):
        pytest.skip("a RealSense camera is plugged in")
    with pytest.raises(DepthSourceError, match="no RealSense camera"):
        next(iter(open_depth_source("realsense")))


def test_the_stubs_stream_reads_through_the_same_interface():
    import socket
    import threading
    from types import SimpleNamespace

    from sitl_stub.depth_stream import encode_frame
    spec = SimpleNamespace(width_px=W, height_px=H, fx_px=40.0, fy_px=40.0, cx_px=31.5,
                           cy_px=23.5, min_depth_m=0.3, max_depth_m=20.0, depth_scale_m=0.001)
    frames = [SimpleNamespace(spec=spec, pixels=np.full((H, W), 500 * (i + 1), np.uint16),
                              frame_number=i, time_boot_ms=1000 + 67 * i, camera_id=0)
              for i in range(2)]
    server = socket.create_server(("127.0.0.1", 0))
    port = server.getsockname()[1]

    def serve():
        conn, _ = server.accept()
        with conn:
            for f in frames:
                conn.sendall(encode_frame(f))
        server.close()

    thread = threading.Thread(target=serve, daemon=True)
    thread.start()
    got = list(open_depth_source(f"stub:127.0.0.1:{port}"))
    thread.join(timeout=5.0)
    assert [g.frame.time_boot_ms for g in got] == [1000, 1067]
    assert all(g.host_time_s is None for g in got)           # the vehicle's clock already
    assert np.array_equal(got[1].frame.depth, frames[1].pixels)


def test_a_stub_that_is_not_there_is_a_clear_error():
    import socket
    with socket.create_server(("127.0.0.1", 0)) as probe:
        port = probe.getsockname()[1]                         # closed again: nobody listens
    with pytest.raises(DepthSourceError, match="cannot connect"):
        next(iter(open_depth_source(f"stub:127.0.0.1:{port}")))
