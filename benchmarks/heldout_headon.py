"""Held-out head-on worlds for the multicopter (issue 33's second check): worlds the project's
generators (companion/sim/worlds.py, traffic_speeds.py) do not make, flown through
``companion simulate --scenario FILE`` with the camera's obstacle ids and without them.

    python benchmarks/heldout_headon.py [--worlds 100] [--seed 0] [--base config/scenarios/copter.yaml]
        [--ids both|on|off] [--out /tmp/heldout-headon] [--python .venv/bin/python]
        [--leg-m 150 220] [--movers 1 3]

World i is drawn from its own random stream (numpy default_rng([seed + i, 0x4E1D0]), shared
with nothing in companion/) and written as a scenario file: the base's vehicle, noise, sensor,
estimator and avoidance, with

- a course in any direction (the generators all fly north), 150 to 220 m long, from (0, 0)
  (``--leg-m``);
- 1 to 3 movers (``--movers``) at 3 to 5 m/s each, heading within 0.15 rad of straight at the
  vehicle, placed to pass 0 to 8 m to either side of the course at 25 to 85 % of the leg, 4 s
  early to 2 s late against a vehicle flying straight at cruise speed (so their start distances
  vary: 60 to 400 m); radius 0.5 to 2 m;
- 0 to 3 static posts (radius 1 to 2 m) 4 to 25 m off the course, at least 25 m apart.

Each world is flown once, with noise seed 7000 + seed + i, by the CLI (a subprocess: what a user
runs), with ``sensor.report_ids`` true and false (the same world, the same noise seed). Success is
simulate's: the goal reached with the closest approach to an obstacle centre >= 0.95 d. Printed:
success / collisions / clearance p5 (min) per mode, and every failure (world, clearance,
collided, the file to fly again; benchmarks/mover_timeline.py --scenario FILE --seed S shows the
nearest mover's last seconds).
"""
from __future__ import annotations

import argparse
import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import yaml

STREAM = 0x4E1D0
NOISE_SEED = 7000
CRUISE_MPS = 5.0
LEG_M = (150.0, 220.0)          # the defaults: the worlds of docs/copter-headon-failures.md
MOVERS = (1, 3)


def draw_world(seed: int, safety_distance_m: float, cruise_mps: float = CRUISE_MPS,
               leg_m: tuple[float, float] = LEG_M, movers: tuple[int, int] = MOVERS) -> dict:
    """The world section (a dict for the scenario YAML) and the mission time of world ``seed``:
    a leg of ``leg_m`` (low, high) metres, ``movers`` (fewest, most) movers."""
    rng = np.random.default_rng([seed, STREAM])
    course = rng.uniform(-math.pi, math.pi)
    leg = rng.uniform(*leg_m)
    along = np.array([math.cos(course), math.sin(course)])
    left = np.array([-along[1], along[0]])
    goal = leg * along
    d = safety_distance_m

    def clear_of_ends(point: np.ndarray, margin_m: float) -> bool:
        return np.hypot(*point) > margin_m and np.hypot(*(point - goal)) > margin_m

    obstacles = []
    posts: list[np.ndarray] = []
    for _ in range(int(rng.integers(0, 4))):
        for _ in range(20):
            s, off = rng.uniform(30.0, leg - 30.0), rng.choice([-1.0, 1.0]) * rng.uniform(4.0, 25.0)
            radius = rng.uniform(1.0, 2.0)
            point = s * along + off * left
            if clear_of_ends(point, 2.0 * d + radius) \
                    and all(np.hypot(*(point - p)) >= 25.0 for p in posts):
                posts.append(point)
                obstacles.append(dict(id=len(obstacles) + 1, north_m=round(float(point[0]), 3),
                                      east_m=round(float(point[1]), 3),
                                      radius_m=round(float(radius), 3)))
                break
    placed = 0
    for _ in range(int(rng.integers(movers[0], movers[1] + 1))):
        for _ in range(20):
            speed = rng.uniform(3.0, 5.0)
            s = rng.uniform(0.25, 0.85) * leg
            off = rng.choice([-1.0, 1.0]) * rng.uniform(0.0, 8.0)
            heading = course + math.pi + rng.uniform(-0.15, 0.15)
            meet_t = s / cruise_mps + rng.uniform(-4.0, 2.0)
            vel = speed * np.array([math.cos(heading), math.sin(heading)])
            start = s * along + off * left - vel * meet_t
            radius = rng.uniform(0.5, 2.0)
            if clear_of_ends(start, 2.0 * d + radius):
                obstacles.append(dict(id=len(obstacles) + 1, north_m=round(float(start[0]), 3),
                                      east_m=round(float(start[1]), 3),
                                      radius_m=round(float(radius), 3),
                                      vel_north_mps=round(float(vel[0]), 4),
                                      vel_east_mps=round(float(vel[1]), 4)))
                placed += 1
                break
    assert placed >= 1, seed
    max_time_s = round(max(120.0, 3.0 * leg / cruise_mps), 1)
    return dict(start=dict(north_m=0.0, east_m=0.0, yaw_deg=round(math.degrees(course), 4)),
                goal=dict(north_m=round(float(goal[0]), 3), east_m=round(float(goal[1]), 3)),
                obstacles=obstacles, max_time_s=max_time_s)


