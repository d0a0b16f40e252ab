"""Figures of the service's 3D flights on the stub (issue 27): the flights of
tests/e2e/test_vertical_flights.py, each with avoidance.vertical on and off, printed as a table.

    python -m benchmarks.vertical_stub [--kinds lowwall,side_by_side,bridge,ceiling,widewall,lowdeck]
                                       [--seeds 1] [--vertical on,off]

Per flight: arrived, arrival time (vehicle s), horizontal path from take-off to arrival, climb
(sum of rises after the take-off), lowest and highest altitude after it, altitude at arrival,
least 3D clearance to an obstacle's axis (capped at its top and base).
"""
from __future__ import annotations

import argparse
import math
import tempfile
from pathlib import Path

from tests.e2e import test_vertical_flights as flights

KINDS = {
    "lowwall": (lambda: flights.world(), {}),
    "side_by_side": (lambda: flights.world(
        flights.posts(100.0, -30.0, -2.0, 1, height_m=3.0)
        + flights.posts(100.0, 2.0, 30.0, 20, height_m=40.0)), {}),
    "bridge": (lambda: flights.world(flights.posts(100.0, -30.0, 30.0, 1, height_m=16.0,
                                                   base_m=14.0)), {}),
    "ceiling": (lambda: flights.world(flights.posts(100.0, -30.0, 30.0, 1, height_m=20.0)),
                {"max_altitude_m": 15.0}),
    # issue 46: a 9 m wall 160 m wide (config/scenarios/widewall.yaml), a deck 6-9 m, 160 m across
    "widewall": (lambda: flights.world(flights.posts(100.0, -80.0, 80.0, 1, height_m=9.0)), {}),
    "lowdeck": (lambda: flights.world(flights.posts(100.0, -80.0, 80.0, 1, height_m=9.0,
                                                    base_m=6.0)), {}),
}


def figures(flying: list[dict], result: dict) -> dict:
    path = sum(math.hypot(b["north_m"] - a["north_m"], b["east_m"] - a["east_m"])
               for a, b in zip(flying, flying[1:]))
    climb = sum(max(0.0, b["up_m"] - a["up_m"]) for a, b in zip(flying, flying[1:])
                if a["up_m"] > 9.5)              # after the take-off
    up = [r["up_m"] for r in flying]
    first = next((i for i, u in enumerate(up) if u > 9.5), 0)
    return {"arrived": bool(result.get("arrived")), "t_s": result.get("arrival_t_s"),
            "min_up_m": min(up[first:]), 
            "path_m": path, "climb_m": climb, "max_up_m": max(r["up_m"] for r in flying),
            "final_up_m": flying[-1]["up_m"], "clearance_m": flights.min_clearance_m(flying)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--kinds", default="lowwall,side_by_side,bridge,ceiling")
    parser.add_argument("--seeds", default="1", help="the stub's seeds, comma-separated")
    parser.add_argument("--vertical", default="on,off")
    args = parser.parse_args()
    print(f"{'world':13s} {'seed':>4s} {'3D':3s} {'arr':4s} {'t_s':>6s} {'path_m':>7s} {'climb_m':>7s} "
          f"{'min_up':>6s} {'max_up':>6s} {'final':>6s} {'clear_m':>7s}")
    for kind in args.kinds.split(","):
        make, avoidance = KINDS[kind]
        for seed in map(int, args.seeds.split(",")):
            for vertical in (v == "on" for v in args.vertical.split(",")):
                row(kind, seed, vertical, make, avoidance)


def row(kind: str, seed: int, vertical: bool, make, avoidance: dict) -> None:
    on = "on" if vertical else "off"
    with tempfile.TemporaryDirectory() as tmp:
        try:
            flying, _, result = flights.fly(Path(tmp), make(), seed=seed,
                                            **{**avoidance, "vertical": vertical})
        except AssertionError as exc:       # no arrival, or a setpoint out of its bounds
            print(f"{kind:13s} {seed:4d} {on:3s} failed: {str(exc)[:120]}")
            return
    f = figures(flying, result)
    print(f"{kind:13s} {seed:4d} {on:3s} {str(f['arrived']):4s} {f['t_s']:6.1f} "
          f"{f['path_m']:7.1f} {f['climb_m']:7.1f} {f['min_up_m']:6.1f} {f['max_up_m']:6.1f} "
          f"{f['final_up_m']:6.1f} {f['clearance_m']:7.2f}", flush=True)


if __name__ == "__main__":
    main()
