"""The stub's depth cameras (sitl_stub/depth_render.py, depth_camera.py, depth_stream.py): the
two renderers agree, the vehicle tilts with its acceleration, and the frames reach a reader over
a real socket from a real stub, in lock-step with its peer."""
from __future__ import annotations

import dataclasses
import math
import socket
import time

import numpy as np
import pytest
import yaml
from pymavlink.dialects.v20 import ardupilotmega as mav

from companion.config.scenario import load_scenario as companion_scenario
from companion.core.perception.depth_frame import CameraMount
from companion.depth.stub_stream import read_frame
from companion.sim.depth_camera import TruePose, render_true_m, scene_of
from companion.sim.depth_render import DepthRenderer, DepthScene, Prism, StereoErrors, sensor_errors
from sitl_stub import telemetry
from sitl_stub.depth_config import Mount
from sitl_stub.depth_render import render_ranges, to_z16
from sitl_stub.sim import Simulation
from sitl_stub.vehicle import Demand
from sitl_stub.world import load_scenario as stub_scenario

from ..sim.test_depth_heldout import random_world
from .support import REPO, connect_udp, start_stub, wait_until

DEPTH_YAML = REPO / "config" / "scenarios" / "depth.yaml"


def both_renderers(posts, prisms, pose: TruePose, mount: CameraMount, spec):
    """(companion Z16, stub Z16) of one world and pose, errors off."""
    arr = np.array(posts, dtype=float).reshape(-1, 5)
    scene = DepthScene(arr[:, :2], arr[:, 2], arr[:, 3], arr[:, 4],
                       tuple(Prism(np.asarray(c, float), b, t) for c, b, t in prisms))
    intr = companion_scenario(DEPTH_YAML).sensor.depth.intrinsics()
    ours = sensor_errors(render_true_m(DepthRenderer(intr), scene, pose, mount), intr,
                         StereoErrors.none(), np.random.default_rng(0))
    quiet = dataclasses.replace(spec, depth_noise=False, edge_shadow=False, dropout_fraction=0.0)
    theirs = to_z16(render_ranges(quiet, pose.north_m, pose.east_m, pose.alt_m, pose.roll_rad,
                                  pose.pitch_rad, pose.yaw_rad,
                                  Mount(mount.offset_frd_m, mount.roll_rad, mount.pitch_rad,
                                        mount.yaw_rad),
                                  posts, [([tuple(p) for p in c], b, t) for c, b, t in prisms]),
                    quiet, np.random.default_rng(0))
    return ours, theirs


def assert_agree(ours, theirs):
    both = (ours > 0) & (theirs > 0)
    assert both.sum() > 0.2 * both.size
    assert np.abs(ours[both].astype(int) - theirs[both].astype(int)).max() <= 1
    # where only one has data: silhouette pixels a ray grazes, a handful at most
    assert ((ours > 0) != (theirs > 0)).sum() <= 0.001 * both.size


@pytest.mark.parametrize("seed", [7, 8, 9])
def test_the_two_renderers_agree_within_a_millimetre_on_random_worlds(seed):
    rng = np.random.default_rng(seed)
    posts, prisms = random_world(rng)
    spec = stub_scenario(DEPTH_YAML).sensor.depth
    pose = TruePose(0.0, 0.0, float(rng.uniform(1.0, 6.0)), float(rng.uniform(-0.2, 0.2)),
                    float(rng.uniform(-0.2, 0.2)), float(rng.uniform(-0.3, 0.3)))
    mount = CameraMount((0.1, 0.0, 0.05), 0.0, float(rng.uniform(-0.4, 0.0)), 0.0)
    assert_agree(*both_renderers(posts, prisms, pose, mount, spec))


def test_the_two_renderers_agree_on_the_depth_scenario_from_its_own_files():
    world = companion_scenario(DEPTH_YAML).world
    scene = scene_of(world, 0.0)
    posts = [(float(c[0]), float(c[1]), float(r), float(b), float(t)) for c, r, b, t in
             zip(scene.post_ne_m, scene.post_radius_m, scene.post_base_m, scene.post_top_m)]
    stub_world = stub_scenario(DEPTH_YAML).world
    assert [(o.north_m, o.east_m, o.radius_m) for o in stub_world.obstacles] == \
        [p[:3] for p in posts]
    pose = TruePose(50.0, 1.0, 10.0, 0.05, -0.12, 0.1)       # posts 10 and 70 m ahead
    ours, theirs = both_renderers(posts, [], pose, CameraMount((0.1, 0.0, 0.0)),
                                  stub_scenario(DEPTH_YAML).sensor.depth)
    assert (ours[200:280, 300:500] > 0).any()                 # the first post, in view
    assert_agree(ours, theirs)


