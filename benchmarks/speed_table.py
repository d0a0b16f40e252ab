"""The README's Monte Carlo table for issue 16: worlds x speeds, the union law; Markdown rows.

    python benchmarks/speed_table.py [--runs 100] [--rows dense@5 dense@10 traffic@5 ...]

A row ``KIND@V+gaps`` sets avoidance.gap_margin_m to 1 m. Each row flies `companion simulate --random-worlds KIND --speed-mps V --runs N` (seeds 0..N-1)
on config/scenarios/paper.yaml. Columns: success (goal reached with clearance >= 0.95 d),
collisions (true distance below the obstacle's radius), closest approach p5 and min, median
detour (path length minus the straight line to the goal radius), wall time. Rows run one after
another; on a shared machine start two or three processes with their own --rows.
"""
from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))   # run as a script: the repo root

import argparse
import dataclasses

import numpy as np

from companion.config.scenario import load_scenario
from companion.sim.simulation import with_speed
from companion.sim.worlds import random_world
from benchmarks.table_rows import fly_row, parse_row  # noqa: E402

ROWS = ("sparse@5", "dense@5", "dense@10", "dense@15", "moving@5", "head-on@5", "crossing@5",
        "overtaking@5", "traffic@5", "gate@5", "gate@5+gaps", "trap@5", "dense@5+gaps")


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--runs", type=int, default=100)
    parser.add_argument("--rows", nargs="+", default=list(ROWS))
    args = parser.parse_args()
    base = load_scenario("config/scenarios/paper.yaml")
    print("| worlds | speed | success | collisions | closest approach p5 (min) | median detour | wall s |")
    print("|---|---|---|---|---|---|---|")
    for row in args.rows:
        kind, speed, suffix = parse_row(row)
        gaps = suffix == "gaps"                   # avoidance.gap_margin_m = 1 m
        scenario = with_speed(base, speed)
        if gaps:
            scenario = dataclasses.replace(scenario, avoidance=dataclasses.replace(
                scenario.avoidance, gap_margin_m=1.0))
        d = scenario.safety_distance_m              # the d of this row's speed
        f = fly_row(lambda seed: random_world(scenario, kind, seed), range(args.runs), d)
        print(f"| {kind} | {speed:g} m/s{', gaps 1 m' if gaps else ''} | {f.ok.mean():.2f} | {f.hit.mean():.2f} | "
              f"{np.percentile(f.clear_m, 5):.1f} m ({f.clear_m.min():.1f} m) | {np.median(f.detour_m):.1f} m | "
              f"{f.wall_s:.0f} |", flush=True)

if __name__ == "__main__":
    main()
