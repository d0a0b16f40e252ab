"""System figures (issue 6): obstacle-to-setpoint latency, replay throughput, closed-loop speed
and the daemon's memory, all from one run of ``benchmarks/run.py``.

- Flights are real ``companion demo`` runs (sitl-stub, `companion run` and a ground station as
  separate processes over loopback), each recording the daemon's tlog.
- Latency, in the daemon: its tlog stamps each inbound record when the link received the
  datagram and each outbound one when it was handed to the socket (companion/mavlink/link.py). The
  pipeline holds a camera frame (its obstacle reports of one time) until a message that is not
  part of it arrives, and decides then; so t(first SET_POSITION_TARGET_LOCAL_NED sent after the
  message that closed the frame, before the next inbound one) - t(the frame's last report), and
  the same setpoint from the closing message (the daemon's reaction once the frame is complete).
  Measured on the long corridor flight.
  Outside it: benchmarks/probe.py, a fake vehicle timing the setpoint's arrival (two hops).
- Closed loop: the paper's scenario at several speedups with the stub on the wall clock
  (``--no-lockstep``). ``sim_s`` is arming to arrival in the vehicle's time (the demo's score);
  ``wall_s`` is the same interval on the daemon's link clock, read off its tlog (each vehicle
  message carries time_boot_ms and a link timestamp), so process start-up, arming handshakes and
  the settle wait are excluded.
- Closed loop in lock-step (the demo's default): as fast as stub and daemon go. The daemon's
  tlog is on the vehicle clock there, so the wall time comes from the demo's ground station
  (``flight_sim_s`` over ``flight_wall_s``: from the first step after the wait for the daemon to
  the arrival; start-up excluded).
- Replay: ``companion.tools.replay.replay_tlog`` called in-process (no interpreter start-up) on the
  corridor flight's tlog, alternating with pymavlink parsing the same file, medians.
- Memory: the daemon child's VmHWM (/proc), read every 20 ms while each demo runs.
"""
from __future__ import annotations

import json
import signal
import subprocess
import sys
import tempfile
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import psutil

from benchmarks import probe
from companion.mavlink.tlog import TlogReader
from companion.config.scenario import load_scenario
from companion.config.service import config_to_dict, load_config
from companion.tools.demo import demo_config

ROOT = Path(__file__).resolve().parent.parent
PAPER = ROOT / "config/scenarios/paper.yaml"
CORRIDOR = Path(__file__).resolve().parent / "corridor.yaml"
OUR_COMPONENT = 191
MIN_CLEARANCE_M = 9.5
SPEEDUPS = (20, 50, 100, 200, 500)
QUICK_SPEEDUPS = (50, 100)
LOCKSTEP_RUNS, QUICK_LOCKSTEP_RUNS = 3, 2
CORRIDOR_SPEEDUP = 20
MEMORY_POLL_S = 0.02
STOP_TIMEOUT_S = 20.0


def flight_timeout_s(speedup: float) -> float:
    """Wall time after which a demo is stopped as failed: 1.5x the paper's 120 s mission,
    plus start-up (the demo's own deadline is the mission time plus 30 s)."""
    return 15.0 + 1.5 * 120.0 / speedup


@dataclass
class Flight:
    scenario: str
    speedup: float
    returncode: int
    reached_goal: bool = False
    min_clearance_m: float | None = None
    sim_s: float | None = None
    wall_s: float | None = None
    demo_wall_time_s: float | None = None
    peak_rss_mb: float | None = None
    latency_ms: dict = field(default_factory=dict)
    tlog_messages: int = 0
    max_stall_sim_s: float | None = None  # longest silence on the daemon's link clock, in vehicle s
    stub_fell_behind: bool = False
    lockstep: bool = False
    stub_free_ran: bool = False  # lock-step: the stub's bounded wait ran out at least once
    judged: bool = True          # the corridor flight is there for latency and replay only
    error: str | None = None

    @property
    def passed(self) -> bool:
        return self.reached_goal and (self.min_clearance_m or 0.0) >= MIN_CLEARANCE_M

    def as_dict(self) -> dict:
        data = {k: v for k, v in self.__dict__.items()}
        data["passed"] = self.passed
        data["real_time_factor"] = self.sim_s / self.wall_s if self.sim_s and self.wall_s else None
        return data


