"""The two motion models on real ArduCopter odometry: how far each drifts from the autopilot.

    python -m benchmarks.ardupilot_odometry [--binary /work/shared/ardupilot] [--speedup 5]

Starts ArduCopter 4.6 SITL (instance 7, TCP 5830; /work/shared/ardupilot/README.md), acts as the
ground station: streams, GUIDED, arm, NAV_TAKEOFF to 10 m, then flies a plan of velocity + yaw
setpoints (the service's type mask): hover, east with the yaw held north (a 90 degree crab), north,
a diagonal with the yaw off the course, hover. It records every ATTITUDE and LOCAL_POSITION_NED and
replays them through the service's pipeline (estimate only) with each motion model, position
fusion off (GPS-denied), and the multicopter's with fusion 'auto' (GPS_RAW_INT, EKF_STATUS_REPORT). The autopilot's own position (SITL's GPS is exact) is the reference.

Prints, per model: the final and largest horizontal distance from the autopilot's position, and the
filter's own 2-sigma radius at the end.
"""
from __future__ import annotations

import argparse
import dataclasses
import gzip
import json
import math
import os
import shutil
import subprocess
import tempfile
import time
from pathlib import Path

os.environ.setdefault("MAVLINK20", "1")
from pymavlink import mavutil  # noqa: E402

from companion.mavlink import codec  # noqa: E402
from companion.config.service import load_config  # noqa: E402
from companion.core.estimation.consistency import radius_2sigma_m  # noqa: E402
from companion.onboard.pipeline import Pipeline  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
INSTANCE = 7
PORT = 5760 + 10 * INSTANCE
# (seconds, vel_north_mps, vel_east_mps, yaw_deg)
PLAN = ((30.0, 0.0, 0.0, 0.0), (20.0, 0.0, 5.0, 0.0), (20.0, 5.0, 0.0, 0.0),
        (20.0, -3.0, -3.0, 90.0), (30.0, 0.0, 0.0, 90.0))
MASK = codec.VELOCITY_YAW_TYPE_MASK


def start_sitl(binary_dir: Path, workdir: Path, speedup: float) -> subprocess.Popen:
    exe = workdir / "arducopter"
    with gzip.open(binary_dir / "arducopter-4.6-sitl.gz") as src, open(exe, "wb") as dst:
        shutil.copyfileobj(src, dst)
    exe.chmod(0o755)
    return subprocess.Popen(
        [str(exe), "--model", "+", "--speedup", str(speedup), "--defaults",
         str(binary_dir / "copter-4.6.parm"), f"-I{INSTANCE}",
         "--home", "-35.363261,149.165230,584,0"],
        cwd=workdir, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)


def connect(deadline_s: float):
    while True:
        try:
            link = mavutil.mavlink_connection(f"tcp:127.0.0.1:{PORT}", source_system=255,
                                              source_component=190)
            link.wait_heartbeat(timeout=5)
            return link
        except Exception:      # the SITL is still starting (connection refused)
            if time.monotonic() > deadline_s:
                raise
            time.sleep(0.5)


def fly(link, recorded: list, speedup: float) -> None:
    """Take off in GUIDED and fly PLAN, recording (wall time, message) of what the companion reads."""
    mav = link.mav
    sysid, compid = link.target_system, 1          # the autopilot component
    for msg_id, rate in ((30, 10.0), (32, 10.0), (24, 2.0), (193, 2.0)):
        mav.command_long_send(sysid, compid, mavutil.mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, 0,
                              msg_id, 1e6 / rate, 0, 0, 0, 0, 0)
    phase, phase_t, t_boot = "arm", time.monotonic(), 0.0
    plan_start = None
    deadline = time.monotonic() + 600.0 / speedup + 120.0
    while time.monotonic() < deadline:
        msg = link.recv_match(blocking=True, timeout=1.0)
        if msg is None:
            continue
        kind = msg.get_type()
        if kind in ("HEARTBEAT", "ATTITUDE", "LOCAL_POSITION_NED", "GPS_RAW_INT",
                    "EKF_STATUS_REPORT") and msg.get_srcComponent() == 1:
            recorded.append((time.monotonic(), bytes(msg.get_msgbuf())))
        if kind == "STATUSTEXT":
            print("  autopilot:", msg.text)
        if kind != "LOCAL_POSITION_NED":
            if phase == "arm" and time.monotonic() - phase_t > 2.0:
                phase_t = time.monotonic()
                mav.command_long_send(sysid, compid, mavutil.mavlink.MAV_CMD_DO_SET_MODE, 0,
                                      mavutil.mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, 4,
                                      0, 0, 0, 0, 0)
                mav.command_long_send(sysid, compid,
                                      mavutil.mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 0, 1,
                                      0, 0, 0, 0, 0, 0)
            if kind == "HEARTBEAT" and phase == "arm" and \
                    msg.base_mode & mavutil.mavlink.MAV_MODE_FLAG_SAFETY_ARMED:
                phase = "takeoff"
                mav.command_long_send(sysid, compid, mavutil.mavlink.MAV_CMD_NAV_TAKEOFF, 0,
                                      0, 0, 0, 0, 0, 0, 10.0)
                print("  armed: taking off")
            continue
        t_boot = msg.time_boot_ms / 1000.0
        if phase == "takeoff" and msg.z < -9.5:
            phase, plan_start = "plan", t_boot
            print(f"  at 10 m after {t_boot:.0f} s of vehicle time: flying the plan")
        if phase != "plan":
            continue
        elapsed, t0 = t_boot - plan_start, 0.0
        for duration, vn, ve, yaw_deg in PLAN:
            if elapsed < t0 + duration:
                mav.set_position_target_local_ned_send(
                    msg.time_boot_ms, sysid, compid, mavutil.mavlink.MAV_FRAME_LOCAL_NED, MASK,
                    0, 0, 0, vn, ve, 0, 0, 0, 0, math.radians(yaw_deg), 0)
                break
            t0 += duration
        else:
            return
    raise RuntimeError(f"the flight did not finish (phase {phase})")


