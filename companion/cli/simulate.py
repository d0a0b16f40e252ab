"""``companion simulate``: seeded Monte Carlo runs of a scenario, in-process."""
from __future__ import annotations

import argparse
import sys

from companion.errors import CompanionError
from companion.config.scenario import load_scenario
from companion.sim.forest_worlds import FOREST_SPECS, world_figures
from companion.sim.worlds import WORLD_KINDS, random_world
from companion.sim.batch import available_cores, fly_runs
from companion.sim.depth_camera import depth_sensor_record
from companion.tools.report import print_summary, write_json
from companion.sim.simulation import aggregate, with_position_fusion, with_speed, with_vertical

DEFAULT_SCENARIO = "config/scenarios/paper.yaml"


def add_parser(sub) -> None:
    p = sub.add_parser("simulate", help="fly a scenario in-process (no MAVLink), N seeded runs",
                       description="Closed loop in-process: truth world, noisy sensors, EKF-SLAM, "
                                   "guidance on the estimate. Run i uses seed S+i.")
    p.add_argument("--scenario", help="scenario YAML (see config/scenarios/); with --random-worlds, "
                                      "the base whose vehicle, sensor and guidance are kept "
                                      f"(default {DEFAULT_SCENARIO})")
    p.add_argument("--random-worlds", choices=sorted(WORLD_KINDS), metavar="KIND",
                   help="fly seeded random worlds instead: run i flies world S+i "
                        f"({', '.join(sorted(WORLD_KINDS))})")
    p.add_argument("--runs", type=_positive_int, default=1, help="number of runs (default 1)")
    p.add_argument("--seed", type=int, default=0, help="seed of the first run (default 0)")
    p.add_argument("--strategy", choices=("cone", "union", "apf"), default=None,
                   help="guidance strategy (default: the scenario's)")
    p.add_argument("--position-fusion", choices=("auto", "on", "off"), default=None,
                   help="fuse the autopilot's position or not (default: the scenario's estimator)")
    p.add_argument("--speed-mps", type=_positive_float, default=None,
                   help="fly at this cruise speed instead of the scenario's vehicle.speed_mps "
                        "(random worlds give the mission time to match)")
    p.add_argument("--vertical", choices=("on", "off"), default=None,
                   help="avoidance in 3D or the 2D law, whatever the scenario's "
                        "avoidance.vertical says (default: the scenario's; the random worlds of "
                        "heights, lowwalls and mixed, turn it on unless the base says false)")
    p.add_argument("--jobs", type=_positive_int, default=None,
                   help="processes flying runs at once (default: the CPUs this process may use, "
                        f"here {available_cores()}); the results do not depend on it")
    p.add_argument("--json", metavar="PATH", help="write {aggregate, runs} as JSON")
    p.add_argument("--plot", metavar="PATH", help="draw the first run as a PNG (paper's Figure 4)")
    p.set_defaults(handler=run)


def _positive_int(text: str) -> int:
    value = int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {text}")
    return value


def _positive_float(text: str) -> float:
    value = float(text)
    if not value > 0.0:
        raise argparse.ArgumentTypeError(f"expected a positive number, got {text}")
    return value


def run(args: argparse.Namespace) -> int:
    if args.scenario is None and args.random_worlds is None:
        raise CompanionError("simulate: give --scenario PATH or --random-worlds KIND")
    scenario = with_position_fusion(load_scenario(args.scenario or DEFAULT_SCENARIO),
                                    args.position_fusion)
    scenario = with_speed(scenario, args.speed_mps)
    scenario = with_vertical(scenario, None if args.vertical is None else args.vertical == "on")
    strategy = args.strategy or scenario.avoidance.strategy
    seeds = range(args.seed, args.seed + args.runs)
    worlds = [random_world(scenario, args.random_worlds, seed) if args.random_worlds else scenario
              for seed in seeds]
    from tqdm import tqdm
    with tqdm(total=args.runs, desc="simulate", unit="run",
              disable=args.runs < 2 or not sys.stderr.isatty()) as progress:
        outcomes = fly_runs(worlds, seeds, strategy, args.jobs or available_cores(),
                            on_done=progress.update)
    agg = aggregate(outcomes, scenario.safety_distance_m)
    agg["strategy"] = strategy
    if scenario.avoidance.safety_distance_rest_m is not None:    # d set by the cruise speed
        agg["safety_distance_m"] = scenario.safety_distance_m
    agg["scenario"] = f"random-{args.random_worlds}" if args.random_worlds else scenario.name
    if scenario.sensor.form == "depth":            # the rendered camera: form, intrinsics, mounts
        agg["sensor"] = depth_sensor_record(scenario.sensor)
    if args.random_worlds in FOREST_SPECS:         # the drawn forests' density and spacing
        agg["forest"] = world_figures(worlds, args.random_worlds)
    report = {"aggregate": agg, "runs": [o.summary for o in outcomes]}
    if args.json:
        write_json(args.json, report)
    if args.plot:
        from companion.sim.plot import plot_run
        first = random_world(scenario, args.random_worlds, args.seed) if args.random_worlds else scenario
        plot_run(args.plot, first, outcomes[0], title=f"{first.name}: {strategy}, seed {args.seed}")
    print_summary(report, sys.stdout)
    return 0
