"""companion depth-record's bags (companion/tools/depth_bags.py): a short flight's rendered depth
frames written as a ROS 2 bag and as the RealSense SDK's own recording, read back through
rosbags and through pyrealsense2's playback, equal the frames rendered, pixel for pixel."""
from __future__ import annotations

import dataclasses
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

from companion.config.scenario import load_scenario
from companion.sim.simulation import run_once
from companion.tools.depth_bags import BagSink, camera_path, image_topic, info_topic

REPO = Path(__file__).resolve().parents[2]


def record(tmp_path, rosbag=None, realsense=None, cameras=1):
    data = yaml.safe_load((REPO / "config/scenarios/depth-pitched.yaml").read_text())
    data["sensor"]["depth"].update(width_px=160, height_px=90)
    if cameras == 2:
        data["sensor"]["cameras"].append({"yaw_deg": 90.0, "pitch_deg": -10.0})
    data["mission"]["max_time_s"] = 1.0
    path = tmp_path / "depth-small.yaml"
    path.write_text(yaml.safe_dump(data))
    scenario = load_scenario(path)
    frames = []
    sink = BagSink(rosbag, realsense, scenario.sensor.depth.rate_hz)

    def keep(batch):
        frames.extend(batch)
        sink(batch)
    run_once(scenario, 3, depth_sink=keep)
    sink.close()
    return scenario, frames


def test_a_ros2_bag_read_back_through_rosbags_holds_the_rendered_frames(tmp_path):
    pytest.importorskip("rosbags", reason="the depth extra (pip install '.[depth]') is not installed")
    from rosbags.rosbag2 import Reader
    from rosbags.typesys import Stores, get_typestore
    scenario, frames = record(tmp_path, rosbag=tmp_path / "bag", cameras=2)
    assert len(frames) == 2 * 16 and any((f.depth > 0).any() for f in frames)   # 1 s at 15 Hz
    typestore = get_typestore(Stores.ROS2_HUMBLE)
    images, infos = [], []
    with Reader(tmp_path / "bag") as reader:
        for conn, stamp_ns, raw in reader.messages():
            msg = typestore.deserialize_cdr(raw, conn.msgtype)
            camera = int(conn.topic.split("/")[1].removeprefix("camera"))
            (images if conn.topic == image_topic(camera) else infos).append((camera, stamp_ns, msg))
            assert conn.topic in (image_topic(camera), info_topic(camera))
    assert len(images) == len(infos) == len(frames)
    by_key = {(f.camera_id, f.time_boot_ms): f for f in frames}
    for camera, stamp_ns, msg in images:
        frame = by_key[(camera, stamp_ns // 1_000_000)]
        assert msg.encoding == "16UC1" and msg.is_bigendian == 0 and msg.step == 2 * msg.width
        pixels = np.frombuffer(bytes(msg.data), dtype="<u2").reshape(msg.height, msg.width)
        assert np.array_equal(pixels, frame.depth)
        assert msg.header.stamp.sec * 1000 + msg.header.stamp.nanosec // 1_000_000 == \
            frame.time_boot_ms
    intr = frames[0].intrinsics
    for camera, _, info in infos:
        assert info.k.tolist() == [intr.fx_px, 0, intr.cx_px, 0, intr.fy_px, intr.cy_px, 0, 0, 1]
        assert (info.width, info.height) == (160, 90) and info.distortion_model == "plumb_bob"


def test_a_realsense_bag_plays_back_through_the_sdk_as_the_rendered_frames(tmp_path):
    rs = pytest.importorskip("pyrealsense2", reason="the depth extra (pip install '.[depth]', "
                                                    "and Debian's libusb-1.0-0) is not installed")
    _, frames = record(tmp_path, realsense=tmp_path / "flight.db3")
    assert camera_path(tmp_path / "flight.db3", 0).exists()
    device = rs.context().load_device(str(tmp_path / "flight.db3"))
    device.as_playback().set_real_time(False)
    sensor = device.query_sensors()[0]
    assert sensor.get_option(rs.option.depth_units) == pytest.approx(0.001)
    queue = rs.frame_queue(1000, True)
    sensor.open(sensor.get_stream_profiles())
    sensor.start(queue)
    played = []
    try:
        while True:
            ok, frame = queue.try_wait_for_frame(5000)
            if not ok:
                break
            depth = frame.as_depth_frame()
            played.append((depth.get_frame_number(), depth.get_timestamp(),
                           np.asanyarray(depth.get_data()).copy(),
                           depth.profile.as_video_stream_profile().get_intrinsics()))
    finally:
        sensor.stop()
        sensor.close()
    assert [p[0] for p in played] == [f.frame_number for f in frames]
    for (number, stamp_ms, pixels, intr), frame in zip(played, frames):
        assert stamp_ms == pytest.approx(frame.time_boot_ms)
        assert np.array_equal(pixels, frame.depth)
        assert (intr.width, intr.height) == (160, 90)
        assert intr.fx == pytest.approx(frame.intrinsics.fx_px, rel=1e-6)
        assert intr.ppy == pytest.approx(frame.intrinsics.cy_px, rel=1e-6)


def test_depth_record_needs_a_depth_scenario_and_says_so(tmp_path):
    done = subprocess.run([sys.executable, "-m", "companion", "depth-record", "--scenario",
                           "config/scenarios/copter.yaml", "--rosbag", str(tmp_path / "b")],
                          cwd=REPO, capture_output=True, text=True, timeout=120)
    assert done.returncode == 2 and "needs sensor.form: depth" in done.stderr


def test_depth_record_from_a_real_stub_stream_writes_a_bag_rosbags_reads(tmp_path):
    pytest.importorskip("rosbags", reason="the depth extra (pip install '.[depth]') is not installed")
    from rosbags.rosbag2 import Reader
    data = yaml.safe_load((REPO / "config/scenarios/depth.yaml").read_text())
    data["sensor"]["depth"].update(width_px=80, height_px=48)
    scenario = tmp_path / "small.yaml"
    scenario.write_text(yaml.safe_dump(data))
    stub = subprocess.Popen([sys.executable, "-m", "sitl_stub", "--scenario", str(scenario),
                             "--tcp", "127.0.0.1:0", "--depth-tcp", "127.0.0.1:0",
                             "--speedup", "5"], cwd=REPO, stdout=subprocess.PIPE,
                            stderr=subprocess.DEVNULL, text=True)
    try:
        fields = dict(part.split("=", 1) for part in stub.stdout.readline().split()[2:])
        done = subprocess.run([sys.executable, "-m", "companion", "depth-record", "--stub",
                               fields["depth"], "--frames", "12", "--rosbag",
                               str(tmp_path / "bag")], cwd=REPO, capture_output=True,
                              text=True, timeout=120)
    finally:
        stub.terminate()
        stub.wait(timeout=10)
    assert done.returncode == 0, done.stderr
    with Reader(tmp_path / "bag") as reader:
        stamps = [stamp for conn, stamp, _ in reader.messages()
                  if conn.topic == image_topic(0)]
    assert len(stamps) == 12
    steps = np.diff(stamps) / 1e6
    assert ((steps >= 66) & (steps <= 67)).all()            # consecutive frames at 15 Hz
