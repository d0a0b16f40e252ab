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

Each process's CPU (user + system, psutil) and context switches are sampled every few
milliseconds with the vehicle time (the stub's truth log): the figures are the deltas over the
flight, from the first step after arming to the arrival, divided by the steps flown.
"""
from __future__ import annotations

import argparse
import json
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


def _last_truth(path: Path) -> tuple[float, bool] | None:
    """(t_s, armed) of the truth log's last whole line."""
    try:
        with path.open("rb") as f:
            f.seek(0, 2)
            size = f.tell()
            f.seek(max(0, size - 4096))
            lines = f.read().splitlines()
    except OSError:
        return None
    for line in reversed(lines):
        try:
            record = json.loads(line)
        except ValueError:
            continue
        return float(record["t_s"]), bool(record.get("armed"))
    return None


def fly(scenario: Path, workdir: Path, overlap: bool = False) -> dict:
    keep, out = workdir / "keep", workdir / "out.json"
    demo = subprocess.Popen(
        [sys.executable, "-m", "companion", "demo", "--scenario", str(scenario), "--lockstep",
         "--keep", str(keep), "--json", str(out)] + (["--lockstep-overlap"] if overlap else []),
        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, cwd=REPO)
    gcs = psutil.Process(demo.pid)
    procs: dict[str, psutil.Process] = {"ground station": gcs}
    samples = []      # (wall s, vehicle t_s, armed, {role: (cpu s, switches, system cpu s)})
    while demo.poll() is None:
        if len(procs) < 3:
            for child in gcs.children():
                role = _role(child)
                if role is not None:
                    procs.setdefault(role, child)
        truth = _last_truth(keep / "truth.jsonl")
        figures = {}
        for role, proc in procs.items():
            try:
                cpu, switches = proc.cpu_times(), proc.num_ctx_switches()
            except psutil.Error:
                continue
            figures[role] = (cpu.user + cpu.system, switches.voluntary + switches.involuntary,
                             cpu.system)
        if truth is not None and len(figures) == 3:
            samples.append((time.perf_counter(), truth[0], truth[1], figures))
        time.sleep(POLL_S)
    result = json.loads(out.read_text())
    arrival_s = result["runs"][0].get("time_s")
    flying = [s for s in samples if s[2]]
    if arrival_s is None or len(flying) < 2:
        return {"error": "no flight seen"}
    t0 = flying[0][1]
    end = next((s for s in flying if s[1] >= t0 + arrival_s - 1e-6), flying[-1])
    start = flying[0]
    steps = (end[1] - start[1]) / 0.1
    row = {"steps": steps, "wall_us_per_step": (end[0] - start[0]) / steps * 1e6,
           "real_time_factor": (end[1] - start[1]) / (end[0] - start[0])}
    for role in ("stub", "companion", "ground station"):
        cpu0, sw0, sys0 = start[3][role]
        cpu1, sw1, sys1 = end[3][role]
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
