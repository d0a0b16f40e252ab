"""The layout of docs/real-vehicle.md with a stock ground station, measured (issue 32).

sitl-stub (TCP) <- MAVProxy as the router (--out one UDP port for `companion run --goal mission`,
another for a pymavlink ground station). The ground station sets GUIDED, arms and sends
NAV_TAKEOFF to 10 m; MAVProxy's `wp load` uploads a mission before, while or after the companion
starts (``--upload``); optionally the ground station re-uploads a changed mission mid-flight or
sets the stream rates to 2 Hz. Prints what it measured as JSON: when the vehicle reached its
take-off altitude and when the companion began commanding (vehicle time, from the companion's
tlog), the MISSION_ACKs seen, the companion's rate warnings, the waypoints flown (true position)
and the clearance.

    python -m benchmarks.gcs_layout --upload during [--speedup 1] [--reupload] [--gcs-rate-hz 2]
    python -m benchmarks.gcs_layout --upload after --speedup 4 --rates 10,4,2   # side by side
"""
from __future__ import annotations

import argparse
import json
import math
import os
import re
import select
import socket
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import yaml

os.environ["MAVLINK20"] = "1"
from pymavlink import mavutil  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
PAPER = REPO / "config" / "scenarios" / "paper.yaml"
MAVPROXY = str(Path(sys.executable).parent / "mavproxy.py")
GUIDED = 4
TAKEOFF_ALT_M = 10.0
ALT_REACHED_M = TAKEOFF_ALT_M - 0.5     # "at take-off altitude": within 0.5 m
# North/east metres in the paper scenario (start 20, 0; posts at 60, 5 and 120, 0)
MISSION_A = [(90.0, 0.0), (150.0, 0.0), (150.0, 25.0)]       # past post 1, through post 2
MISSION_B = [(110.0, 20.0), (160.0, 20.0), (170.0, 0.0)]      # the re-upload, after A's first


def free_udp_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def write_wpl(path: Path, points_ne_m, hold_s: float = 0.0) -> None:
    """QGC WPL 110: home, then NAV_WAYPOINTs (GLOBAL_RELATIVE_ALT, 10 m, acceptance 2 m)."""
    from sitl_stub.world import load_scenario
    lat_lon = load_scenario(PAPER).world.origin.to_lat_lon_deg
    lines = ["QGC WPL 110"]
    lat, lon = lat_lon(20.0, 0.0)
    lines.append(f"0\t1\t0\t16\t0\t0\t0\t0\t{lat:.8f}\t{lon:.8f}\t584.0\t1")
    for seq, (north, east) in enumerate(points_ne_m, start=1):
        lat, lon = lat_lon(north, east)
        lines.append(f"{seq}\t0\t3\t16\t{hold_s:g}\t2\t0\t0\t{lat:.8f}\t{lon:.8f}\t10.0\t1")
    path.write_text("\n".join(lines) + "\n")


class Lines:
    """A subprocess's merged output, collected by a thread (each line with its wall time)."""

    def __init__(self, proc: subprocess.Popen) -> None:
        self.proc, self.lines = proc, []
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self) -> None:
        for line in self.proc.stdout:
            self.lines.append((time.time(), line.rstrip("\n")))

    def text(self) -> str:
        return "\n".join(line for _, line in self.lines)

    def wait_for(self, needle: str, timeout_s: float) -> bool:
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            if needle in self.text():
                return True
            time.sleep(0.05)
        return False


