"""Wide barriers across the leg (issue 46, "climbing needs time"): walls and bridge decks of posts
4 m apart across the paper's leg at 100 m, flown by `companion simulate`'s closed loop with
avoidance.vertical on and off, on config/scenarios/lowwall.yaml's vehicle, camera and limits
(cruise 10 m, d 10 m, altitude limit 30 m).

    python -m benchmarks.wide_barriers [--worlds wall9x160,bridge6-9x161,...] [--seeds 0,1,2]
                                       [--vertical on,off] [--base config/scenarios/lowwall.yaml]

A world is ``wall<top>x<width>`` (a wall of that height and width, centred on the line),
``bridge<base>-<top>x<width>`` (a deck), ``block<top>x<width>`` (a wall as a block), or
``copter:`` before any of them (config/scenarios/copter.yaml's multicopter with lowwall.yaml's
vertical keys). Per flight: arrived, time, horizontal and 3D path, highest and lowest altitude,
least 3D clearance to a post's axis, and the plan changes: how often the chosen plan went from
the cruise altitude to above or below it and back (``flips``), and the longest span of time in
which those changes kept coming less than 5 s apart (``dither_s``).
"""
from __future__ import annotations

import argparse
import dataclasses
import math
import re
from pathlib import Path

import numpy as np

from companion.config.scenario import load_scenario
from companion.config.world import Obstacle
from companion.sim.simulation import run_once, with_vertical

REPO = Path(__file__).resolve().parents[1]
SPACING_M = 4.0
WALL_NORTH_M = 100.0
DITHER_GAP_S = 5.0
DEFAULT_WORLDS = ("wall9x160,wall9x60,wall6x160,wall12x160,wall15x160,wall9x240,bridge6-9x161,"
                  "block40x20,block25x20,wall3x160")


def posts(width_m: float, top_m: float, base_m: float = 0.0) -> tuple[Obstacle, ...]:
    """A row of posts across the line at WALL_NORTH_M, ``width_m`` wide, centred."""
    n = max(1, int(round(width_m / SPACING_M)))
    east = np.linspace(-width_m / 2.0, width_m / 2.0, n + 1)
    return tuple(Obstacle(id=k + 1, north_m=WALL_NORTH_M, east_m=float(e), radius_m=1.0,
                          height_m=top_m, base_m=base_m) for k, e in enumerate(east))


def scenario_for(name: str, base_path: Path):
    """The scenario of a world name (see the module's docstring)."""
    copter = name.startswith("copter:")
    shape = name.split(":", 1)[-1]
    m = re.fullmatch(r"(wall|block)(\d+(?:\.\d+)?)x(\d+(?:\.\d+)?)", shape)
    b = re.fullmatch(r"bridge(\d+(?:\.\d+)?)-(\d+(?:\.\d+)?)x(\d+(?:\.\d+)?)", shape)
    if m:
        obstacles = posts(float(m.group(3)), float(m.group(2)))
    elif b:
        obstacles = posts(float(b.group(3)), float(b.group(2)), float(b.group(1)))
    else:
        raise SystemExit(f"unknown world {name!r}")
    base = load_scenario(base_path)
    if copter:
        copter_scn = load_scenario(REPO / "config" / "scenarios" / "copter.yaml")
        base = dataclasses.replace(copter_scn, avoidance=dataclasses.replace(
            copter_scn.avoidance, vertical=True, max_altitude_m=base.avoidance.max_altitude_m,
            min_altitude_m=base.avoidance.min_altitude_m), world=base.world)
    world = dataclasses.replace(base.world, obstacles=obstacles)
    mission = dataclasses.replace(base.mission, max_time_s=200.0)
    avoidance = dataclasses.replace(base.avoidance, mission_time_s=200.0)
    return dataclasses.replace(base, name=name, world=world, mission=mission, avoidance=avoidance)


def plan_changes(choices: list, cruise_m: float) -> tuple[int, float]:
    """(flips, dither_s) of the decisions' (t_s, plan altitude) (see the module's docstring)."""
    flips = []
    last = None
    for t_s, altitude_m in choices:
        level = abs(altitude_m - cruise_m) < 1.0
        if last is not None and level != last:
            flips.append(t_s)
        last = level
    longest, start = 0.0, None
    for a, b in zip(flips, flips[1:]):
        start = a if start is None else start
        if b - a < DITHER_GAP_S:
            longest = max(longest, b - start)
        else:
            start = None
    return len(flips), longest


def fly(name: str, seed: int, vertical: bool, base_path: Path) -> dict:
    scenario = with_vertical(scenario_for(name, base_path), vertical)
    choices, alts = [], []

    def sink(t_s, choice, truth):
        alts.append(truth.altitude_m)
        if choice is not None:
            choices.append((t_s, choice.plan.altitude_m))
    outcome = run_once(scenario, seed, plan_sink=sink)
    s = outcome.summary
    flips, dither = plan_changes(choices, scenario.world.start.alt_m)
    v = s.get("vertical") or {}
    return {"arrived": s["reached_goal"], "t_s": s["time_s"], "path_m": s["path_length_m"],
            "path_3d_m": v.get("path_3d_m", s["path_length_m"]),
            "max_up_m": v.get("max_altitude_m", math.nan),
            "min_up_m": min(alts) if alts else math.nan,
            "clear_m": s["min_clearance_m"], "collided": s["collided"], "flips": flips,
            "dither_s": dither}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--worlds", default=DEFAULT_WORLDS)
    parser.add_argument("--seeds", default="0")
    parser.add_argument("--vertical", default="on,off")
    parser.add_argument("--base", default=str(REPO / "config" / "scenarios" / "lowwall.yaml"))
    args = parser.parse_args()
    print(f"{'world':22s} {'seed':>4s} {'3D':3s} {'arr':5s} {'t_s':>6s} {'path_m':>7s} "
          f"{'path3d':>7s} {'max_up':>6s} {'min_up':>6s} {'clear_m':>7s} {'flips':>5s} "
          f"{'dither':>6s}")
    for name in args.worlds.split(","):
        for seed in map(int, args.seeds.split(",")):
            for on in (v == "on" for v in args.vertical.split(",")):
                f = fly(name, seed, on, Path(args.base))
                print(f"{name:22s} {seed:4d} {'on' if on else 'off':3s} "
                      f"{str(f['arrived']) + ('!' if f['collided'] else ''):5s} {f['t_s']:6.1f} "
                      f"{f['path_m']:7.1f} {f['path_3d_m']:7.1f} {f['max_up_m']:6.1f} "
                      f"{f['min_up_m']:6.1f} {f['clear_m']:7.2f} {f['flips']:5d} "
                      f"{f['dither_s']:6.1f}", flush=True)


if __name__ == "__main__":
    main()
