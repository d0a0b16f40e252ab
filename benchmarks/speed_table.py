"""The README's Monte Carlo table for issue 16: worlds x speeds, the union law; Markdown rows.

    python benchmarks/speed_table.py [--runs 100] [--rows dense@5 dense@10 traffic@5 ...]

A row ``KIND@V+gaps`` sets avoidance.gap_margin_m to 1 m. Each row flies `companion simulate --random-worlds KIND --speed-mps V --runs N` (seeds 0..N-1)
on config/scenarios/paper.yaml. Columns: success (goal reached with clearance >= 0.95 d),
collisions (true distance below the obstacle's radius), closest approach p5 and min, median
detour (path length minus the straight line to the goal radius), wall time. Rows run one after
another; on a shared machine start two or three processes with their own --rows.
"""
from __future__ import annotations

import argparse
import dataclasses
import time

import numpy as np

from companion.config.scenario import load_scenario
from companion.sim.simulation import run_once, with_speed
from companion.sim.worlds import random_world

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
        kind, speed = row.split("@")
        gaps = speed.endswith("+gaps")            # avoidance.gap_margin_m = 1 m
        speed = speed.removesuffix("+gaps")
        scenario = with_speed(base, float(speed))
        if gaps:
            scenario = dataclasses.replace(scenario, avoidance=dataclasses.replace(
                scenario.avoidance, gap_margin_m=1.0))
        d = scenario.safety_distance_m              # the d of this row's speed
        start = time.perf_counter()
        rows = []
        for seed in range(args.runs):
            world = random_world(scenario, kind, seed)
            s = run_once(world, seed).summary
            straight = np.hypot(world.world.goal.north_m - world.world.start.north_m,
                                world.world.goal.east_m - world.world.start.east_m
                                ) - world.world.goal.radius_m
            rows.append((s["reached_goal"] and s["min_clearance_m"] >= 0.95 * d, s["collided"],
                         s["min_clearance_m"], s["path_length_m"] - straight))
        ok, hit, clear, detour = map(np.array, zip(*rows))
        print(f"| {kind} | {float(speed):g} m/s{', gaps 1 m' if gaps else ''} | {ok.mean():.2f} | {hit.mean():.2f} | "
              f"{np.percentile(clear, 5):.1f} m ({clear.min():.1f} m) | {np.median(detour):.1f} m | "
              f"{time.perf_counter() - start:.0f} |", flush=True)


if __name__ == "__main__":
    main()
