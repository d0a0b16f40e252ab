"""Soak: a long flight of `companion run` against the stub; the daemon's memory over time.

    python -m benchmarks.soak [--minutes 5] [--speedup 20] [--scenario config/scenarios/soak.yaml]

Starts sitl-stub (the soak scenario: a field of obstacles, then a goal no soak reaches) and the
daemon (`companion run --report`, so the track is recorded too, as the demo does), sets GUIDED,
arms and takes off to 10 m as a ground station, and samples the daemon's resident memory (psutil) every few
seconds of wall time. Prints RSS at the first minute and at the end, the growth between them,
the growth over the second half of the soak (a leak keeps growing there; warm-up does not), the
simulated distance flown, and the daemon's counters from its final report.

Warm-up to expect: the report's track (pipeline.track, a deque of REPORT_TRACK_ROWS = 36,000
rows of 13 doubles, about 210 bytes each with their array objects: ~7 MB) fills at one row per
odometry sample, i.e. in 3600 s of vehicle time, about a minute of wall time in lock-step.
RSS grows linearly until then and is flat after (measured: +6.3% up to 62 s, +0.0% after).
"""
from __future__ import annotations

import argparse
import json
import os
import signal
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import psutil
import yaml

os.environ.setdefault("MAVLINK20", "1")
from pymavlink import mavutil  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
SAMPLE_S = 5.0
FIRST_MINUTE_S = 60.0


@dataclass
class SoakResult:
    rss_first_minute_mb: float
    rss_end_mb: float
    wall_s: float
    samples: list[tuple[float, float]]      # (wall s, RSS MB)
    report: dict

    @property
    def growth(self) -> float:
        return self.rss_end_mb / self.rss_first_minute_mb - 1.0

    @property
    def rss_half_time_mb(self) -> float:
        """RSS at the sample nearest half the soak's wall time."""
        return min(self.samples, key=lambda s: abs(s[0] - self.wall_s / 2))[1]

    @property
    def growth_second_half(self) -> float:
        return self.rss_end_mb / self.rss_half_time_mb - 1.0


def _ready_ports(stub: subprocess.Popen, timeout_s: float = 20.0) -> tuple[int, int]:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        line = stub.stdout.readline()
        if line.startswith("SITL_STUB READY"):
            ports = dict(part.split("=", 1) for part in line.split()[2:])
            return int(ports["tcp"].rsplit(":", 1)[1]), int(ports["udp"].rsplit(":", 1)[1])
        if not line and stub.poll() is not None:
            break
    raise RuntimeError("sitl-stub did not get ready")


def _command(conn, command: int, *params: float, timeout_s: float = 15.0) -> None:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        conn.mav.command_long_send(1, 1, command, 0, *params, *[0] * (7 - len(params)))
        ack = conn.recv_match(type="COMMAND_ACK", blocking=True, timeout=0.5)
        if ack is not None and ack.command == command and ack.result == 0:
            return
    raise RuntimeError(f"command {command} not accepted")


