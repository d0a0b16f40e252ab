"""``companion simulate`` wall time against a baseline checkout, alternated (issue 28 item 5).

    git worktree add /tmp/base f61c56d        # the checkout to compare with (any commit)
    python benchmarks/simulate_throughput.py --baseline /tmp/base [--rounds 5]
        [--args "--random-worlds dense --runs 100"]

Each round runs the baseline's CLI, then this checkout's, as subprocesses with the same Python
(``PYTHONPATH`` set to each tree, each from its own folder so the scenario paths resolve), and
times them from outside. Alternating puts the two side by side in the machine's same moments: on
a shared machine the load moves both, so the ratio of the pair says more than either time. It
prints every time, each side's median, the ratio of the medians and the median of the pairs'
ratios, and checks that both wrote the same aggregate (the speed-up must not change a result;
fields a tree does not have are left out of the comparison).
"""
from __future__ import annotations

import argparse
import json
import os
import shlex
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parents[1]


def timed_run(tree: Path, args: list[str], json_path: Path) -> float:
    """Seconds of wall time of ``python -m companion ARGS --json JSON_PATH`` from ``tree``."""
    env = dict(os.environ, PYTHONPATH=str(tree))
    start = time.perf_counter()
    subprocess.run([sys.executable, "-m", "companion", *args, "--json", str(json_path)],
                   cwd=tree, env=env, check=True, stdout=subprocess.DEVNULL)
    return time.perf_counter() - start


def same_aggregate(a: dict, b: dict) -> bool:
    """The runs' summaries equal on the keys both trees write."""
    runs_a, runs_b = a["runs"], b["runs"]
    return len(runs_a) == len(runs_b) and all(
        all(x[k] == y[k] for k in x.keys() & y.keys()) for x, y in zip(runs_a, runs_b))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--baseline", required=True, type=Path, help="a checkout to compare with")
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--args", default="simulate --random-worlds dense --runs 100",
                        help="the companion command line to time (default: %(default)s)")
    args = parser.parse_args()
    command = shlex.split(args.args)
    if command[0] != "simulate":
        command = ["simulate", *command]
    times: dict[str, list[float]] = {"baseline": [], "this": []}
    with tempfile.TemporaryDirectory() as tmp:
        outputs = {name: Path(tmp) / f"{name}.json" for name in times}
        for round_no in range(1, args.rounds + 1):
            for name, tree in (("baseline", args.baseline.resolve()), ("this", HERE)):
                seconds = timed_run(tree, command, outputs[name])
                times[name].append(seconds)
                print(f"round {round_no}: {name:8s} {seconds:7.2f} s", flush=True)
        equal = same_aggregate(*(json.loads(outputs[n].read_text()) for n in times))
    base, this = (statistics.median(times[n]) for n in times)
    pairs = statistics.median(b / t for b, t in zip(times["baseline"], times["this"]))
    print(f"medians: baseline {base:.2f} s, this {this:.2f} s: {base / this:.2f}x; "
          f"median of the pairs' ratios {pairs:.2f}x; same runs: {'yes' if equal else 'NO'}")


if __name__ == "__main__":
    main()