# ------------------------------------------------------------------ tlog readings
@dataclass
class FrameLatencies:
    """Obstacle frames -> reacting setpoints in one tlog, ns of the daemon's link clock, in file
    order: ``total`` from the receipt of the frame's last report, ``reaction`` from the receipt
    of the message that closed the frame; ``unanswered`` frames had no setpoint (before arming,
    a frame that changed nothing)."""
    total: list[int] = field(default_factory=list)
    reaction: list[int] = field(default_factory=list)
    unanswered: int = 0

    def as_dict(self) -> dict:
        return probe.percentiles_ms(self.total) | {
            "unanswered": self.unanswered, "reaction": probe.percentiles_ms(self.reaction)}


def _frame_key(msg) -> tuple | None:
    """(system, component, time s) of an obstacle report: the pipeline's frame is the reports of
    one camera with one time (onboard/camera_frames.py FrameAssembly.continued_by)."""
    kind = msg.get_type()
    if kind == "OBSTACLE_DISTANCE_3D":
        t_s = msg.time_boot_ms / 1000.0
    elif kind == "OBSTACLE_DISTANCE":
        t_s = msg.time_usec / 1e6
    else:
        return None
    return msg.get_srcSystem(), msg.get_srcComponent(), t_s


def tlog_latencies_ns(path: Path) -> FrameLatencies:
    """Obstacle frame -> reacting setpoint, from the daemon's tlog.

    The daemon writes an inbound record just before handling it, and what the handling sends
    right after. A camera frame is handed to the estimator (and decided on) when the first
    message that is not part of it is handled, so its setpoint follows that closing message
    and counts as the reaction only if it comes before the next inbound record.
    """
    out = FrameLatencies()
    open_key, open_t_us = None, None        # the frame being assembled, its last report's time
    closed = None                           # (last report t_us, closing t_us) awaiting a setpoint
    for record in TlogReader(path):
        msg = record.msg
        if msg.get_srcComponent() != OUR_COMPONENT:
            if closed is not None:
                out.unanswered += 1
                closed = None
            key = _frame_key(msg)
            if open_key is not None and key != open_key:
                closed, open_key = (open_t_us, record.t_us), None
            if key is not None:
                open_key, open_t_us = key, record.t_us
        elif msg.get_type() == "SET_POSITION_TARGET_LOCAL_NED" and closed is not None:
            out.total.append((record.t_us - closed[0]) * 1000)
            out.reaction.append((record.t_us - closed[1]) * 1000)
            closed = None
    out.unanswered += (closed is not None) + (open_key is not None)
    return out


def link_clock(path: Path) -> tuple[np.ndarray, np.ndarray, int]:
    """(vehicle time s, link time s) of every inbound message carrying time_boot_ms, and the
    record count: the map from the vehicle's clock to the daemon's wall clock."""
    boot, link, records = [], [], 0
    for record in TlogReader(path):
        records += 1
        msg = record.msg
        if msg.get_srcComponent() != OUR_COMPONENT and hasattr(msg, "time_boot_ms") \
                and msg.get_type() in ("ATTITUDE", "LOCAL_POSITION_NED"):
            boot.append(msg.time_boot_ms / 1000.0)
            link.append(record.t_us / 1e6)
    return np.array(boot), np.array(link), records