def soak(minutes: float, speedup: float, scenario: Path, workdir: Path,
         lockstep: bool = True) -> SoakResult:
    """Fly for ``minutes`` of wall time; RSS of the daemon at the first minute and at the end.
    ``lockstep``: stub and daemon in lock-step (``speedup`` paces only the stub's fallback)."""
    pace = ["--lockstep"] if lockstep else []
    config = yaml.safe_load((REPO / "config" / "companion.yaml").read_text())
    world = yaml.safe_load(scenario.read_text())
    config["goal"] = dict(world["world"]["goal"])
    config["avoidance"].update(mission_time_s=None)
    config_path = workdir / "companion.yaml"
    config_path.write_text(yaml.safe_dump(config))
    report_path = workdir / "report.json"
    stub = subprocess.Popen(
        [sys.executable, "-m", "sitl_stub", "--scenario", str(scenario), "--tcp", "127.0.0.1:0",
         "--udp", "127.0.0.1:0", "--speedup", str(speedup), *pace], stdout=subprocess.PIPE,
        stderr=open(workdir / "stub.stderr", "w"), text=True, cwd=REPO)
    daemon = None
    try:
        tcp_port, udp_port = _ready_ports(stub)
        daemon = subprocess.Popen(
            [sys.executable, "-m", "companion", "run", "--connect", f"udpout:127.0.0.1:{udp_port}",
             "--config", str(config_path), "--report", str(report_path), *pace],
            stdout=subprocess.DEVNULL, stderr=open(workdir / "companion.stderr", "w"), cwd=REPO)
        gcs = mavutil.mavlink_connection(f"tcp:127.0.0.1:{tcp_port}", source_system=255,
                                         source_component=190)
        gcs.wait_heartbeat(timeout=10)
        deadline = time.monotonic() + 20.0
        while not report_path.exists():          # the daemon's estimator has started
            if time.monotonic() > deadline or daemon.poll() is not None:
                raise RuntimeError("the companion's estimator did not start")
            time.sleep(0.1)
        _command(gcs, mavutil.mavlink.MAV_CMD_DO_SET_MODE, 1, 4)
        _command(gcs, mavutil.mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1)
        _command(gcs, mavutil.mavlink.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, 0, 0, 0, 10.0)  # airborne first
        process = psutil.Process(daemon.pid)
        started = time.monotonic()
        samples: list[tuple[float, float]] = []
        first_minute_mb = None
        end_s = minutes * 60.0
        while (elapsed := time.monotonic() - started) < end_s:
            if daemon.poll() is not None or stub.poll() is not None:
                raise RuntimeError("a process died during the soak; see the stderr files in "
                                   f"{workdir}")
            rss_mb = process.memory_info().rss / 2 ** 20
            samples.append((elapsed, rss_mb))
            if first_minute_mb is None and elapsed >= FIRST_MINUTE_S:
                first_minute_mb = rss_mb
            # drain the ground station's socket (the stub streams to it)
            while gcs.recv_match(blocking=False) is not None:
                pass
            time.sleep(min(SAMPLE_S, max(end_s - elapsed, 0.0)))
        rss_end_mb = process.memory_info().rss / 2 ** 20
        wall_s = time.monotonic() - started
        gcs.close()
    finally:
        for proc in (daemon, stub):
            if proc is not None and proc.poll() is None:
                proc.send_signal(signal.SIGTERM)
                try:
                    proc.wait(timeout=10)
                except subprocess.TimeoutExpired:
                    proc.kill()
    report = json.loads(report_path.read_text())
    return SoakResult(first_minute_mb or samples[-1][1], rss_end_mb, wall_s, samples, report)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--minutes", type=float, default=5.0, help="wall minutes (default 5)")
    parser.add_argument("--speedup", type=float, default=20.0,
                        help="the stub's pace without lock-step (and its fallback with it)")
    parser.add_argument("--no-lockstep", action="store_true",
                        help="the stub on the wall clock at --speedup instead of lock-step")
    parser.add_argument("--scenario", type=Path, default=REPO / "config/scenarios/soak.yaml")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="soak-") as tmp:
        result = soak(args.minutes, args.speedup, args.scenario, Path(tmp),
                      lockstep=not args.no_lockstep)
    report = result.report
    track_t = report["track"]["t_s"]
    print(f"soak: {result.wall_s:.0f} s wall at speedup {args.speedup:g}, "
          f"{(track_t[-1] - track_t[0]) if track_t else 0:.0f} s simulated in the report's track "
          f"({len(track_t)} rows)")
    print(f"daemon RSS at the first minute: {result.rss_first_minute_mb:.1f} MB")
    print(f"daemon RSS at the end:          {result.rss_end_mb:.1f} MB "
          f"({100 * result.growth:+.1f} %)")
    print(f"daemon RSS at half time:        {result.rss_half_time_mb:.1f} MB "
          f"(second half {100 * result.growth_second_half:+.1f} %)")
    print("RSS samples (wall s, MB): " + ", ".join(f"{t:.0f}:{m:.1f}" for t, m in result.samples))
    print(f"landmarks {len(report['landmarks'])}, setpoints {report['setpoints']}, "
          f"counters {report['counters']}, link {report['link']}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