class Layout:
    """Starts and stops the processes; every wait is bounded."""

    def __init__(self, workdir: Path, speedup: float = 1.0, seed: int = 3,
                 scenario: Path = PAPER, stub_args=()) -> None:
        self.dir = workdir
        self.speedup = speedup
        self.procs: list[subprocess.Popen] = []
        self.truth = workdir / "truth.jsonl"
        self.tlog = workdir / "companion.tlog"
        self.report = workdir / "report.json"
        stub = subprocess.Popen(
            [sys.executable, "-m", "sitl_stub", "--scenario", str(scenario), "--tcp",
             "127.0.0.1:0", "--seed", str(seed), "--speedup", str(speedup),
             "--truth-log", str(self.truth), *stub_args],
            stdout=subprocess.PIPE, stderr=open(workdir / "stub.stderr", "w"),
            stdin=subprocess.DEVNULL, text=True, cwd=REPO)
        self.procs.append(stub)
        ready, _, _ = select.select([stub.stdout], [], [], 20.0)
        line = stub.stdout.readline() if ready else ""
        if not line.startswith("SITL_STUB READY"):
            self.close()
            raise RuntimeError(f"stub not ready: {line!r}")
        ports = dict(part.split("=", 1) for part in line.split()[2:])
        self.stub_tcp = int(ports["tcp"].rsplit(":", 1)[1])
        self.companion_port, self.gcs_port = free_udp_port(), free_udp_port()
        self.mavproxy = subprocess.Popen(
            [sys.executable, MAVPROXY, f"--master=tcp:127.0.0.1:{self.stub_tcp}",
             f"--out=udp:127.0.0.1:{self.companion_port}", f"--out=udp:127.0.0.1:{self.gcs_port}"],
            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, stdin=subprocess.PIPE, text=True,
            cwd=workdir, env=dict(os.environ, PYTHONUNBUFFERED="1"))
        self.procs.append(self.mavproxy)
        self.mavproxy_out = Lines(self.mavproxy)
        if not self.mavproxy_out.wait_for("Detected vehicle 1:1", 30.0):
            self.close()
            raise RuntimeError("MAVProxy did not detect the vehicle:\n" + self.mavproxy_out.text())
        self.gcs = mavutil.mavlink_connection(f"udpin:127.0.0.1:{self.gcs_port}",
                                              source_system=255, source_component=190)
        self.gcs.wait_heartbeat(timeout=10)
        self.companion = None

    def mavproxy_command(self, text: str) -> None:
        self.mavproxy.stdin.write(text + "\n")
        self.mavproxy.stdin.flush()

    def wp_load(self, wpl: Path) -> None:
        self.mavproxy_command(f"wp load {wpl}")

    def start_companion(self, config_overrides: dict | None = None) -> None:
        sys.path.insert(0, str(REPO))
        from companion.config.service import config_to_dict, load_config
        data = config_to_dict(load_config(REPO / "config" / "companion.yaml"))
        for section, values in (config_overrides or {}).items():
            data[section].update(values)
        config = self.dir / "companion.yaml"
        config.write_text(yaml.safe_dump(data))
        self.companion_stderr = self.dir / "companion.stderr"
        self.companion = subprocess.Popen(
            [sys.executable, "-m", "companion", "-v", "run", "--connect",
             f"udpin:127.0.0.1:{self.companion_port}", "--config", str(config), "--goal",
             "mission", "--tlog", str(self.tlog), "--report", str(self.report)],
            stdout=subprocess.DEVNULL, stderr=open(self.companion_stderr, "w"),
            stdin=subprocess.DEVNULL, text=True, cwd=REPO)
        self.procs.append(self.companion)

    # -------------------------------------------------------------- the ground station
    def command(self, command: int, *params: float, timeout_s: float = 10.0) -> None:
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            self.gcs.mav.command_long_send(1, 1, command, 0, *params, *[0] * (7 - len(params)))
            end = time.monotonic() + 0.5
            while time.monotonic() < end:
                ack = self.gcs.recv_match(type="COMMAND_ACK", blocking=True, timeout=0.1)
                if ack is not None and ack.command == command and ack.result == 0:
                    return
        raise RuntimeError(f"command {command} not accepted within {timeout_s} s")

    def take_off(self) -> None:
        self.command(mavutil.mavlink.MAV_CMD_DO_SET_MODE, 1, GUIDED)
        self.command(mavutil.mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1)
        self.command(mavutil.mavlink.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, 0, 0, 0, TAKEOFF_ALT_M)

    def set_rates(self, rate_hz: int) -> None:
        """As MAVProxy and Mission Planner do: REQUEST_DATA_STREAM for all streams."""
        self.gcs.mav.request_data_stream_send(1, 1, 0, rate_hz, 1)

    def drain(self) -> None:
        while self.gcs.recv_match(blocking=False) is not None:
            pass

    def close(self) -> None:
        for proc in reversed(self.procs):
            if proc.poll() is None:
                if proc is self.mavproxy and proc.stdin:
                    try:
                        proc.stdin.close()
                    except OSError:
                        pass
                proc.terminate()
        for proc in self.procs:
            try:
                proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()


