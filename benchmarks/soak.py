"""Soak: a long flight of `companion run` against the stub; the daemon's memory over time.

    python -m benchmarks.soak [--minutes 5] [--speedup 20] [--scenario config/scenarios/soak.yaml]
    python -m benchmarks.soak --sim-hours 2          # issue 31: missions back to back, lock-step

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
import math
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


def _stop(*procs: subprocess.Popen | None) -> None:
    """SIGTERM each process still running, SIGKILL it after 10 s, and reap it."""
    for proc in procs:
        if proc is not None and proc.poll() is None:
            proc.send_signal(signal.SIGTERM)
            try:
                proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()


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
        _stop(daemon, stub)
    report = json.loads(report_path.read_text())
    return SoakResult(first_minute_mb or samples[-1][1], rss_end_mb, wall_s, samples, report)



# ---------------------------------------------------------------- missions back to back
# Issue 31's 2-hour soak: missions flown one after another in lock-step, the daemon run as
# config/companion.service runs it (`companion -v run --goal mission --tlog PATH`, no report, so
# no track is kept), the ground station uploading the next mission once the companion says the
# last is complete. Two missions of different lengths alternate, so MISSION_CURRENT.total says
# each is new (the stub fills no mission_id): out through the soak field and back.
MISSION_A_NE_M = [(650.0, 0.0), (20.0, 0.0)]
MISSION_B_NE_M = [(350.0, 3.0), (650.0, 0.0), (20.0, 0.0)]
SAMPLE_SIM_S = 60.0                 # a sample of RSS, fds and tlog bytes per simulated minute
MISSION_TIMEOUT_SIM_S = 900.0       # a mission not complete by then is counted failed, the next goes


@dataclass
class ProcSample:
    sim_s: float
    wall_s: float
    rss_mb: float
    fds: int
    tlog_bytes: int
    cpu_s: float


def proc_rss_mb(pid: int) -> float:
    """VmRSS from /proc/PID/status, in MiB."""
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024.0
    raise RuntimeError(f"no VmRSS for {pid}")


def proc_fds(pid: int) -> int:
    return len(os.listdir(f"/proc/{pid}/fd"))


def proc_cpu_s(pid: int) -> float:
    """utime + stime of /proc/PID/stat, in seconds (fields 14 and 15; the name may hold spaces)."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def mission_items(points_ne_m, origin, acceptance_m: float = 2.0) -> list:
    """Home (item 0, as ArduCopter stores it) and NAV_WAYPOINTs at 10 m relative altitude."""
    from companion.core.flat_earth import to_lat_lon_deg
    home_lat, home_lon = to_lat_lon_deg(origin.lat_deg, origin.lon_deg, 20.0, 0.0)
    items = [(0, mavutil.mavlink.MAV_FRAME_GLOBAL, 0.0, home_lat, home_lon, 0.0)]
    for seq, (north, east) in enumerate(points_ne_m, start=1):
        lat, lon = to_lat_lon_deg(origin.lat_deg, origin.lon_deg, north, east)
        items.append((seq, mavutil.mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, acceptance_m,
                      lat, lon, 10.0))
    return items


def upload_mission(conn, items, timeout_s: float = 30.0) -> None:
    """The mission protocol, ground-station side: MISSION_COUNT, each requested item, the ACK."""
    deadline = time.monotonic() + timeout_s
    conn.mav.mission_count_send(1, 1, len(items), 0)
    last_sent = time.monotonic()
    while time.monotonic() < deadline:
        msg = conn.recv_match(type=["MISSION_REQUEST", "MISSION_REQUEST_INT", "MISSION_ACK"],
                              blocking=True, timeout=0.5)
        if msg is None:
            if time.monotonic() - last_sent > 2.0:            # nothing asked: start again
                conn.mav.mission_count_send(1, 1, len(items), 0)
                last_sent = time.monotonic()
            continue
        if msg.target_system != 255:
            continue
        if msg.get_type() == "MISSION_ACK":
            if msg.type == mavutil.mavlink.MAV_MISSION_ACCEPTED:
                return
            raise RuntimeError(f"mission upload refused: MISSION_ACK type {msg.type}")
        seq, frame, acceptance_m, lat, lon, alt_m = items[msg.seq]
        conn.mav.mission_item_int_send(1, 1, seq, frame, mavutil.mavlink.MAV_CMD_NAV_WAYPOINT,
                                       0, 1, 0.0, acceptance_m, 0.0, float("nan"),
                                       int(round(lat * 1e7)), int(round(lon * 1e7)), alt_m, 0)
        last_sent = time.monotonic()
    raise RuntimeError("mission upload not acknowledged")


