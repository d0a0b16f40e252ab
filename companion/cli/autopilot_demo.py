"""``companion demo --autopilot PATH``: the demo's options and output for ArduPilot SITL."""
from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

from companion.cli.run import run_task_tree
from companion.config.paths import resolve_config
from companion.errors import CompanionError
from companion.tools.report import print_summary, write_json

DEFAULTS_ENV = "ARDUCOPTER_DEFAULTS"
DEFAULT_TAKEOFF_ALT_M = 10.0


def add_autopilot_arguments(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group(
        "ArduPilot SITL (instead of the stub)",
        "The real ArduCopter SITL binary as the vehicle, the stub's camera beside it "
        "(sitl-stub --camera-only) and the service up from boot: GUIDED, arm, NAV_TAKEOFF, then "
        "the service flies. Truth: SITL's SIMSTATE.")
    g.add_argument("--autopilot", metavar="PATH", help="the ArduCopter SITL binary")
    g.add_argument("--autopilot-defaults", metavar="PATH",
                   help=f"its defaults (.parm) file (default ${DEFAULTS_ENV})")
    g.add_argument("--takeoff-alt", type=float, default=DEFAULT_TAKEOFF_ALT_M, metavar="M",
                   help=f"NAV_TAKEOFF altitude above home (default {DEFAULT_TAKEOFF_ALT_M:g} m)")
    g.add_argument("--service-start", choices=("boot", "airborne"), default="boot",
                   help="boot: the service runs from SITL's boot (default, the workflow of "
                        "docs/real-vehicle.md); airborne: it starts once the takeoff altitude is "
                        "reached (a check of the harness without the takeoff phase)")
    g.add_argument("--unshaped", action="store_true",
                   help="plan as on the stub: no ArduCopter velocity shaping (jerk 5 m/s^3) "
                        "and no yaw lead (0.5 s), which --autopilot otherwise "
                        "uses where the --config leaves commanding.max_jerk_mps3 / yaw_lead_s null")


def setup_from(args: argparse.Namespace):
    from companion.tools.autopilot_demo import AutopilotSetup
    defaults = args.autopilot_defaults or os.environ.get(DEFAULTS_ENV)
    if not defaults:
        raise CompanionError(f"--autopilot needs --autopilot-defaults PATH (or ${DEFAULTS_ENV}): "
                             "the .parm file, e.g. ArduPilot's "
                             "Tools/autotest/default_params/copter.parm")
    if args.drop_rate or args.signing_key:
        raise CompanionError("--drop-rate and --signing-key are the stub's; not with --autopilot")
    if not 1.0 <= args.takeoff_alt <= 100.0:
        raise CompanionError(f"--takeoff-alt: expected 1 to 100 m, got {args.takeoff_alt:g}")
    return AutopilotSetup(Path(args.autopilot).resolve(), Path(defaults).resolve(),
                          args.takeoff_alt, args.service_start,
                          resolve_config(args.config), shaped=not args.unshaped)


def run_autopilot(args: argparse.Namespace, scenario_path: Path, scenario) -> int:
    from companion.tools.autopilot_demo import AutopilotFiles, run_autopilot_demo
    from companion.tools.demo_scoring import demo_result, score
    setup = setup_from(args)
    started = time.monotonic()
    with tempfile.TemporaryDirectory(prefix="companion-demo-ardupilot-") as tmp:
        workdir = Path(args.keep or tmp).resolve()
        workdir.mkdir(parents=True, exist_ok=True)
        tlog = Path(args.tlog).resolve() if args.tlog else workdir / "companion.tlog"
        files = AutopilotFiles(workdir, tlog)
        report, _, truth, checks = run_task_tree(run_autopilot_demo(
                scenario_path, scenario, files, args.speedup, args.seed, setup))
        summary, arrays = score(report, truth, scenario, args.seed)
    wall_s = time.monotonic() - started
    result = demo_result(summary, arrays.pop("nees"), scenario)
    result["aggregate"].update(wall_time_s=round(wall_s, 2), speedup=args.speedup,
                               autopilot=str(setup.binary))
    result["flight"] = checks
    if args.json:
        write_json(args.json, result)
    if args.plot:
        _plot(args.plot, arrays, scenario, f"{scenario.name}: ArduCopter SITL, seed {args.seed}")
    print_summary(result, sys.stdout)
    print_flight(summary, checks, wall_s, args.speedup)
    if args.tlog:
        print(f"tlog: {args.tlog}")
    return 0 if summary["reached_goal"] else 1


def print_flight(summary: dict, checks: dict, wall_s: float, speedup: float) -> None:
    def fmt(value, unit=""):
        return "n/a" if value is None else f"{value:.1f}{unit}"
    print(f"time to goal {summary['time_s']:.1f} s from arming (autopilot time), {wall_s:.1f} s "
          f"wall (speedup {speedup:g}); urgent events {summary['urgent_events']}")
    print(f"takeoff to {checks['takeoff_alt_m']:g} m (service from {checks['service_start']}): "
          f"armed at {fmt(checks['armed_t_s'], ' s')}, first setpoint at "
          f"{fmt(checks['first_setpoint_t_s'], ' s')} at "
          f"{fmt(checks['first_setpoint_alt_m'], ' m')} ({checks['first_setpoint_landed_state']}); setpoints {checks['setpoints']}, while "
          f"landed {checks['setpoints_while_landed']} (service's own view "
          f"{checks['setpoints_while_landed_by_service_tlog']}); max altitude "
          f"{fmt(checks['max_alt_m'], ' m')}")
    north, east = checks["ekf_origin_ne_m"]
    print(f"truth: {checks['truth']}; EKF origin at north {north:.2f} m, east {east:.2f} m of the "
          "scenario frame")


def _plot(path: str, arrays: dict, scenario, title: str) -> None:
    import numpy as np

    from companion.sim.plot import plot_paths
    goal, start = scenario.world.goal, scenario.world.start
    plot_paths(path, **arrays, safety_distance_m=scenario.safety_distance_m,
               goal_ne=np.array([goal.north_m, goal.east_m]), title=title,
               start_ne=np.array([start.north_m, start.east_m]))