def replay(recorded: list, motion_model: str, position_fusion: str = "off") -> dict:
    base = load_config(REPO / "config" / "companion.yaml")
    config = dataclasses.replace(
        base, estimator=dataclasses.replace(base.estimator, motion_model=motion_model,
                                            position_fusion=position_fusion),
        failsafe=dataclasses.replace(base.failsafe, require_camera=False))
    pipeline = Pipeline(config, None)
    parser = codec.Parser()
    worst, last = 0.0, None
    started = False
    for t_link, packet in recorded:
        msg = parser.decode_packet(packet)
        event = codec.decode(msg) if msg is not None else None
        if event is None:
            continue
        # Start once at 10 m: the estimate of a flight, not of the takeoff.
        if isinstance(event, (codec.LocalPosition, codec.Attitude)) and not started:
            if not (isinstance(event, codec.LocalPosition) and msg.z < -9.5):
                continue
            started = True
        pipeline.handle(t_link, event)
        nav = pipeline.navigator
        if isinstance(event, codec.LocalPosition) and nav is not None:
            gap = math.hypot(nav.slam.pose[0] - event.north_m, nav.slam.pose[1] - event.east_m)
            worst, last = max(worst, gap), (gap, radius_2sigma_m(nav.slam.pose_cov))
    return {"final_m": last[0], "max_m": worst, "claimed_2sigma_m": last[1],
            "fixes": dict(pipeline.navigator.position_fixes)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--binary", type=Path, default=Path("/work/shared/ardupilot"))
    parser.add_argument("--speedup", type=float, default=5.0)
    parser.add_argument("--recording", type=Path,
                        help="replay this recording (JSON) instead of flying; or, with --save, "
                             "write the flight's there")
    parser.add_argument("--save", action="store_true")
    args = parser.parse_args()
    recorded: list = []
    if args.recording and not args.save:
        recorded = [(t, bytes.fromhex(h)) for t, h in json.loads(args.recording.read_text())]
    else:
        fly_sitl(args, recorded)
        if args.recording:
            args.recording.write_text(json.dumps([(t, p.hex()) for t, p in recorded]))
    report(recorded)


def fly_sitl(args, recorded: list) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        sitl = start_sitl(args.binary, Path(tmp), args.speedup)
        try:
            link = connect(time.monotonic() + 60.0)
            fly(link, recorded, args.speedup)
        finally:
            sitl.terminate()
            try:
                sitl.wait(timeout=10)
            except subprocess.TimeoutExpired:
                sitl.kill()


def report(recorded: list) -> None:
    plan = ", ".join(f"{d:.0f} s v=({vn:g},{ve:g}) yaw {y:g}" for d, vn, ve, y in PLAN)
    print(f"plan: {plan}; estimate from 10 m up, position fusion off")
    for model, fusion in (("paper", "off"), ("velocity_ned", "off"), ("velocity_ned", "auto")):
        r = replay(recorded, model, fusion)
        print(f"{model:13s} fusion {fusion:4s} final {r['final_m']:6.2f} m, max {r['max_m']:6.2f} m "
              f"from the autopilot's position; the filter's own 2-sigma "
              f"{r['claimed_2sigma_m']:.2f} m; fixes {r['fixes']}")


if __name__ == "__main__":
    main()