@dataclass
class MissionSoakResult:
    samples: list[ProcSample]
    missions_flown: int
    missions_complete: int
    sim_s: float
    wall_s: float
    min_clearance_m: float          # the stub's SIMSTATE (truth), airborne, to the field's posts' centres
    warmup_sim_s: float
    closest: tuple | None
    stderr: str
    warnings: int

    def after_warmup(self) -> list[ProcSample]:
        return [s for s in self.samples if s.sim_s >= self.warmup_sim_s]

    def summary(self) -> dict:
        after = self.after_warmup() or self.samples[-1:]
        first, last = self.samples[0], self.samples[-1]
        rss = [s.rss_mb for s in after]
        hours = (last.sim_s - first.sim_s) / 3600.0
        return {
            "sim_s": round(self.sim_s, 1), "wall_s": round(self.wall_s, 1),
            "speed_x": round(self.sim_s / self.wall_s, 1) if self.wall_s else None,
            "missions_flown": self.missions_flown, "missions_complete": self.missions_complete,
            "min_clearance_m": round(self.min_clearance_m, 2), "closest": self.closest,
            "rss_warmup_end_mb": round(after[0].rss_mb, 2), "rss_end_mb": round(last.rss_mb, 2),
            "rss_min_after_warmup_mb": round(min(rss), 2),
            "rss_max_after_warmup_mb": round(max(rss), 2),
            "rss_spread_after_warmup": round(max(rss) / min(rss) - 1.0, 4),
            "rss_growth_after_warmup": round(last.rss_mb / after[0].rss_mb - 1.0, 4),
            "fds_first": first.fds, "fds_last": last.fds,
            "fds_max": max(s.fds for s in self.samples),
            "tlog_mb": round(last.tlog_bytes / 1e6, 2),
            "tlog_mb_per_hour": round((last.tlog_bytes - first.tlog_bytes) / 1e6 / hours, 2)
            if hours > 0 else None,
            "cpu_s_per_sim_s": round((last.cpu_s - first.cpu_s) / (last.sim_s - first.sim_s), 4)
            if last.sim_s > first.sim_s else None,
            "warnings_logged": self.warnings,
        }


