"""Compare guidance strategies on identical seeded worlds; prints a Markdown table.

    python benchmarks/compare_strategies.py [--runs 100] [--seed 0] [--kinds sparse dense]

Columns: success (goal reached with clearance >= 0.95 d), collisions (true distance below the
obstacle's own radius), closest approach p5, and the median detour (path length minus the
straight start-goal distance).
"""
from __future__ import annotations

import argparse
import time

import numpy as np

from companion.config.scenario import load_scenario
from companion.sim.simulation import run_once
from companion.sim.worlds import random_world


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--runs", type=int, default=100)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--kinds", nargs="+", default=["sparse", "dense"])
    parser.add_argument("--strategies", nargs="+", default=["cone", "union", "apf"])
    args = parser.parse_args()
    base = load_scenario("config/scenarios/paper.yaml")
    d = base.safety_distance_m
    print("| worlds | strategy | success | collisions | closest approach p5 | median detour | wall s |")
    print("|---|---|---|---|---|---|---|")
    for kind in args.kinds:
        for strategy in args.strategies:
            start = time.perf_counter()
            rows = []
            for seed in range(args.seed, args.seed + args.runs):
                world = random_world(base, kind, seed)
                s = run_once(world, seed, strategy).summary
                straight = np.hypot(world.world.goal.north_m - world.world.start.north_m,
                                    world.world.goal.east_m - world.world.start.east_m
                                    ) - world.world.goal.radius_m   # the flight ends at the radius
                rows.append((s["reached_goal"] and s["min_clearance_m"] >= 0.95 * d,
                             s["collided"], s["min_clearance_m"], s["path_length_m"] - straight))
            ok, hit, clear, detour = map(np.array, zip(*rows))
            print(f"| {kind} | {strategy} | {ok.mean():.2f} | {hit.mean():.2f} | "
                  f"{np.percentile(clear, 5):.1f} m | {np.median(detour):.1f} m | "
                  f"{time.perf_counter() - start:.1f} |")


if __name__ == "__main__":
    main()
