"""CPU time of one path search (core/avoidance/path_search.plan_path) in a dense patch of trees.

    python benchmarks/path_plan_cost.py [--baseline DIR] [--rounds 2] [--repeats 15]

300 trees at least 2.5 m apart (forest-dense's spacing) in 80 m x 60 m ahead of the vehicle,
safety radii 1.5 m (d at 5 m/s), the goal 200 m away, with ``path_steady``'s parameters
(STEADY_PATH) and with the default ones. Each checkout (this one, and ``--baseline``, another
checkout of the repository) is timed in its own process, alternated ``--rounds`` times; each
figure is the median CPU time of ``--repeats`` plans.
"""
from __future__ import annotations

import argparse
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PROBE = """
import sys, time
sys.path.insert(0, sys.argv[1])
import numpy as np
from companion.core.avoidance.path_search import STEADY_PATH, PathParams, plan_path
rng = np.random.default_rng(1)
trees = []
while len(trees) < 300:
    p = rng.uniform([0.0, -30.0], [80.0, 30.0])
    if all(np.hypot(*(p - q)) >= 2.5 for q in trees):
        trees.append(p)
trees = np.array(trees)
radii = np.full(len(trees), 1.5)
for name, params in (("steady", STEADY_PATH), ("default", PathParams())):
    times = []
    for _ in range(int(sys.argv[2])):
        t = time.process_time()
        plan_path(np.array([-2.0, 0.0]), np.array([200.0, 0.0]), trees, radii, params, 0.0)
        times.append(time.process_time() - t)
    print(name, 1000.0 * float(np.median(times)))
"""


def measure(repo: str, repeats: int) -> dict[str, float]:
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1", MKL_NUM_THREADS="1")
    out = subprocess.run([sys.executable, "-c", PROBE, repo, str(repeats)], env=env, check=True,
                         capture_output=True, text=True).stdout
    return {line.split()[0]: float(line.split()[1]) for line in out.splitlines()}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--baseline", help="another checkout of the repository, timed alternately")
    parser.add_argument("--rounds", type=int, default=2)
    parser.add_argument("--repeats", type=int, default=15)
    args = parser.parse_args()
    repos = [str(ROOT)] + ([args.baseline] if args.baseline else [])
    for round_ in range(args.rounds):
        for repo in repos:
            figures = measure(repo, args.repeats)
            print(f"round {round_ + 1} {repo}: " + ", ".join(
                f"{name} {ms:.1f} ms" for name, ms in figures.items()))


if __name__ == "__main__":
    main()
