"""The README's forest table (issue 28): success and collisions against speed at both densities.

    python benchmarks/forest_table.py [--runs 100] [--rows forest@3 forest@5 ... forest-dense@10]

Row ``KIND@V`` flies `companion simulate --scenario config/scenarios/forest.yaml --random-worlds
KIND --speed-mps V --runs N` (seeds 0..N-1). Columns: success (goal reached with every tree's
centre at least 0.95 d away), collisions (inside a trunk), closest approach to a centre p5 and
min, to a trunk's surface min, median path length, runs that timed out, wall time. Rows run one
after another; on a shared machine start a process per row.
"""
from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))   # run as a script: the repo root

import argparse

import numpy as np

from companion.config.scenario import load_scenario
from companion.sim.simulation import with_speed
from companion.sim.worlds import random_world
from benchmarks.table_rows import fly_row, parse_row  # noqa: E402

ROWS = tuple(f"{kind}@{v}" for kind in ("forest", "forest-dense") for v in (3, 5, 7, 10))


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--runs", type=int, default=100)
    parser.add_argument("--rows", nargs="+", default=list(ROWS))
    args = parser.parse_args()
    base = load_scenario("config/scenarios/forest.yaml")
    print("| worlds | speed | d | runs | success | collisions | centre clearance p5 (min) | "
          "surface min | median path | timed out | wall s |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for row in args.rows:
        kind, speed, _ = parse_row(row)
        scenario = with_speed(base, speed)
        d = scenario.safety_distance_m                 # d grows with the cruise speed
        f = fly_row(lambda seed: random_world(scenario, kind, seed), range(args.runs), d)
        print(f"| {kind} | {speed:g} m/s | {d:.2f} m | {args.runs} | {f.ok.mean():.2f} | {f.hit.mean():.2f} | "
              f"{np.percentile(f.clear_m, 5):.2f} m ({f.clear_m.min():.2f} m) | {f.surface_m.min():.2f} m | "
              f"{np.median(f.path_m):.0f} m | {f.late.sum()} | {f.wall_s:.0f} |", flush=True)

if __name__ == "__main__":
    main()
