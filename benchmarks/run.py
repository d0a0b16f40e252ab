"""Benchmarks: ``python benchmarks/run.py [--quick] [--json PATH]``.

Prints a table and writes JSON with every figure measured in this one run, so ratios compare
numbers taken side by side on the same (shared, noisy) machine. Timing goals live here, not in
the tests.
"""
from __future__ import annotations

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")      # as the service does: see companion/__main__.py

import argparse  # noqa: E402
import json  # noqa: E402
import platform  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))          # the dense oracle lives in tests/, the sections beside this file

from benchmarks import ekf  # noqa: E402


def targets(report: dict) -> dict:
    """The issue's goals, each a ratio of figures from this run."""
    rows = {row["landmarks"]: row for row in report["ekf"]}
    out = {
        "update_200_over_floor": rows[200]["update_us"] / rows[200]["floor_rank2_us"],
        "dense_200_over_update": rows[200]["dense_update_us"] / rows[200]["update_us"],
        "predict_500_over_10": rows[500]["predict_us"] / rows[10]["predict_us"],
    }
    limits = {"update_200_over_floor": ("<=", 2.5), "dense_200_over_update": (">=", 40.0),
              "predict_500_over_10": ("<=", 3.0)}
    system = report.get("system", {})
    if "latency_ms" in system:
        out["latency_p99_ms"] = system["latency_ms"]["p99"]
        limits["latency_p99_ms"] = ("<", 2.0)
    if "replay" in system:
        out["replay_over_parse"] = system["replay"]["msgs_per_s"] / system["replay"]["parse_only_msgs_per_s"]
        limits["replay_over_parse"] = (">=", 0.5)
    if "closed_loop" in system:
        out["closed_loop_real_time_factor"] = system["closed_loop"]["sim_s"] / system["closed_loop"]["wall_s"]
        limits["closed_loop_real_time_factor"] = (">=", 50.0)
    verdicts = {}
    for key, value in out.items():
        op, limit = limits[key]
        ok = value <= limit if op == "<=" else value >= limit if op == ">=" else value < limit
        verdicts[key] = {"value": value, "target": f"{op} {limit}", "met": bool(ok)}
    return verdicts


def print_report(report: dict) -> None:
    print(f"{'landmarks':>9} {'predict us':>11} {'update us':>10} {'step10 us':>10} "
          f"{'floor us':>9} {'dense us':>10} {'upd/floor':>9} {'dense/upd':>9}")
    for row in report["ekf"]:
        print(f"{row['landmarks']:>9} {row['predict_us']:>11.1f} {row['update_us']:>10.1f} "
              f"{row['step10_us']:>10.1f} {row['floor_rank2_us']:>9.1f} {row['dense_update_us']:>10.1f} "
              f"{row['update_us'] / row['floor_rank2_us']:>9.2f} "
              f"{row['dense_update_us'] / row['update_us']:>9.1f}")
    if "system" in report:
        from benchmarks.system import print_system
        print_system(report["system"])
    print("targets:")
    for key, verdict in report["targets"].items():
        print(f"  {key:<30} {verdict['value']:>10.3f}  {verdict['target']:<8} "
              f"{'met' if verdict['met'] else 'NOT MET'}")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer repetitions (about a minute)")
    parser.add_argument("--json", metavar="PATH", help="write the figures as JSON")
    parser.add_argument("--skip-system", action="store_true",
                        help="estimator only (no stub, daemon or replay)")
    args = parser.parse_args()
    started = time.perf_counter()
    report = {"machine": {"python": platform.python_version(), "processor": platform.machine()},
              "quick": args.quick, "ekf": ekf.run(args.quick)}
    if not args.skip_system:
        from benchmarks import system
        report["system"] = system.run(args.quick)
    report["targets"] = targets(report)
    report["wall_s"] = time.perf_counter() - started
    print_report(report)
    if args.json:
        Path(args.json).write_text(json.dumps(report, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
