"""The service's own depth perception in real time (issue 44): capture -> setpoint latency and
CPU per second of flight, with the shipped defaults.

    nice python -m benchmarks.depth_service [--scenario config/scenarios/depth.yaml]
        [--flights 1] [--quota 0.25 --throttle cgroup|sigstop]

Each flight is ``companion demo --scenario S --no-lockstep --speedup 1``: the stub on the wall
clock renders its camera at the scenario's rate (depth.yaml: a D455 at 848x480, 15 Hz) and
serves the frames on a local TCP socket (``--depth-tcp``); ``companion run --depth stub:...``
(config/companion.yaml as shipped, the scenario laid over it as ``companion demo`` does) reads
them in its reader thread, perceives them in its executor and flies by them. Figures:

- capture -> setpoint: for each frame that gave an observation, from its capture (its
  time_boot_ms, the stub's clock, tied to the companion's Unix clock by the smallest receipt
  minus time_boot_ms of the MAVLink messages within TIE_WINDOW_S of the capture: cpu_quota.py's
  tie, taken locally because a loaded stub falls behind the wall clock and rebases) to the first
  SET_POSITION_TARGET_LOCAL_NED the companion sent after the frame's observations were in the
  estimator (the report's ``depth_feed.absorbed``, the tlog's sent records). It includes the
  stub's own rendering of the frame after its capture time, the socket, the wait in the slot,
  the perception and the decision. From the first setpoint on (commanding). ``capture_to_read``:
  its first part, to the frame read whole from the socket (the stub renders a frame at the first
  physics step at or after its capture, 0 to 67 ms later at 15 Hz on 10 Hz steps, then sends it).
- read -> absorbed: the service's own part (``depth_feed.read_to_absorbed_ms``: a frame read
  whole from the socket -> its observations in the estimator and the decision on them made; the
  setpoint goes to the socket next).
- perceive: the executor's time per frame (queueing included).
- CPU per second of flight: utime + stime of the ``companion run`` process (all its threads),
  sampled every 0.5 s, from arming to arrival (cpu_quota.py's DaemonWatch). Target: 0.25 of
  one core. With ``--quota``: the process under that quota (cpu_quota.py's throttles).
"""
from __future__ import annotations

import argparse
import json
import os
import signal
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

from benchmarks.cpu_quota import (DaemonWatch, OUR_COMPONENT, make_throttle, percentiles_ms,
                                  read_truth)
from companion.mavlink.tlog import TlogReader

REPO = Path(__file__).resolve().parents[1]
CPU_TARGET = 0.25
TIE_WINDOW_S = 1.0


