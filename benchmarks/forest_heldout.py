"""Held-out forests (issue 28): trees from a generator the project's worlds do not use.

    python benchmarks/forest_heldout.py [--runs 30] [--seed 7000] [--rows grid400@5 grid800@3 ...]

companion/sim/forest_worlds.py draws Poisson-disc forests (dart throwing). This script draws its
own, with another spatial process at the same densities: a jittered grid, a square lattice of
pitch 1 / sqrt(density) (5 m at 400 per ha, 3.54 m at 800 per ha) rotated by a random angle,
each tree moved uniformly within +-JITTER of the pitch along both axes (so at least
(1 - 2 x JITTER) x pitch apart: 2.5 m at 400 per ha, 1.77 m at 800), trunks 0.1-0.4 m, the same
200 m leg, 60 m wide corridor (plus 10 m before and after) and clearings at the start and goal
as forest_worlds.forest_world. Each world is flown by run_once with config/scenarios/forest.yaml
at the row's speed; row ``gridDENSITY@V``. Columns as benchmarks/forest_table.py.
"""
from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))   # run as a script: the repo root

import argparse
import dataclasses
import math

import numpy as np

from companion.config.scenario import Scenario, load_scenario
from companion.config.world import Goal, Obstacle, StartPose, World
from companion.sim.forest_worlds import FOREST_SPECS, start_clearing_m
from companion.sim.simulation import with_speed
from benchmarks.table_rows import fly_row, parse_row  # noqa: E402

JITTER = 0.25            # of the pitch, either way along each axis


def jittered_grid_world(base: Scenario, seed: int, density_per_ha: float) -> Scenario:
    """A forest of ``density_per_ha`` on a rotated, jittered square lattice (module docstring)."""
    spec = FOREST_SPECS["forest"]
    rng = np.random.default_rng([seed, 0x6E1D])
    leg = spec.leg_m
    pitch = 100.0 / math.sqrt(density_per_ha)
    angle = rng.uniform(0.0, 0.5 * math.pi)
    reach = leg + 2.0 * (spec.margin_m + spec.corridor_half_width_m)
    ticks = np.arange(-reach, reach, pitch)
    gu, gv = np.meshgrid(ticks, ticks, indexing="ij")
    lattice = np.stack([gu.ravel(), gv.ravel()], axis=1) + rng.uniform(-0.5, 0.5, 2) * pitch
    lattice = lattice + rng.uniform(-JITTER, JITTER, lattice.shape) * pitch
    c, s = math.cos(angle), math.sin(angle)
    trees = lattice @ np.array([[c, s], [-s, c]]) + np.array([0.5 * leg, 0.0])
    inside = (trees[:, 0] >= -spec.margin_m) & (trees[:, 0] <= leg + spec.margin_m) \
        & (np.abs(trees[:, 1]) <= spec.corridor_half_width_m)
    trees = trees[inside]
    radii = rng.uniform(*spec.radius_m, len(trees))
    d = base.safety_distance_m
    keep = (np.hypot(trees[:, 0], trees[:, 1]) > start_clearing_m(base, spec)) \
        & (np.hypot(trees[:, 0] - leg, trees[:, 1]) > d + spec.clearing_extra_m)
    obstacles = tuple(Obstacle(id=i + 1, north_m=float(p[0]), east_m=float(p[1]), radius_m=float(r))
                      for i, (p, r) in enumerate(zip(trees[keep], radii[keep])))
    world = World(start=StartPose(0.0, 0.0, 0.0), goal=Goal(float(leg), 0.0, base.world.goal.radius_m),
                  obstacles=obstacles, origin=base.world.origin)
    max_time = max(base.mission.max_time_s, 3.0 * leg / base.vehicle.speed_mps)
    return dataclasses.replace(base, name=f"grid{density_per_ha:g}-{seed}", world=world,
                               mission=dataclasses.replace(base.mission, max_time_s=max_time),
                               avoidance=dataclasses.replace(base.avoidance,
                                                             mission_time_s=max_time))


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--runs", type=int, default=30)
    parser.add_argument("--seed", type=int, default=7000)
    parser.add_argument("--rows", nargs="+", default=["grid400@5", "grid400@10", "grid800@3"])
    args = parser.parse_args()
    base = load_scenario("config/scenarios/forest.yaml")
    print("| worlds | speed | d | seeds | success | collisions | centre clearance p5 (min) | "
          "surface min | median path | timed out | wall s | failed seeds (closest centre) |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for row in args.rows:
        kind, speed, _ = parse_row(row)
        density = float(kind.removeprefix("grid"))
        scenario = with_speed(base, speed)
        d = scenario.safety_distance_m                 # d grows with the cruise speed
        f = fly_row(lambda seed: jittered_grid_world(scenario, seed, density),
                    range(args.seed, args.seed + args.runs), d)
        print(f"| jittered grid {density:g}/ha | {speed:g} m/s | {d:.2f} m | {args.seed}-"
              f"{args.seed + args.runs - 1} | {f.ok.mean():.2f} | {f.hit.mean():.2f} | "
              f"{np.percentile(f.clear_m, 5):.2f} m ({f.clear_m.min():.2f} m) | {f.surface_m.min():.2f} m | "
              f"{np.median(f.path_m):.0f} m | {f.late.sum()} | {f.wall_s:.0f} | "
              f"{f.failed() or '-'} |", flush=True)

if __name__ == "__main__":
    main()