def mission_soak(sim_hours: float, workdir: Path, scenario: Path = REPO / "config/scenarios/soak.yaml",
                 warmup_sim_s: float = 1200.0, wall_limit_s: float = 3 * 3600.0,
                 progress=None) -> MissionSoakResult:
    """Missions back to back in lock-step for ``sim_hours`` of vehicle time; the daemon's RSS,
    open fds, tlog bytes and CPU seconds sampled each simulated minute from /proc."""
    from companion.config.scenario import load_scenario
    from companion.core.flat_earth import to_north_east_m
    world = load_scenario(scenario).world
    posts = [(o.north_m, o.east_m) for o in world.obstacles]
    config = yaml.safe_load((REPO / "config" / "companion.yaml").read_text())
    config["avoidance"].update(mission_time_s=None)
    config_path = workdir / "companion.yaml"
    config_path.write_text(yaml.safe_dump(config))
    tlog = workdir / "flight.tlog"
    stub_err = open(workdir / "stub.stderr", "w")
    stub = subprocess.Popen(
        [sys.executable, "-m", "sitl_stub", "--scenario", str(scenario), "--tcp", "127.0.0.1:0",
         "--udp", "127.0.0.1:0", "--route", "--lockstep", "--log-level", "WARNING"],
        stdout=subprocess.PIPE, stderr=stub_err, text=True, cwd=REPO)
    daemon = None
    companion_err = workdir / "companion.stderr"
    missions = [mission_items(MISSION_A_NE_M, world.origin),
                mission_items(MISSION_B_NE_M, world.origin)]
    samples: list[ProcSample] = []
    flown = complete = 0
    min_clearance = float("inf")
    closest = None                  # (sim s, post north/east) of the closest approach
    started = time.monotonic()
    sim_s = 0.0
    try:
        tcp_port, udp_port = _ready_ports(stub)
        gcs = mavutil.mavlink_connection(f"tcp:127.0.0.1:{tcp_port}", source_system=255,
                                         source_component=190)
        gcs.wait_heartbeat(timeout=10)
        upload_mission(gcs, missions[0])
        flown = 1
        with open(companion_err, "w") as err:
            daemon = subprocess.Popen(
                [sys.executable, "-m", "companion", "-v", "run", "--connect",
                 f"udpout:127.0.0.1:{udp_port}", "--config", str(config_path), "--goal",
                 "mission", "--tlog", str(tlog), "--lockstep"],
                stdout=subprocess.DEVNULL, stderr=err, cwd=REPO)
        pid = daemon.pid
        deadline = time.monotonic() + 30.0
        while "mission: 2 waypoints" not in companion_err.read_text(errors="replace"):
            if time.monotonic() > deadline or daemon.poll() is not None:
                raise RuntimeError(f"the companion did not read the mission; see {workdir}")
            time.sleep(0.2)
        _command(gcs, mavutil.mavlink.MAV_CMD_DO_SET_MODE, 1, 4)
        _command(gcs, mavutil.mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1)
        _command(gcs, mavutil.mavlink.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, 0, 0, 0, 10.0)
        mission_started_s = next_sample_s = 0.0
        airborne = False
        end_s = sim_hours * 3600.0
        while sim_s < end_s:
            if daemon.poll() is not None or stub.poll() is not None:
                raise RuntimeError(f"a process died during the soak; see the stderr files in {workdir}")
            if time.monotonic() - started > wall_limit_s:
                break
            msg = gcs.recv_match(type=["LOCAL_POSITION_NED", "STATUSTEXT", "SIMSTATE"],
                                 blocking=True, timeout=1.0)
            if msg is None:
                continue
            if msg.get_type() == "SIMSTATE":        # the stub's truth (as ArduPilot's SITL)
                if airborne:
                    north, east = to_north_east_m(world.origin.lat_deg, world.origin.lon_deg,
                                                  msg.lat / 1e7, msg.lng / 1e7)
                    gap, post = min((math.hypot(north - n, east - e), (n, e)) for n, e in posts)
                    if gap < min_clearance:
                        min_clearance, closest = gap, (round(sim_s, 1), post)
                continue
            if msg.get_type() == "LOCAL_POSITION_NED":
                sim_s = msg.time_boot_ms / 1000.0
                airborne = msg.z < -5.0
                if sim_s >= next_sample_s:
                    samples.append(ProcSample(sim_s, time.monotonic() - started, proc_rss_mb(pid),
                                              proc_fds(pid), tlog.stat().st_size if tlog.exists()
                                              else 0, proc_cpu_s(pid)))
                    next_sample_s = sim_s + SAMPLE_SIM_S
                    if progress is not None:
                        progress(samples[-1], flown, complete)
                timed_out = sim_s - mission_started_s > MISSION_TIMEOUT_SIM_S
            else:
                timed_out = False
            done = msg.get_type() == "STATUSTEXT" and msg.get_srcComponent() == 191 \
                and "mission complete" in msg.text
            if done or timed_out:
                complete += done
                upload_mission(gcs, missions[flown % 2])
                flown += 1
                mission_started_s = sim_s
        gcs.close()
        samples.append(ProcSample(sim_s, time.monotonic() - started, proc_rss_mb(pid),
                                  proc_fds(pid), tlog.stat().st_size, proc_cpu_s(pid)))
    finally:
        _stop(daemon, stub)
        stub_err.close()
    text = companion_err.read_text(errors="replace")
    return MissionSoakResult(samples, flown, complete, sim_s, time.monotonic() - started,
                             min_clearance, warmup_sim_s, closest, text,
                             text.count("WARNING"))