def setpoints_and_ties(tlog: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(Unix s of every setpoint we sent, sorted), and for every message of the stub with a
    time_boot_ms: its stub s and its receipt minus that (Unix s - stub s), by stub s."""
    sent, boot, gap = [], [], []
    for record in TlogReader(tlog):
        t, msg = record.t_us / 1e6, record.msg
        if msg.get_srcComponent() == OUR_COMPONENT:
            if msg.get_type() == "SET_POSITION_TARGET_LOCAL_NED":
                sent.append(t)
        elif hasattr(msg, "time_boot_ms"):
            boot.append(msg.time_boot_ms / 1000.0)
            gap.append(t - msg.time_boot_ms / 1000.0)
    order = np.argsort(boot, kind="stable")
    return np.sort(np.array(sent)), np.array(boot)[order], np.array(gap)[order]


def offset_at(capture_s: float, boot: np.ndarray, gap: np.ndarray) -> float:
    """Unix s - stub s near ``capture_s``: the fastest delivery within TIE_WINDOW_S."""
    lo, hi = np.searchsorted(boot, [capture_s - TIE_WINDOW_S, capture_s + TIE_WINDOW_S])
    return float(gap[lo:hi].min()) if hi > lo else float(gap.min())


def capture_to_setpoint_s(absorbed: list, sent: np.ndarray, boot: np.ndarray,
                          gap: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per frame with observations, after the first setpoint: capture -> the next setpoint,
    and capture -> read whole from the socket (the stub's rendering and the socket)."""
    if len(sent) == 0:
        return np.zeros(0), np.zeros(0)
    total, read = [], []
    for capture_s, absorbed_unix_s, observations, read_unix_s in absorbed:
        if observations <= 0 or absorbed_unix_s < sent[0]:
            continue
        i = int(np.searchsorted(sent, absorbed_unix_s))
        if i < len(sent):
            captured_unix_s = capture_s + offset_at(capture_s, boot, gap)
            total.append(sent[i] - captured_unix_s)
            read.append(read_unix_s - captured_unix_s)
    return np.array(total), np.array(read)


def fly(scenario: str, workdir: Path, seed: int, throttle) -> dict:
    keep, tlog, out = workdir / f"f{seed}", workdir / f"f{seed}.tlog", workdir / f"f{seed}.json"
    demo = subprocess.Popen(
        [sys.executable, "-m", "companion", "demo", "--scenario", scenario, "--no-lockstep",
         "--speedup", "1", "--seed", str(seed), "--tlog", str(tlog), "--keep", str(keep),
         "--json", str(out)], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
        stdin=subprocess.DEVNULL, cwd=REPO)
    watch = DaemonWatch(demo, throttle)
    watch.start()
    try:
        _, stderr = demo.communicate(timeout=600)
    except subprocess.TimeoutExpired:
        demo.send_signal(signal.SIGINT)
        _, stderr = demo.communicate(timeout=30)
    watch.stop()
    result: dict = {"seed": seed}
    if not out.exists():
        return {**result, "error": stderr.decode(errors="replace")[-400:]}
    run = json.loads(out.read_text())["runs"][0]
    result.update(reached_goal=run["reached_goal"], min_clearance_m=round(run["min_clearance_m"], 2),
                  flight_s=run["time_s"])
    report = json.loads((keep / "companion-report.json").read_text())
    feed = report["depth_feed"]
    sent, boot, gap = setpoints_and_ties(tlog)
    latency, to_read = capture_to_setpoint_s(feed["absorbed"], sent, boot, gap)
    result.update(capture_to_setpoint=percentiles_ms(latency),
                  capture_to_read=percentiles_ms(to_read),
                  read_to_absorbed_ms=feed["read_to_absorbed_ms"], perceive_ms=feed["perceive_ms"],
                  frames_received=feed["received"], frames_dropped=feed["dropped"],
                  frames_perceived=report.get("depth", {}).get("frames"))
    armed = [r for r in read_truth(keep / "truth.jsonl") if r["armed"]]
    if watch.samples and armed:
        start = armed[0]["t_s"] + offset_at(armed[0]["t_s"], boot, gap)
        end = start + result["flight_s"]
        picked = [(t, c) for t, c in watch.samples if start <= t <= end]
        if len(picked) >= 2:
            result["cpu_s_per_s"] = round((picked[-1][1] - picked[0][1])
                                          / (picked[-1][0] - picked[0][0]), 3)
    return result


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scenario", default="config/scenarios/depth.yaml")
    ap.add_argument("--flights", type=int, default=1, help="seeds 0..N-1 (default 1)")
    ap.add_argument("--quota", type=float, help="run the service under this CPU quota")
    ap.add_argument("--throttle", choices=("cgroup", "sigstop"), default="cgroup")
    ap.add_argument("--json", help="write the figures here")
    args = ap.parse_args(argv)
    print(f"load average before: {os.getloadavg()[0]:.2f}, {os.cpu_count()} cpus", flush=True)
    flights = []
    with tempfile.TemporaryDirectory(prefix="depth-service-") as tmp:
        for seed in range(args.flights):
            throttle = None if args.quota is None else \
                make_throttle(args.throttle, args.quota, f"depth-service-{os.getpid()}-{seed}")
            try:
                flights.append(fly(args.scenario, Path(tmp), seed, throttle))
            finally:
                if throttle is not None:
                    throttle.close()
            print(json.dumps(flights[-1]), flush=True)
    print(f"load average after: {os.getloadavg()[0]:.2f}")
    cpu = [f["cpu_s_per_s"] for f in flights if "cpu_s_per_s" in f]
    if cpu:
        print(f"CPU per second of flight: max {max(cpu):.3f} of a core (target {CPU_TARGET}: "
              f"{'met' if max(cpu) <= CPU_TARGET else 'NOT met'})")
    if args.json:
        Path(args.json).write_text(json.dumps({"quota": args.quota, "flights": flights},
                                              indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
