"""The README's forest table (issue 28): success and collisions against speed at both densities.

    python benchmarks/forest_table.py [--runs 100] [--rows forest@3 forest@5 ... forest-dense@10]

Row ``KIND@V`` flies `companion simulate --scenario config/scenarios/forest.yaml --random-worlds
KIND --speed-mps V --runs N` (seeds 0..N-1). Columns: success (goal reached with every tree's
centre at least 0.95 d away), collisions (inside a trunk), closest approach to a centre p5 and
min, to a trunk's surface min, median path length, runs that timed out, wall time. Rows run one
after another; on a shared machine start a process per row.
"""
from __future__ import annotations

import argparse
import time

import numpy as np

from companion.config.scenario import load_scenario
from companion.sim.simulation import run_once, with_speed
from companion.sim.worlds import random_world

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
        kind, speed = row.split("@")
        scenario = with_speed(base, float(speed))
        d = scenario.safety_distance_m                 # d grows with the cruise speed
        start = time.perf_counter()
        rows = []
        for seed in range(args.runs):
            s = run_once(random_world(scenario, kind, seed), seed).summary
            rows.append((s["reached_goal"] and s["min_clearance_m"] >= 0.95 * d, s["collided"],
                         s["min_clearance_m"], s["min_surface_clearance_m"], s["path_length_m"],
                         not s["arrived"]))
        ok, hit, clear, surface, path, late = map(np.array, zip(*rows))
        print(f"| {kind} | {float(speed):g} m/s | {d:.2f} m | {args.runs} | {ok.mean():.2f} | {hit.mean():.2f} | "
              f"{np.percentile(clear, 5):.2f} m ({clear.min():.2f} m) | {surface.min():.2f} m | "
              f"{np.median(path):.0f} m | {late.sum()} | {time.perf_counter() - start:.0f} |",
              flush=True)


if __name__ == "__main__":
    main()
