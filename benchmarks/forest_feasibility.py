"""The best any flight could do in a forest: the widest passage from start to goal in the true world.

For each seeded world, the bottleneck clearance of the best path: the largest c such that the
start and the goal are joined by a path keeping at least c from every tree's centre (the
clearance ``companion simulate`` scores, success being c >= 0.95 d). It is found on a grid
(``--resolution-m``, default 0.04 m) by the distance transform and a bisection on c over the
connected free space; the path stays within ``--side-m`` of the centre line (default 30 m, the
corridor's edge: a crossing of the forest; 45 lets it go round the forest outside the corridor,
which only the clearings at the start and the goal then bound). No flight with perfect knowledge and
tracking can pass a world whose bottleneck is below 0.95 d, so the fraction of worlds at or above
it is an upper bound on the success rate at that d.

    python -m benchmarks.forest_feasibility --kind forest-dense --runs 100 [--seed 0]

prints each seed's bottleneck and, for several d, the bound on success.
"""
from __future__ import annotations

import argparse
import json

import numpy as np
from scipy import ndimage

from companion.config.paths import resolve_config
from companion.config.scenario import load_scenario
from companion.sim.forest_worlds import FOREST_SPECS, forest_world


def bottleneck_clearance_m(centres: np.ndarray, start: tuple[float, float], goal: tuple[float, float],
                           lo: tuple[float, float], hi: tuple[float, float],
                           resolution_m: float = 0.04, bisections: int = 12) -> float:
    """Largest c (to within the grid) such that a path from ``start`` to ``goal`` inside the box
    [lo, hi] keeps at least c from every centre (k, 2); 0 if start or goal sits on a centre."""
    lo_a, hi_a = np.asarray(lo, float), np.asarray(hi, float)
    shape = np.floor((hi_a - lo_a) / resolution_m).astype(int) + 1
    free = np.ones(shape, bool)
    cells = np.round((np.asarray(centres, float).reshape(-1, 2) - lo_a) / resolution_m).astype(int)
    inside = np.all((cells >= 0) & (cells < shape), axis=1)
    free[cells[inside, 0], cells[inside, 1]] = False
    distance_m = ndimage.distance_transform_edt(free) * resolution_m
    s = tuple(np.round((np.asarray(start) - lo_a) / resolution_m).astype(int))
    g = tuple(np.round((np.asarray(goal) - lo_a) / resolution_m).astype(int))
    low, high = 0.0, float(distance_m.max())
    for _ in range(bisections):
        c = 0.5 * (low + high)
        labels, _ = ndimage.label(distance_m >= c)
        if labels[s] and labels[s] == labels[g]:
            low = c
        else:
            high = c
    return low


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--kind", choices=sorted(FOREST_SPECS), default="forest-dense")
    parser.add_argument("--runs", type=int, default=100)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--resolution-m", type=float, default=0.04)
    parser.add_argument("--side-m", type=float, default=30.0)
    parser.add_argument("--json", default=None)
    args = parser.parse_args(argv)
    base = load_scenario(resolve_config("config/scenarios/forest.yaml"))
    spec = FOREST_SPECS[args.kind]
    found = {}
    for seed in range(args.seed, args.seed + args.runs):
        world = forest_world(base, seed, args.kind).world
        centres = np.array([[o.north_m, o.east_m] for o in world.obstacles])
        c = bottleneck_clearance_m(centres, (world.start.north_m, world.start.east_m),
                                   (world.goal.north_m, world.goal.east_m),
                                   (-spec.margin_m - 5.0, -args.side_m),
                                   (spec.leg_m + spec.margin_m + 5.0, args.side_m), args.resolution_m)
        found[seed] = c
        print(f"seed {seed}: widest passage keeps {c:.2f} m from every centre", flush=True)
    values = np.array(list(found.values()))
    print(f"{args.kind}, seeds {args.seed}-{args.seed + args.runs - 1}: bottleneck median "
          f"{np.median(values):.2f} m, min {values.min():.2f} m")
    for d in (1.0, 1.2, 1.5, 2.0):
        print(f"  d = {d:.1f} m: {np.mean(values >= 0.95 * d):.2f} of the worlds can be passed at 0.95 d")
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"kind": args.kind, "bottleneck_m": found}, f, indent=1)


if __name__ == "__main__":
    main()
