"""Where a lock-step step's time goes: CPU per step of the stub, the companion and the demo's
ground station, measured while `companion demo --lockstep` flies the paper scenario.

    python -m benchmarks.lockstep_cost [--runs 3] [--scenario config/scenarios/paper.yaml]
                                       [--overlap]    # companion demo --lockstep-overlap

The lock-step loop is serial: the stub steps and sends, the companion answers, the stub steps
again. So on a machine with a core free for each, a step costs about the stub's CPU plus the
companion's plus the wake-ups between them, and the real-time factor is bounded by
dt / (stub + companion CPU per step) (with --overlap, where the stub runs one step ahead:
dt / the larger of the two). On a shared machine the wall time is that plus the time
the processes wait for a core; CPU per step is what the code costs, whatever the load.

Each process's CPU (its main thread's on-CPU time from /proc/PID/schedstat, in ns: the event
loop's thread, the only busy one; psutil's user + system where that is missing) and context switches are sampled when the stub logs the
companion's first ODOMETRY (the flight's first step) and when the companion logs its arrival:
the figures are the deltas, divided by the steps flown between (the arrival's vehicle time in
the companion's report). The system CPU (psutil, 10 ms ticks) is only a rough split.
"""
from __future__ import annotations

import argparse
import json
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import psutil

REPO = Path(__file__).resolve().parents[1]
PAPER = REPO / "config/scenarios/paper.yaml"
POLL_S = 0.005


def _role(proc: psutil.Process) -> str | None:
    try:
        cmd = proc.cmdline()
    except psutil.Error:
        return None
    if "sitl_stub" in cmd:
        return "stub"
    if "companion" in cmd and "run" in cmd:
        return "companion"
    return None


def _cpu_s(proc: psutil.Process) -> float:
    """On-CPU time of ``proc``'s main thread, where its event loop runs (Linux
    /proc/PID/schedstat, nanoseconds; the per-thread files are missing on this VM's kernel);
    psutil's user + system of all threads where that is missing, which counts 10 ms ticks: too
    coarse for a flight of one wall second (+-23 us a step over 426 steps)."""
    try:
        return int(Path(f"/proc/{proc.pid}/schedstat").read_text().split()[0]) / 1e9
    except (OSError, ValueError, IndexError):
        cpu = proc.cpu_times()
        return cpu.user + cpu.system


def _log_time(path: Path, pattern: re.Pattern) -> float | None:
    """The vehicle time in the first line of a child's log matching ``pattern``, if any yet."""
    try:
        text = path.read_text(errors="replace")
    except OSError:
        return None
    match = pattern.search(text)
    return float(match.group(1)) if match else None


FIRST_ANSWER = re.compile(r"lock-step peer: \S+ \(first ODOMETRY at ([\d.]+) s\)")
ARRIVED = re.compile(r"arrived at the goal at ([\d.]+) s")


def fly(scenario: Path, workdir: Path, overlap: bool = False) -> dict:
    """One flight: each process's CPU and switches sampled when the stub logs the companion's
    first ODOMETRY (the flight's first step; logging flushes every line) and when the companion
    logs its arrival, within POLL_S of each; the steps between are the arrival's vehicle time
    (the companion's report) less the first answer's."""
    keep, out = workdir / "keep", workdir / "out.json"
    demo = subprocess.Popen(
        [sys.executable, "-m", "companion", "demo", "--scenario", str(scenario), "--lockstep",
         "--keep", str(keep), "--json", str(out)] + (["--lockstep-overlap"] if overlap else []),
        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, cwd=REPO)
    gcs = psutil.Process(demo.pid)
    procs: dict[str, psutil.Process] = {"ground station": gcs}
    marks = []      # (wall s, {role: (cpu s, switches, system cpu s)}) at the first answer, arrival
    watched = [(keep / "sitl-stub.stderr", FIRST_ANSWER), (keep / "companion.stderr", ARRIVED)]
    first_t_s = None
    while demo.poll() is None and len(marks) < 2:
        if len(procs) < 3:
            for child in gcs.children():
                role = _role(child)
                if role is not None:
                    procs.setdefault(role, child)
        path, pattern = watched[len(marks)]
        t_s = _log_time(path, pattern) if len(procs) == 3 else None
        if t_s is not None:
            wall = time.perf_counter()
            figures = {}
            for role, proc in procs.items():
                try:
                    cpu, switches = proc.cpu_times(), proc.num_ctx_switches()
                    figures[role] = (_cpu_s(proc), switches.voluntary + switches.involuntary,
                                     cpu.system)
                except psutil.Error:
                    pass
            marks.append((wall, figures))
            first_t_s = t_s if first_t_s is None else first_t_s
        time.sleep(POLL_S)
    demo.wait()
    report = json.loads((keep / "companion-report.json").read_text()) \
        if (keep / "companion-report.json").exists() else {}
    arrival_s = report.get("arrival_t_s")
    if len(marks) < 2 or arrival_s is None or any(len(m[1]) < 3 for m in marks):
        return {"error": "no flight seen"}
    (wall0, start), (wall1, end) = marks
    steps = (arrival_s - first_t_s) / 0.1
    row = {"steps": steps, "wall_us_per_step": (wall1 - wall0) / steps * 1e6,
           "real_time_factor": (arrival_s - first_t_s) / (wall1 - wall0)}
    for role in ("stub", "companion", "ground station"):
        cpu0, sw0, sys0 = start[role]
        cpu1, sw1, sys1 = end[role]
        row[f"{role} cpu_us_per_step"] = (cpu1 - cpu0) / steps * 1e6
        row[f"{role} of it system_us_per_step"] = (sys1 - sys0) / steps * 1e6
        row[f"{role} switches_per_step"] = (sw1 - sw0) / steps
    serial = row["stub cpu_us_per_step"] + row["companion cpu_us_per_step"]
    row["bound_real_time_factor"] = 0.1 / (serial * 1e-6)
    # --lockstep-overlap: the two compute at once, so the slower one bounds the step
    row["overlap_bound_real_time_factor"] = 0.1 / (max(row["stub cpu_us_per_step"],
                                                       row["companion cpu_us_per_step"]) * 1e-6)
    return row


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--scenario", type=Path, default=PAPER)
    parser.add_argument("--overlap", action="store_true",
                        help="fly with --lockstep-overlap (the stub one step ahead)")
    args = parser.parse_args(argv)
    rows = []
    for _ in range(args.runs):
        with tempfile.TemporaryDirectory(prefix="lockstep-cost-") as tmp:
            rows.append(fly(args.scenario, Path(tmp), args.overlap))
    good = [r for r in rows if "error" not in r]
    if not good:
        print("no run gave figures:", rows)
        return 1
    print(f"{len(good)} of {len(rows)} lock-step flights of {args.scenario.name}, medians per step:")
    for key in good[0]:
        print(f"  {key:<34} {np.median([r[key] for r in good]):10.1f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