def write_scenario(base: dict, drawn: dict, report_ids: bool, name: str, path: Path) -> None:
    text = json.loads(json.dumps(base))              # a deep copy of the base's YAML
    world = text["world"]
    world["start"] = drawn["start"]
    world["goal"] = dict(drawn["goal"], radius_m=world["goal"]["radius_m"])
    world["obstacles"] = drawn["obstacles"]
    text["name"] = name
    text["sensor"]["report_ids"] = report_ids
    text["mission"]["max_time_s"] = drawn["max_time_s"]
    text["avoidance"]["mission_time_s"] = drawn["max_time_s"]
    path.write_text(yaml.safe_dump(text, sort_keys=False))


def fly(python: str, path: Path, seed: int) -> dict:
    out = path.with_suffix(".json")
    subprocess.run([python, "-m", "companion", "simulate", "--scenario", str(path), "--runs", "1",
                    "--seed", str(seed), "--json", str(out)], check=True,
                   stdout=subprocess.DEVNULL)
    return json.loads(out.read_text())["runs"][0]


def figures(runs: list[dict], safety_distance_m: float) -> dict:
    clear = np.array([r["min_clearance_m"] if r["min_clearance_m"] is not None else math.inf
                      for r in runs])
    success = [r["reached_goal"] and c >= 0.95 * safety_distance_m for r, c in zip(runs, clear)]
    finite = clear[np.isfinite(clear)]
    return dict(runs=len(runs), success=float(np.mean(success)),
                collisions=int(sum(r["collided"] for r in runs)),
                p5=float(np.percentile(finite, 5)) if finite.size else None,
                min=float(finite.min()) if finite.size else None,
                failures=[(r["world"], round(float(c), 2), bool(r["collided"]),
                           bool(r["reached_goal"]))
                          for r, c, ok in zip(runs, clear, success) if not ok])


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--worlds", type=int, default=100)
    p.add_argument("--seed", type=int, default=0, help="world i is drawn with seed + i")
    p.add_argument("--base", default="config/scenarios/copter.yaml")
    p.add_argument("--ids", choices=("both", "on", "off"), default="both")
    p.add_argument("--out", default="/tmp/heldout-headon")
    p.add_argument("--python", default=sys.executable)
    p.add_argument("--json", help="write the figures and every run as JSON")
    p.add_argument("--leg-m", type=float, nargs=2, default=LEG_M, metavar=("LOW", "HIGH"),
                   help="the leg's length is drawn from this range (m)")
    p.add_argument("--movers", type=int, nargs=2, default=MOVERS, metavar=("FEWEST", "MOST"),
                   help="how many movers a world has, drawn from this range (inclusive)")
    args = p.parse_args()
    if not 0.0 < args.leg_m[0] <= args.leg_m[1]:
        p.error(f"--leg-m: want 0 < LOW <= HIGH, got {args.leg_m[0]:g} {args.leg_m[1]:g}")
    if not 1 <= args.movers[0] <= args.movers[1]:
        p.error(f"--movers: want 1 <= FEWEST <= MOST, got {args.movers[0]} {args.movers[1]}")
    base = yaml.safe_load(Path(args.base).read_text())
    d = float(base["avoidance"]["safety_distance_m"])
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    modes = {"both": (True, False), "on": (True,), "off": (False,)}[args.ids]
    results = {}
    for ids in modes:
        label = "ids" if ids else "no-ids"
        runs = []
        for i in range(args.worlds):
            world = args.seed + i
            drawn = draw_world(world, d, float(base["vehicle"]["speed_mps"]),
                               tuple(args.leg_m), tuple(args.movers))
            path = out / f"heldout-{label}-{world}.yaml"
            write_scenario(base, drawn, ids, f"heldout-headon-{label}-{world}", path)
            run = fly(args.python, path, NOISE_SEED + world)
            run["world"] = world
            runs.append(run)
        results[label] = dict(figures(runs, d), all=runs)
        f = results[label]
        print(f"{label:6s} worlds {args.seed}-{args.seed + args.worlds - 1}: success "
              f"{f['success']:.2f}, collisions {f['collisions']}, clearance p5 {f['p5']:.2f} m "
              f"(min {f['min']:.2f} m)", flush=True)
        for world, clear, collided, reached in f["failures"]:
            print(f"    world {world}: {clear:.2f} m{' COLLISION' if collided else ''}"
                  f"{'' if reached else ', goal not reached'}  ({out}/heldout-{label}-{world}.yaml,"
                  f" --seed {NOISE_SEED + world})", flush=True)
    if args.json:
        Path(args.json).write_text(json.dumps(results, indent=1, default=float))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
