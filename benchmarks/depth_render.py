"""The simulated depth cameras' cost (issue 43): render time per frame and the stub's lock-step
step rate with the depth camera on and off.

    python -m benchmarks.depth_render [--frames 100] [--steps 150]

1. Render: a forest of 50 trees (trunks 0.15 to 0.5 m, 6 to 20 m tall) 3 to 20 m ahead within
   the view, seen from 3 m up with a flying tilt (roll 2 deg, pitch -5 deg), at 848x480 and
   424x240 (D455's 87 x 58 deg): p50 / p99 per frame of companion/sim's renderer (ray casting
   alone, the stereo errors alone, both) and of the stub's (both), over --frames frames with the
   camera moving 0.3 m a frame. Wall time (time.perf_counter) of this process, and its CPU
   time (time.process_time: without the waits for a core on a loaded machine).
2. Lock-step: sitl-stub --lockstep on that forest (the vehicle on the ground; its camera, at the
   ground, sees the trunks), a pymavlink peer answering every sample at once; --steps steps
   with --depth-tcp (a reader taking every frame) and without. Steps per wall second, and the
   stub's own CPU per step (its main thread's on-CPU time, /proc/PID/schedstat: what the code
   costs whatever else the machine runs).
"""
from __future__ import annotations

import argparse
import math
import os
import socket
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np
import yaml

REPO = Path(__file__).resolve().parents[1]
DEPTH_YAML = REPO / "config/scenarios/depth.yaml"
TREES = 50


def forest(seed: int = 50) -> list[tuple[float, float, float, float, float]]:
    """(north, east, radius, base, top) of TREES trunks in the view, 3 to 20 m ahead."""
    rng = np.random.default_rng(seed)
    out = []
    while len(out) < TREES:
        dist, bearing = rng.uniform(3.0, 20.0), rng.uniform(-0.7, 0.7)
        out.append((dist * math.cos(bearing), dist * math.sin(bearing),
                    float(rng.uniform(0.15, 0.5)), 0.0, float(rng.uniform(6.0, 20.0))))
    return out


def percentiles_ms(times_s: list[float]) -> str:
    a = np.array(times_s) * 1000.0
    return f"p50 {np.percentile(a, 50):6.2f} ms  p99 {np.percentile(a, 99):6.2f} ms"


def bench_render(frames: int) -> None:
    from companion.config.depth import DepthConfig
    from companion.core.perception.depth_frame import CameraMount
    from companion.sim.depth_camera import TruePose, render_true_m
    from companion.sim.depth_render import DepthRenderer, DepthScene, ErrorModel, StereoErrors
    from sitl_stub.depth_config import Mount
    from sitl_stub.depth_render import StubRenderer, to_z16
    from sitl_stub.world import load_scenario as stub_scenario
    trees = forest()
    arr = np.array(trees)
    scene = DepthScene(arr[:, :2], arr[:, 2], arr[:, 3], arr[:, 4])
    for width, height in ((848, 480), (424, 240)):
        config = DepthConfig(width_px=width, height_px=height)
        intr = config.intrinsics()
        renderer = DepthRenderer(intr)
        errors = ErrorModel(intr, StereoErrors.of(config))
        rng = np.random.default_rng(0)
        out = np.empty((height, width))
        cast, noisy, both, stub, cpu_both, cpu_stub = [], [], [], [], [], []
        spec = stub_scenario(DEPTH_YAML).sensor.depth
        spec = type(spec)(**{**spec.__dict__, "width_px": width, "height_px": height,
                             "fx_px": intr.fx_px, "fy_px": intr.fy_px, "cx_px": intr.cx_px,
                             "cy_px": intr.cy_px})
        stub_rng = np.random.default_rng(0)
        stub_renderer = StubRenderer(spec)
        seen = 0.0
        for k in range(frames):
            pose = TruePose(-0.3 * (k % 10), 0.0, 3.0, math.radians(2.0), math.radians(-5.0), 0.0)
            c0 = time.process_time()
            t0 = time.perf_counter()
            true_m = render_true_m(renderer, scene, pose, CameraMount(), out)
            t1 = time.perf_counter()
            pixels = errors(true_m, rng)
            t2 = time.perf_counter()
            c1 = time.process_time()
            to_z16(stub_renderer.ranges(pose.north_m, pose.east_m, pose.alt_m, pose.roll_rad,
                                        pose.pitch_rad, pose.yaw_rad, Mount(), trees, []), spec,
                   stub_rng)
            t3 = time.perf_counter()
            cpu_stub.append(time.process_time() - c1)
            cpu_both.append(c1 - c0)
            cast.append(t1 - t0)
            noisy.append(t2 - t1)
            both.append(t2 - t0)
            stub.append(t3 - t2)
            seen += float((pixels > 0).mean())
        print(f"{width}x{height}, {TREES} trees, {frames} frames ({seen / frames:.0%} of pixels "
              "with data)")
        print(f"  companion ray casting   {percentiles_ms(cast)}")
        print(f"  companion errors        {percentiles_ms(noisy)}")
        print(f"  companion frame (both)  {percentiles_ms(both)}")
        print(f"  stub frame (both)       {percentiles_ms(stub)}")
        print(f"  CPU time: companion frame {percentiles_ms(cpu_both)}, stub frame "
              f"{percentiles_ms(cpu_stub)}")