def measure(layout: Layout, waypoints) -> dict:
    """The figures of a finished run, from the truth log, the companion's tlog and logs."""
    from companion.mavlink.tlog import TlogReader
    truth = [json.loads(line) for line in layout.truth.read_text().splitlines() if line.strip()]
    reached = [r["t_s"] for r in truth if r["armed"] and r["up_m"] >= ALT_REACHED_M]
    records = [(r.t_us, r.msg) for r in TlogReader(layout.tlog)] if layout.tlog.exists() else []
    boot_ms = None
    first_setpoint_boot_ms = None
    acks = []
    odometry_ms = []
    for _, msg in records:
        kind = msg.get_type()
        if msg.get_srcSystem() == 1 and hasattr(msg, "time_boot_ms"):
            boot_ms = msg.time_boot_ms
            if kind == "LOCAL_POSITION_NED":
                odometry_ms.append(boot_ms)
        if kind == "MISSION_ACK":
            acks.append((msg.get_srcSystem(), msg.get_srcComponent(), msg.target_system,
                         msg.target_component, msg.type))
        if kind == "SET_POSITION_TARGET_LOCAL_NED" and msg.get_srcComponent() == 191 \
                and first_setpoint_boot_ms is None:
            first_setpoint_boot_ms = boot_ms
    stderr = layout.companion_stderr.read_text(errors="replace") if layout.companion else ""
    report = json.loads(layout.report.read_text()) if layout.report.exists() else {}
    flying = [r for r in truth if r["armed"] and r["up_m"] > 5.0]
    # each waypoint in order: the first true position within 4 m after the previous one's
    order, t_prev = [], 0.0
    for north, east in waypoints:
        near = [r["t_s"] for r in flying if r["t_s"] >= t_prev
                and math.hypot(r["north_m"] - north, r["east_m"] - east) <= 4.0]
        order.append(near[0] if near else None)
        t_prev = near[0] if near else t_prev
    clearance = min((math.hypot(r["north_m"] - o["north_m"], r["east_m"] - o["east_m"])
                     - o.get("radius_m", 0.0) * 0 for r in flying for o in r["obstacles"]),
                    default=None)
    # the odometry's interval while commanding (vehicle time): what the link delivered
    commanding = [t for t in odometry_ms if first_setpoint_boot_ms is not None
                  and t >= first_setpoint_boot_ms]
    intervals = sorted(b - a for a, b in zip(commanding, commanding[1:]) if b > a)
    relative = [t - reached[0] if t is not None and reached else None for t in order]
    return {
        "odometry_interval_median_s": intervals[len(intervals) // 2] / 1e3 if intervals else None,
        "odometry_interval_mean_s": sum(intervals) / len(intervals) / 1e3 if intervals else None,
        "waypoint_after_alt_s": relative,
        "estimator_state_changes": [(c["t_s"], c["state"]) for c in
                                    report.get("estimator_state_changes") or []],
        "alt_reached_t_s": reached[0] if reached else None,
        "first_setpoint_t_s": first_setpoint_boot_ms / 1e3 if first_setpoint_boot_ms else None,
        "handover_s": (first_setpoint_boot_ms / 1e3 - reached[0])
        if reached and first_setpoint_boot_ms else None,
        "mission_acks": acks,
        "rate_warnings": len(re.findall(r"below \d+% of the asked rate", stderr)),
        "rate_lines": [line for line in stderr.splitlines() if "rate" in line and "WARNING" in line][:5],
        "mission_lines": [line.split(": ", 1)[-1] for line in stderr.splitlines()
                          if "mission" in line.lower() and "effective config" not in line][:20],
        "phases": report.get("phases"),
        "airborne_t_s": next((t for t, phase, _ in report.get("phases") or []
                              if phase == "airborne"), None),
        "phase_lines": [line for line in stderr.splitlines() if "flight phase" in line],
        "waypoint_t_s": order,
        "clearance_m": clearance,
        "mavproxy_wp": [line for _, line in layout.mavproxy_out.lines
                        if re.search(r"waypoint|Request|OPERATION|Loaded|Sent", line)][:20],
    }


def wait_for_file_text(path: Path, needle: str, timeout_s: float) -> bool:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if path.exists() and needle in path.read_text(errors="replace"):
            return True
        time.sleep(0.02)
    return False


def run(upload: str, speedup: float, reupload: bool, gcs_rate_hz: int | None,
        workdir: Path, duration_s: float) -> dict:
    wpl_a, wpl_b = workdir / "a.txt", workdir / "b.txt"
    write_wpl(wpl_a, MISSION_A)
    write_wpl(wpl_b, MISSION_B)
    layout = Layout(workdir, speedup=speedup)
    try:
        if gcs_rate_hz is not None:
            layout.set_rates(gcs_rate_hz)
        if upload == "before":
            layout.wp_load(wpl_a)
            layout.mavproxy_out.wait_for("waypoints in ", 20.0)
        if upload == "during":            # the companion starts as MAVProxy uploads
            layout.start_companion()
            wait_for_file_text(layout.companion_stderr, "vehicle found", 20.0)
            layout.wp_load(wpl_a)
            layout.take_off()
        elif upload == "before":          # uploaded, then the companion up, then the takeoff
            layout.start_companion()
            wait_for_file_text(layout.companion_stderr, "vehicle found", 20.0)
            layout.take_off()
        else:                             # after: the companion up from boot, the upload later
            layout.start_companion()
            wait_for_file_text(layout.companion_stderr, "vehicle found", 20.0)
            layout.take_off()
            time.sleep(3.0 / speedup)
            layout.wp_load(wpl_a)
        end = time.monotonic() + duration_s / speedup
        next_rates = time.monotonic()
        reuploaded = False
        flown = MISSION_A
        while time.monotonic() < end:
            layout.drain()
            if reupload and not reuploaded and "waypoint 1 reached" in \
                    layout.companion_stderr.read_text(errors="replace"):
                layout.wp_load(wpl_b)          # the first waypoint reached: a changed mission
                reuploaded, flown = True, MISSION_A[:1] + MISSION_B
            if gcs_rate_hz is not None and time.monotonic() >= next_rates:
                layout.set_rates(gcs_rate_hz)        # as a ground station re-asks
                next_rates += 5.0 / speedup
            if layout.report.exists():
                mission = json.loads(layout.report.read_text()).get("mission") or {}
                if mission.get("complete"):
                    break
            time.sleep(0.05)
    finally:
        layout.close()
    result = measure(layout, flown)
    result["report_mission"] = (json.loads(layout.report.read_text()).get("mission")
                                if layout.report.exists() else None)
    result["reuploaded"] = reuploaded
    return result


def rate_table(rates_hz, upload: str, speedup: float, workdir: Path, duration_s: float) -> list:
    """One flight per odometry rate, side by side (issue 32): the companion's own 10 Hz
    request (rate 10: no ground station rate) or a ground station setting every stream to the
    rate (REQUEST_DATA_STREAM every 5 s of vehicle time, as MAVProxy re-asks)."""
    rows = []
    for rate in rates_hz:
        flight_dir = workdir / f"{rate}hz"
        flight_dir.mkdir(parents=True, exist_ok=True)
        result = run(upload, speedup, False, None if rate == 10 else rate, flight_dir, duration_s)
        times = result["waypoint_t_s"]
        airborne = result["airborne_t_s"]
        checks = (None not in times and times == sorted(times)
                  and result["clearance_m"] is not None and result["clearance_m"] >= 9.5
                  and airborne is not None and result["alt_reached_t_s"] is not None
                  and airborne - result["alt_reached_t_s"] <= 5.0)
        rows.append({"rate_hz": rate, "odometry_interval_mean_s":
                     result["odometry_interval_mean_s"],
                     "waypoint_after_alt_s": result["waypoint_after_alt_s"],
                     "airborne_after_alt_s": (airborne - result["alt_reached_t_s"])
                     if airborne is not None and result["alt_reached_t_s"] is not None else None,
                     "clearance_m": result["clearance_m"],
                     "estimator_state_changes": result["estimator_state_changes"],
                     "checks_hold": checks})
    return rows


def print_table(rows) -> None:
    print(f"{'rate':>5} {'odom dt':>8} {'waypoints after take-off altitude (s)':>38} "
          f"{'airborne':>9} {'clearance':>10} {'estimator':>10} checks")
    for row in rows:
        wps = "/".join("-" if t is None else f"{t:.1f}" for t in row["waypoint_after_alt_s"])
        states = ",".join(state for _, state in row["estimator_state_changes"]) or "-"
        dt = row["odometry_interval_mean_s"]
        airborne = row["airborne_after_alt_s"]
        print(f"{row['rate_hz']:>4}Hz {'-' if dt is None else f'{dt:.2f} s':>8} {wps:>38} "
              f"{'-' if airborne is None else f'{airborne:.1f} s':>9} "
              f"{row['clearance_m'] or 0.0:>8.2f} m {states:>10} "
              f"{'hold' if row['checks_hold'] else 'FAIL'}")


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--upload", choices=("before", "during", "after"), default="during")
    p.add_argument("--speedup", type=float, default=1.0)
    p.add_argument("--reupload", action="store_true")
    p.add_argument("--gcs-rate-hz", type=int)
    p.add_argument("--duration-s", type=float, default=150.0, help="vehicle seconds at most")
    p.add_argument("--keep", metavar="DIR")
    p.add_argument("--rates", metavar="HZ,HZ,...",
                   help="one flight per odometry rate, printed side by side (10: the companion's "
                        "own request; others: the ground station sets all streams to it), e.g. "
                        "10,4,2; --reupload and --gcs-rate-hz are then ignored")
    args = p.parse_args()
    workdir = Path(args.keep) if args.keep else Path(tempfile.mkdtemp(prefix="gcs_layout_"))
    workdir.mkdir(parents=True, exist_ok=True)
    if args.rates:
        rows = rate_table([int(r) for r in args.rates.split(",")], args.upload, args.speedup,
                          workdir, args.duration_s)
        print(json.dumps(rows, indent=1))
        print_table(rows)
        return
    print(json.dumps(run(args.upload, args.speedup, args.reupload, args.gcs_rate_hz, workdir,
                         args.duration_s), indent=1))


if __name__ == "__main__":
    main()