def test_a_stub_multicopter_accelerating_pitches_nose_down_by_atan_a_over_g_and_reports_it():
    sim = Simulation(stub_scenario(DEPTH_YAML), seed=0)
    sim.step(Demand(vel_north_mps=5.0, target_up_m=0.0), armed=True)
    accel = sim.truth.vel_north_mps / sim.dt_s
    assert accel == pytest.approx(sim.scenario.vehicle.max_accel_mps2)
    roll, pitch = sim.tilt_rad
    assert pitch == pytest.approx(-math.atan(accel / 9.80665)) and roll == pytest.approx(0.0)
    msg = telemetry.attitude(sim.t_s, 0.0, 0.0, *sim.tilt_rad)
    assert msg.pitch == pytest.approx(pitch, abs=1e-6) and msg.roll == pytest.approx(0.0)
    sim.step(Demand(vel_north_mps=5.0, target_up_m=0.0), armed=False)
    assert sim.tilt_rad == (0.0, 0.0)                          # on the ground: level


def small_depth_scenario(tmp_path):
    data = yaml.safe_load(DEPTH_YAML.read_text())
    data["sensor"]["depth"].update(width_px=212, height_px=120)
    path = tmp_path / "depth-small.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def test_frames_stream_over_a_real_socket_in_lock_step_with_increasing_numbers(tmp_path):
    scenario = small_depth_scenario(tmp_path)
    intr = companion_scenario(scenario).sensor.depth.intrinsics()
    stub = start_stub(tmp_path, "--udp", "127.0.0.1:0", "--lockstep", "--depth-tcp",
                      "127.0.0.1:0", scenario=scenario)
    conn = connect_udp(stub.udp_port)
    depth = socket.create_connection(("127.0.0.1", stub.depth_port), timeout=10.0)
    try:
        stream = depth.makefile("rb")
        conn.mav.heartbeat_send(18, 8, 0, 0, 0)
        for msg_id in (32, 30):
            conn.mav.command_long_send(1, 1, mav.MAV_CMD_SET_MESSAGE_INTERVAL, 0, msg_id,
                                       100_000, 0, 0, 0, 0, 0)
        answered_ms = -1
        frames = []
        deadline = time.monotonic() + 30.0
        while answered_ms < 1000 and time.monotonic() < deadline:
            msg = conn.recv_match(type="LOCAL_POSITION_NED", blocking=True, timeout=0.5)
            if msg is None or msg.time_boot_ms <= answered_ms:
                continue
            nan = float("nan")
            # every frame up to this sample's time has been sent before the sample
            while not frames or frames[-1].time_boot_ms + 67 <= msg.time_boot_ms:
                frames.append(read_frame(stream))
            answered_ms = msg.time_boot_ms
            conn.mav.send(mav.MAVLink_odometry_message(
                answered_ms * 1000, 1, 12, 0, 0, nan, [1, 0, 0, 0], nan, nan, nan, nan, nan,
                nan, [nan] * 21, [nan] * 21, 0, 3, 0))
        assert answered_ms >= 1000
        numbers = [f.frame_number for f in frames]
        assert numbers == list(range(len(numbers)))            # from frame 0, none missed
        assert all(f.time_boot_ms == round(f.frame_number * 1000 / 15) for f in frames)
        assert frames[-1].time_boot_ms <= answered_ms + 100     # never ahead of the lock
        first = frames[0]
        assert first.camera_id == 0 and first.depth.shape == (120, 212)
        assert first.intrinsics == dataclasses.replace(intr)
    finally:
        depth.close()
        conn.close()
        assert stub.stop() == 0
    wait_until(lambda: "frames sent" in stub.stderr(), 5.0)


def test_the_two_occlusion_shadows_agree_and_the_stubs_noise_follows_intels_model():
    from companion.sim.depth_render import occlusion_shadow
    from sitl_stub.depth_render import shadow_mask
    spec = stub_scenario(DEPTH_YAML).sensor.depth
    posts = [(6.0, 0.0, 0.4, 0.0, math.inf), (12.0, 1.5, 1.0, 0.0, math.inf)]
    quiet = dataclasses.replace(spec, depth_noise=False, edge_shadow=False, dropout_fraction=0.0)
    depth = render_ranges(quiet, 0.0, 0.0, 2.0, 0.0, 0.0, 0.0, Mount(), posts, [])
    theirs = shadow_mask(depth, spec)
    ours = occlusion_shadow(depth, spec.fx_px, spec.baseline_m)
    assert theirs.sum() > 1000 and (theirs == ours).all()
    # noise on: the RMS at 4 m within 15% of sigma_z = z^2 subpixel / (fx baseline)
    wall = [([(4.0, -30.0), (4.3, -30.0), (4.3, 30.0), (4.0, 30.0)], 0.0, 30.0)]
    noisy = dataclasses.replace(spec, edge_shadow=False, dropout_fraction=0.0)
    true_m = render_ranges(noisy, 0.0, 0.0, 10.0, 0.0, 0.0, 0.0, Mount(), [], wall)
    rng = np.random.default_rng(5)
    errors = np.concatenate([(to_z16(true_m, noisy, rng)[100:380, 200:648] * 0.001
                              - true_m[100:380, 200:648]).ravel() for _ in range(5)])
    model = 16.0 * spec.subpixel / (spec.fx_px * spec.baseline_m)
    assert abs(np.sqrt(np.mean(errors ** 2)) - model) <= 0.15 * model