def main_missions(args) -> int:
    def progress(sample: ProcSample, flown: int, complete: int) -> None:
        if int(sample.sim_s) % 600 < SAMPLE_SIM_S:
            print(f"  sim {sample.sim_s:7.0f} s  wall {sample.wall_s:6.0f} s  RSS "
                  f"{sample.rss_mb:6.1f} MB  fds {sample.fds:3d}  tlog "
                  f"{sample.tlog_bytes / 1e6:6.1f} MB  cpu {sample.cpu_s:7.1f} s  missions "
                  f"{complete}/{flown}", file=sys.stderr, flush=True)

    with tempfile.TemporaryDirectory(prefix="soak-missions-") as tmp:
        workdir = args.keep or Path(tmp)
        workdir.mkdir(parents=True, exist_ok=True)
        result = mission_soak(args.sim_hours, workdir, args.scenario,
                              warmup_sim_s=60.0 * args.warmup_min, progress=progress)
    figures = result.summary()
    figures["load_average"] = [round(x, 2) for x in os.getloadavg()]
    if args.json:
        print(json.dumps({**figures, "samples": [vars(s) for s in result.samples]}))
        return 0
    print(f"mission soak: {figures['sim_s']:.0f} s simulated in {figures['wall_s']:.0f} s wall "
          f"({figures['speed_x']} x), missions complete {result.missions_complete} of "
          f"{result.missions_flown} flown, closest approach {figures['min_clearance_m']} m "
          f"(post centres, truth; at sim s, post: {figures['closest']})")
    print(f"RSS after warm-up ({args.warmup_min:g} sim min): {figures['rss_warmup_end_mb']} MB, "
          f"end {figures['rss_end_mb']} MB ({100 * figures['rss_growth_after_warmup']:+.1f} %), "
          f"min..max after warm-up {figures['rss_min_after_warmup_mb']}.."
          f"{figures['rss_max_after_warmup_mb']} MB (spread "
          f"{100 * figures['rss_spread_after_warmup']:.1f} %; flat within 5 %: "
          f"{'yes' if figures['rss_spread_after_warmup'] <= 0.05 else 'no'})")
    held = result.stderr.count("arrival uncertain")
    print(f"'arrival uncertain' lines (a waypoint held, not declared reached: the pose 2-sigma "
          f"above the arrival tolerance): {held}")
    print(f"open fds first {figures['fds_first']}, last {figures['fds_last']}, "
          f"max {figures['fds_max']}")
    print(f"tlog {figures['tlog_mb']} MB, {figures['tlog_mb_per_hour']} MB per hour of flight; "
          f"companion CPU {figures['cpu_s_per_sim_s']} s per simulated s; "
          f"WARNING lines {figures['warnings_logged']}; load average {figures['load_average']}")
    print("samples (sim s: RSS MB/fds): " + ", ".join(
        f"{s.sim_s:.0f}:{s.rss_mb:.1f}/{s.fds}" for s in result.samples[::5]))
    return 0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--minutes", type=float, default=5.0, help="wall minutes (default 5)")
    parser.add_argument("--speedup", type=float, default=20.0,
                        help="the stub's pace without lock-step (and its fallback with it)")
    parser.add_argument("--no-lockstep", action="store_true",
                        help="the stub on the wall clock at --speedup instead of lock-step")
    parser.add_argument("--scenario", type=Path, default=REPO / "config/scenarios/soak.yaml")
    parser.add_argument("--sim-hours", type=float, default=None,
                        help="missions back to back in lock-step for this much vehicle time "
                             "(issue 31's soak: 2); samples /proc each simulated minute")
    parser.add_argument("--warmup-min", type=float, default=20.0,
                        help="with --sim-hours: simulated minutes of warm-up (default 20)")
    parser.add_argument("--json", action="store_true", help="with --sim-hours: the figures as JSON")
    parser.add_argument("--keep", type=Path, default=None,
                        help="with --sim-hours: keep the tlog and stderr files in this directory")
    args = parser.parse_args(argv)
    if args.sim_hours is not None:
        return main_missions(args)
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
