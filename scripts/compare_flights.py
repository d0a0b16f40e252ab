#!/usr/bin/env python3
"""Seeded flights before and after a change: save them, then compare them field by field.

    python scripts/compare_flights.py save DIR [--python PY] [--repo REPO]
    python scripts/compare_flights.py compare DIR_A DIR_B

``save`` runs the ``companion`` CLI as a subprocess (``PY -m companion``, from ``REPO`` so the
scenario paths resolve) and writes one JSON file per flight set into DIR:

    paper.json    companion simulate --scenario config/scenarios/paper.yaml --runs 10 (seeds 0-9)
    traffic.json  companion simulate --scenario config/scenarios/copter.yaml --random-worlds traffic
                  --runs 30 (seeds 0-29)
    dense.json    companion simulate --random-worlds dense --runs 30 (seeds 0-29, paper.yaml base)
    urban.json    companion simulate --scenario config/scenarios/sectors.yaml --random-worlds urban
                  --runs 10 (seeds 0-9; urban worlds need a sensor that sees walls: sectors.yaml)
    demo.json     companion demo --scenario config/scenarios/paper.yaml --lockstep --seed 0
                  (stub, daemon and ground station as processes on loopback, lock-step)

``compare`` prints ``equal`` and exits 0 when every field of every file is the same (floats
exactly: a behaviour-preserving change flies the same bits), otherwise it lists each differing
field as ``file: path: A != B`` and exits 1. Ignored, because they are honestly run-dependent:

    aggregate.wall_time_s       the demo's wall seconds from start to end (process start-up,
                                machine load)
    aggregate.flight_wall_s     the demo's wall seconds of the flight itself (machine load)
    aggregate.real_time_factor  flight_sim_s / flight_wall_s, so as run-dependent as the latter

Everything else is compared, the lock-step demo's flight included: lock-step makes the stub and
the companion step together, so the flight does not depend on the load (README, lock-step).

It lives in scripts/ (not in the package, not in benchmarks/): it is a developer's check for
behaviour-preserving changes, it prints no figures, and it drives the CLI from outside so the same
script can record any checkout (``--python``/``--repo`` of another worktree).
"""
from __future__ import annotations

import argparse
import json
import math
import subprocess
import sys
import tempfile
from pathlib import Path

FLIGHTS: dict[str, list[str]] = {
    "paper": ["simulate", "--scenario", "config/scenarios/paper.yaml", "--seed", "0", "--runs", "10"],
    "traffic": ["simulate", "--scenario", "config/scenarios/copter.yaml", "--random-worlds", "traffic",
                "--seed", "0", "--runs", "30"],
    "dense": ["simulate", "--random-worlds", "dense", "--seed", "0", "--runs", "30"],
    "urban": ["simulate", "--scenario", "config/scenarios/sectors.yaml", "--random-worlds", "urban",
              "--seed", "0", "--runs", "10"],
    "demo": ["demo", "--scenario", "config/scenarios/paper.yaml", "--lockstep", "--seed", "0"],
}

# dotted paths (list indices as numbers) whose values depend on the run, not on the code
RUN_DEPENDENT = {
    "aggregate.wall_time_s",
    "aggregate.flight_wall_s",
    "aggregate.real_time_factor",
}


def save(out_dir: Path, python: str, repo: Path, only: list[str] | None) -> int:
    out_dir.mkdir(parents=True, exist_ok=True)
    for name, args in FLIGHTS.items():
        if only and name not in only:
            continue
        target = out_dir / f"{name}.json"
        with tempfile.TemporaryDirectory(prefix="compare-flights-") as tmp:
            tmp_json = Path(tmp) / "out.json"
            cmd = [python, "-m", "companion", *args, "--json", str(tmp_json)]
            print("$", " ".join(cmd), flush=True)
            done = subprocess.run(cmd, cwd=repo, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                  text=True)
            if done.returncode != 0 or not tmp_json.exists():
                sys.stderr.write(done.stdout + done.stderr)
                print(f"{name}: companion exited {done.returncode}", file=sys.stderr)
                return 2
            target.write_text(tmp_json.read_text())
        print(f"  -> {target}", flush=True)
    return 0


def differences(a, b, path: str = "") -> list[str]:
    if path in RUN_DEPENDENT:
        return []
    if isinstance(a, dict) and isinstance(b, dict):
        out = []
        for key in sorted(set(a) | set(b), key=str):
            sub = f"{path}.{key}" if path else str(key)
            if sub in RUN_DEPENDENT:
                continue
            if key not in a:
                out.append(f"{sub}: missing in A")
            elif key not in b:
                out.append(f"{sub}: missing in B")
            else:
                out.extend(differences(a[key], b[key], sub))
        return out
    if isinstance(a, list) and isinstance(b, list):
        out = []
        if len(a) != len(b):
            out.append(f"{path}: length {len(a)} != {len(b)}")
        for i, (x, y) in enumerate(zip(a, b)):
            out.extend(differences(x, y, f"{path}.{i}" if path else str(i)))
        return out
    same = a == b or (isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b))
    return [] if same and type(a) is type(b) else [f"{path}: {a!r} != {b!r}"]


def compare(dir_a: Path, dir_b: Path) -> int:
    report = []
    for name in FLIGHTS:
        fa, fb = dir_a / f"{name}.json", dir_b / f"{name}.json"
        if not fa.exists() or not fb.exists():
            report.append(f"{name}.json: missing in {'A' if not fa.exists() else 'B'}")
            continue
        report.extend(f"{name}.json: {d}" for d in
                      differences(json.loads(fa.read_text()), json.loads(fb.read_text())))
    if not report:
        print("equal")
        return 0
    print("\n".join(report))
    print(f"{len(report)} differing field(s)")
    return 1


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)
    p = sub.add_parser("save", help="fly the seeded sets and write DIR/<set>.json")
    p.add_argument("dir", type=Path)
    p.add_argument("--python", default=sys.executable,
                   help="the interpreter with companion installed (default: this one)")
    p.add_argument("--repo", type=Path, default=Path(__file__).resolve().parent.parent,
                   help="the checkout whose config/ to fly (default: this script's)")
    p.add_argument("--only", nargs="+", choices=sorted(FLIGHTS), help="save only these sets")
    c = sub.add_parser("compare", help="say 'equal' or list the differing fields")
    c.add_argument("dir_a", type=Path)
    c.add_argument("dir_b", type=Path)
    args = parser.parse_args(argv)
    if args.command == "save":
        return save(args.dir.resolve(), args.python, args.repo.resolve(), args.only)
    return compare(args.dir_a, args.dir_b)


if __name__ == "__main__":
    sys.exit(main())