# ------------------------------------------------------------------ flights
class PeakMemory(threading.Thread):
    """Polls VmHWM of the `companion run` grandchild of ``parent`` until stopped."""

    def __init__(self, parent: subprocess.Popen) -> None:
        super().__init__(daemon=True)
        self.parent, self.peak_kb, self._stop_event = parent, None, threading.Event()

    def run(self) -> None:
        pid = None
        while not self._stop_event.wait(MEMORY_POLL_S):
            try:
                if pid is None:
                    pid = next((c.pid for c in psutil.Process(self.parent.pid).children()
                                if _is_daemon(c.cmdline())), None)
                if pid is not None:
                    self.peak_kb = _vm_hwm_kb(pid) or self.peak_kb
            except (psutil.Error, OSError, IndexError):
                continue

    def stop(self) -> float | None:
        self._stop_event.set()
        self.join()
        return self.peak_kb / 1024.0 if self.peak_kb else None


def _is_daemon(cmdline: list[str]) -> bool:
    """`python -m companion [-v] run ...`."""
    return cmdline[1:3] == ["-m", "companion"] and "run" in cmdline[3:5]


def _vm_hwm_kb(pid: int) -> int | None:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmHWM:"):
            return int(line.split()[1])
    return None


def fly(scenario: Path, speedup: float, workdir: Path, name: str,
        lockstep: bool = False) -> tuple[Flight, Path]:
    """One `companion demo`; returns its figures and the daemon's tlog. Without ``lockstep``,
    the stub runs on the wall clock at ``speedup``."""
    keep, tlog, out = workdir / name, workdir / f"{name}.tlog", workdir / f"{name}.json"
    proc = subprocess.Popen(
        [sys.executable, "-m", "companion", "demo", "--scenario", str(scenario),
         "--speedup", str(speedup), "--tlog", str(tlog), "--keep", str(keep), "--json", str(out),
         "--lockstep" if lockstep else "--no-lockstep"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, stdin=subprocess.DEVNULL, cwd=ROOT)
    memory = PeakMemory(proc)
    memory.start()
    try:
        stdout, stderr = proc.communicate(timeout=flight_timeout_s(speedup) if
                                          scenario == PAPER else None)
    except subprocess.TimeoutExpired:
        proc.send_signal(signal.SIGINT)          # the demo stops both children on Ctrl-C
        try:
            stdout, stderr = proc.communicate(timeout=STOP_TIMEOUT_S)
        except subprocess.TimeoutExpired:
            proc.kill()
            stdout, stderr = proc.communicate()
        stderr = f"no arrival within {flight_timeout_s(speedup):.0f} s wall".encode()
    flight = Flight(scenario.stem, speedup, proc.returncode, peak_rss_mb=memory.stop(),
                    lockstep=lockstep)
    if not out.exists():
        flight.error = (stderr or stdout).decode(errors="replace").strip()[-500:]
        if refused := arrival_refusal(keep / "companion.stderr"):
            flight.error += f" ({refused})"
        if tlog.exists():
            # obstacle-to-setpoint latency needs a flight, not an arrival: the 1 km GPS-denied
            # corridor ends its leg ~7 m from the goal (the estimate's drift) and the companion
            # honestly refuses to declare arrival there, so the demo times out
            flight.latency_ms = tlog_latencies_ns(tlog).as_dict()
        return flight, tlog
    result = json.loads(out.read_text())
    summary = result["runs"][0]
    flight.reached_goal = bool(summary["reached_goal"])
    flight.min_clearance_m = summary["min_clearance_m"]
    flight.sim_s = summary["time_s"]
    flight.demo_wall_time_s = result["aggregate"]["wall_time_s"]
    flight.stub_fell_behind = "falling behind" in _read(keep / "sitl-stub.stderr")
    if lockstep:
        aggregate = result["aggregate"]
        flight.stub_free_ran = "free-running" in _read(keep / "sitl-stub.stderr")
        flight.sim_s, flight.wall_s = aggregate["flight_sim_s"], aggregate["flight_wall_s"]
        _, _, flight.tlog_messages = link_clock(tlog)
        return flight, tlog
    armed_s = _armed_at(keep / "truth.jsonl")
    boot_s, link_s, flight.tlog_messages = link_clock(tlog)
    if armed_s is not None and len(boot_s) > 1 and flight.sim_s is not None:
        start, end = np.interp([armed_s, armed_s + flight.sim_s], boot_s, link_s)
        flight.wall_s = float(end - start)
        flying = (link_s >= start) & (link_s <= end)
        if flying.sum() > 1:
            # Vehicle time that passed while the daemon heard nothing (stub, kernel or daemon
            # not scheduled): at speedup 200 a 10 ms stall is 2 s of flying on an old setpoint.
            flight.max_stall_sim_s = float(np.max(np.diff(link_s[flying]))) * speedup
    flight.latency_ms = tlog_latencies_ns(tlog).as_dict()
    return flight, tlog


def arrival_refusal(companion_stderr: Path) -> str | None:
    """The companion's last "arrival uncertain: pose 2-sigma X m" notice, if it gave one."""
    lines = [line for line in _read(companion_stderr).splitlines() if "arrival uncertain" in line]
    return lines[-1].partition("WARNING ")[2].partition(": ")[2] or lines[-1] if lines else None


def _armed_at(truth: Path) -> float | None:
    for line in _read(truth).splitlines():
        try:
            record = json.loads(line)
        except ValueError:
            continue
        if record.get("armed"):
            return float(record["t_s"])
    return None


def _read(path: Path) -> str:
    try:
        return path.read_text(errors="replace")
    except OSError:
        return ""


def closed_loop(flights: list[Flight]) -> dict:
    """The highest speedup at which every flight passed, with the median times there."""
    by_speedup: dict[float, list[Flight]] = {}
    for f in flights:
        by_speedup.setdefault(f.speedup, []).append(f)
    passing = [s for s, fs in by_speedup.items() if all(f.passed and f.wall_s for f in fs)]
    if not passing:
        return {"speedup": None, "sim_s": None, "wall_s": None}
    best = max(passing)
    fs = by_speedup[best]
    return {"speedup": best, "runs": len(fs),
            "sim_s": float(np.median([f.sim_s for f in fs])),
            "wall_s": float(np.median([f.wall_s for f in fs]))}


def closed_loop_lockstep(flights: list[Flight]) -> dict:
    """Median real-time factor of the lock-step paper flights (each flight's own ratio)."""
    timed = [f for f in flights if f.sim_s and f.wall_s]
    factors = [f.sim_s / f.wall_s for f in timed]
    return {"runs": len(flights), "timed": len(timed),
            "all_passed": all(f.passed for f in flights),
            "any_free_ran": any(f.stub_free_ran for f in flights),
            "real_time_factor": float(np.median(factors)) if factors else None,
            "real_time_factor_min": float(min(factors)) if factors else None,
            "sim_s": float(np.median([f.sim_s for f in timed])) if timed else None,
            "wall_s": float(np.median([f.wall_s for f in timed])) if timed else None}


# ------------------------------------------------------------------ replay
def measure_replay(tlog: Path, reps: int) -> dict:
    """companion replay in-process vs pymavlink parsing alone, alternated, medians."""
    from pymavlink import mavutil

    from companion.core.navigation import navigator
    from companion.tools.replay import replay_tlog
    config = load_config(tlog.with_suffix(".config.yaml"))
    parse_s, replay_s, messages, parsed = [], [], 0, 0
    for _ in range(reps):
        start = time.perf_counter()
        conn = mavutil.mavlink_connection(str(tlog))
        parsed = 0
        while conn.recv_msg() is not None:
            parsed += 1
        conn.close()
        parse_s.append(time.perf_counter() - start)
        start = time.perf_counter()
        result = replay_tlog(tlog, config)
        replay_s.append(time.perf_counter() - start)
        messages = result.messages
    boot_s, _, _ = link_clock(tlog)          # the vehicle's clock (a tlog stamps wall time)
    flight_s = float(boot_s[-1] - boot_s[0]) if len(boot_s) > 1 else None
    # One more replay with Navigator.decide timed: how much of replay is guidance.
    decide = navigator.Navigator.decide
    spent = [0.0, 0]

    def timed(self, t_s):
        began = time.perf_counter()
        try:
            return decide(self, t_s)
        finally:
            spent[0] += time.perf_counter() - began
            spent[1] += 1
    navigator.Navigator.decide = timed
    try:
        start = time.perf_counter()
        replay_tlog(tlog, config)
        instrumented_s = time.perf_counter() - start
    finally:
        navigator.Navigator.decide = decide
    return {"msgs_per_s": messages / float(np.median(replay_s)),
            "parse_only_msgs_per_s": parsed / float(np.median(parse_s)),
            "messages": messages, "parsed": parsed, "reps": reps, "flight_s": flight_s,
            "real_time_factor": flight_s / float(np.median(replay_s)) if flight_s else None,
            "replay_s": float(np.median(replay_s)), "parse_only_s": float(np.median(parse_s)),
            "decisions": spent[1], "decide_us": spent[0] / max(spent[1], 1) * 1e6,
            "decide_share": spent[0] / instrumented_s}


# ------------------------------------------------------------------ entry point
def run(quick: bool) -> dict:
    speedups = QUICK_SPEEDUPS if quick else SPEEDUPS
    repeats = 1 if quick else 2
    with tempfile.TemporaryDirectory(prefix="companion-bench-") as tmp:
        workdir = Path(tmp)
        loopback = probe.loopback_rtt(500 if quick else 3000)
        samples = 300 if quick else 2000
        paper_config = config_to_dict(demo_config(load_scenario(PAPER)))
        probed = probe.run_probe(samples, workdir, paper_config)
        inside = tlog_latencies_ns(Path(probed["tlog"])).total
        corridor, corridor_tlog = fly(CORRIDOR, CORRIDOR_SPEEDUP, workdir, "corridor")
        corridor.judged = False
        flights = []
        for _ in range(repeats):
            for speedup in speedups:
                flights.append(fly(PAPER, speedup, workdir, f"paper-x{speedup}-{len(flights)}")[0])
        replay = measure_replay(corridor_tlog, 2 if quick else 5) if corridor_tlog.exists() \
            else {"msgs_per_s": None, "parse_only_msgs_per_s": None}
        locked = [fly(PAPER, CORRIDOR_SPEEDUP, workdir, f"paper-lockstep-{i}", lockstep=True)[0]
                  for i in range(QUICK_LOCKSTEP_RUNS if quick else LOCKSTEP_RUNS)]
    all_flights = [corridor, *flights, *locked]
    # Memory in normal operation: the corridor and the flights that passed (an overwhelmed daemon
    # at too high a speedup queues messages; its peak is kept apart).
    peaks = [f.peak_rss_mb for f in all_flights if f.peak_rss_mb and (f.passed or not f.judged)]
    overloaded = [f.peak_rss_mb for f in all_flights if f.peak_rss_mb]
    latency = dict(corridor.latency_ms)
    latency["source"] = f"daemon tlog, {corridor.scenario} demo at speedup {CORRIDOR_SPEEDUP}"
    if not corridor.reached_goal:
        latency["source"] += f"; the flight did not arrive: {corridor.error or '?'}"
    return {
        "latency_ms": latency,
        "latency_probe_ms": {"external": probed["external_ms"], "missed": probed["missed"],
                             "daemon": probe.percentiles_ms(inside[-samples:])},
        "loopback_rtt_ms": loopback,
        "replay": replay,
        "closed_loop": closed_loop(flights),
        "closed_loop_lockstep": closed_loop_lockstep(locked),
        "memory_mb": max(peaks) if peaks else None,
        "memory_mb_all_flights": max(overloaded) if overloaded else None,
        "flights": [f.as_dict() for f in all_flights],
    }


# ------------------------------------------------------------------ printing
def print_system(system: dict) -> None:
    def ms(fig: dict) -> str:
        if not fig.get("samples"):
            return "no samples"
        return (f"p50 {fig['p50']:.3f} ms, p99 {fig['p99']:.3f} ms, max {fig['max']:.3f} ms "
                f"(n={fig['samples']})")
    lat, prb = system["latency_ms"], system["latency_probe_ms"]
    print(f"obstacle -> setpoint, daemon tlog ({lat['source']}): {ms(lat)}")
    if "reaction" in lat:
        print(f"                      from the message that closed the frame: "
              f"{ms(lat['reaction'])}; frames unanswered: {lat['unanswered']}")
    print(f"obstacle -> setpoint, external probe (2 loopback hops): {ms(prb['external'])}")
    print(f"                      same reports in the daemon tlog:  {ms(prb['daemon'])}")
    print(f"loopback round trip (Python echo process): {ms(system['loopback_rtt_ms'])}")
    rep = system["replay"]
    if "messages" in rep:
        print(f"replay in-process: {rep['msgs_per_s']:,.0f} msg/s; pymavlink parse only "
              f"{rep['parse_only_msgs_per_s']:,.0f} msg/s; ratio "
              f"{rep['msgs_per_s'] / rep['parse_only_msgs_per_s']:.2f} ({rep['messages']} messages, "
              f"median of {rep['reps']}); Navigator.decide {rep['decide_us']:.0f} us x "
              f"{rep['decisions']} = {100 * rep['decide_share']:.0f}% of replay time")
        if rep.get("real_time_factor"):
            print(f"replay against the flight: {rep['flight_s']:.0f} s of tlog replayed in "
                  f"{rep['replay_s']:.2f} s, {rep['real_time_factor']:.0f}x real time")
    print(f"{'flight':>10} {'speedup':>7} {'passed':>6} {'sim s':>6} {'wall s':>7} {'x real':>7} "
          f"{'clear m':>7} {'demo s':>6} {'lat p50':>7} {'lat p99':>7} {'n':>4} {'RSS MB':>6} "
          f"{'stall s':>7}")
    for f in system["flights"]:
        def num(value, fmt):
            return format(value, fmt) if value is not None else "-"
        lat_f = f["latency_ms"]
        verdict = ("yes" if f["passed"] else "NO") if f["judged"] else "n/a"
        pace = "lock" if f["lockstep"] else format(f["speedup"], "g")
        print(f"{f['scenario']:>10} {pace:>7} {verdict:>6} "
              f"{num(f['sim_s'], '6.1f')} {num(f['wall_s'], '7.3f')} "
              f"{num(f['real_time_factor'], '7.1f')} {num(f['min_clearance_m'], '7.2f')} "
              f"{num(f['demo_wall_time_s'], '6.1f')} {num(lat_f.get('p50'), '7.3f')} "
              f"{num(lat_f.get('p99'), '7.3f')} {lat_f.get('samples', 0):>4} "
              f"{num(f['peak_rss_mb'], '6.1f')} {num(f['max_stall_sim_s'], '7.2f')}"
              + ("  stub fell behind" if f["stub_fell_behind"] else "")
              + ("  stub free-ran (lock-step wait ran out)" if f["stub_free_ran"] else "")
              + (f"  error: {f['error']}" if f["error"] else ""))
    loop = system["closed_loop"]
    if loop["speedup"] is not None:
        print(f"closed loop: paper at speedup {loop['speedup']:g} (highest passing), "
              f"{loop['sim_s']:.1f} s simulated in {loop['wall_s']:.3f} s wall "
              f"(arming to arrival, median of {loop['runs']})")
    locked = system["closed_loop_lockstep"]
    if locked["real_time_factor"] is not None:
        print(f"closed loop in lock-step: paper {locked['sim_s']:.1f} s simulated in "
              f"{locked['wall_s']:.3f} s wall, {locked['real_time_factor']:.0f}x real time "
              f"(median of {locked['timed']}, min {locked['real_time_factor_min']:.0f}x; "
              f"start-up excluded)")
    if system["memory_mb"] is not None:
        print(f"daemon peak RSS (VmHWM): {system['memory_mb']:.1f} MB (corridor and passing "
              f"flights; {system['memory_mb_all_flights']:.1f} MB over all)")