def _schedstat_ns(pid: int) -> int:
    return int(Path(f"/proc/{pid}/task/{pid}/schedstat").read_text().split()[0])


def bench_lockstep(steps: int, depth: bool, scenario: Path) -> tuple[float, float, int]:
    """(steps per wall second, stub CPU ms per step, frames read) of one lock-step run."""
    os.environ["MAVLINK20"] = "1"
    from pymavlink import mavutil
    from pymavlink.dialects.v20 import ardupilotmega as mav
    args = [sys.executable, "-m", "sitl_stub", "--scenario", str(scenario), "--tcp", "none",
            "--udp", "127.0.0.1:0", "--lockstep", "--log-level", "WARNING"]
    if depth:
        args += ["--depth-tcp", "127.0.0.1:0"]
    proc = subprocess.Popen(args, cwd=REPO, stdout=subprocess.PIPE, text=True)
    frames = [0]
    try:
        fields = dict(p.split("=", 1) for p in proc.stdout.readline().split()[2:])
        conn = mavutil.mavlink_connection(f"udpout:{fields['udp']}", source_system=255)
        if depth:
            host, port = fields["depth"].rsplit(":", 1)
            sock = socket.create_connection((host, int(port)))

            def drain() -> None:
                while sock.recv(1 << 20):
                    frames[0] += 1          # (chunks, not frames: counted below from bytes)
            threading.Thread(target=drain, daemon=True).start()
        conn.mav.heartbeat_send(18, 8, 0, 0, 0)
        for msg_id in (32, 30):
            conn.mav.command_long_send(1, 1, mav.MAV_CMD_SET_MESSAGE_INTERVAL, 0, msg_id,
                                       100_000, 0, 0, 0, 0, 0)
        nan = float("nan")
        answered, start = -1, None
        while answered < steps * 100:
            msg = conn.recv_match(type="LOCAL_POSITION_NED", blocking=True, timeout=5.0)
            if msg is None:
                raise RuntimeError("the stub stopped sending")
            if msg.time_boot_ms <= answered:
                continue
            if start is None:
                start = (time.perf_counter(), _schedstat_ns(proc.pid), msg.time_boot_ms)
            answered = msg.time_boot_ms
            conn.mav.send(mav.MAVLink_odometry_message(
                answered * 1000, 1, 12, 0, 0, nan, [1, 0, 0, 0], nan, nan, nan, nan, nan, nan,
                [nan] * 21, [nan] * 21, 0, 3, 0))
        wall = time.perf_counter() - start[0]
        cpu_ns = _schedstat_ns(proc.pid) - start[1]
        done = (answered - start[2]) / 100
        return done / wall, cpu_ns / 1e6 / done, frames[0]
    finally:
        proc.terminate()
        proc.wait(timeout=10)


def forest_scenario(tmp: Path) -> Path:
    data = yaml.safe_load(DEPTH_YAML.read_text())
    start = data["world"]["start"]
    data["world"]["obstacles"] = [
        {"id": i + 1, "north_m": start["north_m"] + n, "east_m": start["east_m"] + e,
         "radius_m": r, "height_m": top} for i, (n, e, r, _, top) in enumerate(forest())]
    data["world"]["goal"] = {"north_m": start["north_m"] - 50.0, "east_m": 0.0, "radius_m": 2.0}
    path = tmp / "forest-depth.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--frames", type=int, default=100)
    p.add_argument("--steps", type=int, default=150)
    args = p.parse_args(argv)
    print(f"{time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}, {os.cpu_count()} CPUs, load "
          f"average {os.getloadavg()[0]:.2f}")
    bench_render(args.frames)
    with tempfile.TemporaryDirectory() as tmp:
        scenario = forest_scenario(Path(tmp))
        for depth in (False, True):
            rate, cpu_ms, _ = bench_lockstep(args.steps, depth, scenario)
            print(f"stub lock-step, depth camera {'on ' if depth else 'off'} (848x480, 15 Hz): "
                  f"{rate:6.1f} steps/s wall, stub CPU {cpu_ms:6.2f} ms/step")
    return 0


if __name__ == "__main__":
    sys.exit(main())
