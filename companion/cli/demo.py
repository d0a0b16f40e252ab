"""``companion demo``: fly a scenario with the stub, the companion daemon and a ground station."""
from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

from companion.cli.autopilot_demo import add_autopilot_arguments, run_autopilot
from companion.cli.run import run_task_tree
from companion.config.scenario import load_scenario
from companion.config.service import load_user_config
from companion.errors import CompanionError
from companion.config.paths import resolve_config
from companion.tools.report import print_summary, write_json

DEFAULT_SCENARIO = "config/scenarios/paper.yaml"
DEFAULT_BASE_CONFIG = "config/companion.yaml"


def add_parser(sub) -> None:
    p = sub.add_parser(
        "demo", help="fly a scenario end to end over MAVLink: sitl-stub + companion run + a GCS",
        description="Starts sitl-stub and `companion run` as processes on loopback, sets GUIDED "
                    "and arms as a ground station would, waits for the companion to report "
                    "arrival, and scores the flight like `companion simulate`.")
    p.add_argument("--scenario", default=DEFAULT_SCENARIO,
                   help=f"scenario YAML (default {DEFAULT_SCENARIO})")
    p.add_argument("--config", default=DEFAULT_BASE_CONFIG, metavar="PATH",
                   help="the service's settings the scenario's are laid over (its estimator, "
                        "avoidance, goal and vehicle limits come from the scenario; links, "
                        "streams, failsafes and the rest from here; default "
                        f"{DEFAULT_BASE_CONFIG})")
    p.add_argument("--lockstep", action=argparse.BooleanOptionalAction, default=True,
                   help="stub and companion in lock-step: the same flight whatever the machine's "
                        "load, as fast as the two processes go (default); --no-lockstep: the "
                        "stub runs on the wall clock at --speedup")
    p.add_argument("--lockstep-overlap", action="store_true",
                   help="lock-step with the stub one step ahead: both processes compute at once "
                        "(faster on two free cores), the companion's setpoints take effect one "
                        "control period later; still the same flight whatever the load")
    p.add_argument("--speedup", type=float, default=20.0,
                   help="simulated seconds per wall second without lock-step, and of the "
                        "stub's free-run fallback in lock-step (default 20)")
    p.add_argument("--seed", type=int, default=0, help="the stub's noise seed (default 0)")
    p.add_argument("--drop-rate", type=float, default=0.0,
                   help="fraction of datagrams (UDP, companion <-> stub) and TCP messages (ground "
                        "station <-> stub) the stub drops, both directions, seeded by --seed "
                        "(default 0)")
    p.add_argument("--signing-key", metavar="FILE",
                   help="MAVLink 2 signing for everyone: FILE holds the key as 64 hex chars")
    p.add_argument("--json", metavar="PATH", help="write {aggregate, runs} as JSON")
    p.add_argument("--plot", metavar="PATH", help="draw the flight as a PNG (paper's Figure 4)")
    p.add_argument("--tlog", metavar="PATH", help="the companion records its traffic here")
    p.add_argument("--depth-record", metavar="FILE.db3",
                   help="a depth scenario: record the stub's depth stream beside the flight to "
                        "this RealSense bag (companion depth-record; the extra 'depth'), for "
                        "companion replay TLOG --depth realsense-bag:FILE.db3")
    p.add_argument("--keep", metavar="DIR", help="keep the work files (truth log, report, "
                   "children's stderr) in DIR instead of a temporary directory")
    p.add_argument("--view-feed", metavar="HOST:PORT",
                   help="the companion sends its live state to `companion view` there; with "
                        "--keep DIR the view can draw the truth too (DIR/truth.jsonl)")
    p.add_argument("--stub-autopilot", choices=("ardupilot", "px4"), default="ardupilot",
                   help="the stub's face: ArduCopter (default) or PX4 (sitl-stub --autopilot "
                        "px4: the service runs from boot, the ground station arms, takes off to "
                        "an AMSL altitude, and OFFBOARD is entered as --px4-offboard says)")
    p.add_argument("--px4-offboard", choices=("operator", "companion"), default=None,
                   help="PX4: who switches to OFFBOARD: the ground station (operator) or the "
                        "service (companion); default: the --config's px4.offboard")
    p.add_argument("--px4", metavar="DIR",
                   help="fly PX4's own SITL with its SIH simulator instead of the stub: DIR is a "
                        "PX4 SITL build (bin/px4 and etc/, built outside this repository; "
                        "$PX4_SITL_DIR in the tests), the stub's camera beside it")
    p.add_argument("--px4-kill-at-north", type=float, metavar="M",
                   help="with --px4: SIGKILL the service once the vehicle passes north M m, let "
                        "PX4's offboard-loss fallback hold it, start a new service")
    add_autopilot_arguments(p)
    p.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    from companion.tools.demo import DemoFiles, run_demo
    from companion.tools.px4_stub_demo import px4_ground_station
    from companion.tools.demo_scoring import demo_result, flight_timing, score
    if args.speedup <= 0:
        raise CompanionError(f"--speedup: expected a positive number, got {args.speedup}")
    if not 0.0 <= args.drop_rate < 1.0:
        raise CompanionError(f"--drop-rate: expected a fraction in [0, 1), got {args.drop_rate}")
    scenario_path = resolve_config(args.scenario)
    scenario = load_scenario(scenario_path)
    base_config = resolve_config(args.config)
    load_user_config(base_config)             # a bad base names its file and key, before a child
    if args.view_feed:
        from companion.view.feed import parse_address
        parse_address(args.view_feed, "--view-feed")
    if args.lockstep_overlap and (not args.lockstep or args.autopilot):
        raise CompanionError("--lockstep-overlap is the stub's, in lock-step: not with "
                             "--no-lockstep or --autopilot")
    if args.unshaped and not args.autopilot:
        raise CompanionError("--unshaped is --autopilot's (the stub's flights are unshaped)")
    if args.depth_record and scenario.sensor.form != "depth":
        raise CompanionError(f"--depth-record: {args.scenario} has no depth camera "
                             "(sensor.form: depth)")
    if args.autopilot:
        return run_autopilot(args, scenario_path, scenario)
    if args.px4:
        return run_px4(args, scenario_path, scenario)
    tlog = Path(args.tlog).resolve() if args.tlog else None
    started = time.monotonic()
    with tempfile.TemporaryDirectory(prefix="companion-demo-") as tmp:
        workdir = Path(args.keep or tmp)
        workdir.mkdir(parents=True, exist_ok=True)
        files = DemoFiles(workdir, tlog)
        report, _, truth, samples = run_task_tree(run_demo(
                scenario_path, scenario, files, args.speedup, args.seed, args.drop_rate,
                Path(args.signing_key).resolve() if args.signing_key else None, args.lockstep,
                args.view_feed, args.lockstep_overlap, base_config, args.stub_autopilot,
                args.px4_offboard, px4_ground_station,
                Path(args.depth_record).resolve() if args.depth_record else None))
        summary, arrays = score(report, truth, scenario, args.seed)
    wall_s = time.monotonic() - started
    result = demo_result(summary, arrays.pop("nees"), scenario)
    result["aggregate"]["wall_time_s"] = round(wall_s, 2)
    result["aggregate"]["speedup"] = args.speedup
    result["aggregate"]["lockstep"] = args.lockstep
    if args.lockstep_overlap:
        result["aggregate"]["lockstep_overlap"] = True
    t_arrival = report.get("arrival_t_s")
    result["aggregate"].update(flight_timing(
        samples, t_arrival - summary["time_s"] if t_arrival is not None else 0.0, t_arrival))
    if args.stub_autopilot == "px4":          # ArduCopter's result stays as it was
        result["flight"] = px4_flight(report, truth)
    if args.json:
        write_json(args.json, result)
    if args.plot:
        import numpy as np

        from companion.sim.plot import plot_paths
        goal = scenario.world.goal
        plot_paths(args.plot, **arrays, safety_distance_m=scenario.safety_distance_m,
                   goal_ne=np.array([goal.north_m, goal.east_m]),
                   title=f"{scenario.name}: companion demo over MAVLink, seed {args.seed}",
                   start_ne=np.array([scenario.world.start.north_m, scenario.world.start.east_m]))
    print_summary(result, sys.stdout)
    rtf = result["aggregate"]["real_time_factor"]
    pace = "lock-step" if args.lockstep else f"speedup {args.speedup:g}"
    print(f"time to goal {summary['time_s']:.1f} s simulated, {wall_s:.1f} s wall in all "
          f"({pace}; the flight at {rtf if rtf is not None else '?'}x real time); "
          f"urgent events {summary['urgent_events']}")
    if args.tlog:
        print(f"tlog: {args.tlog}")
    if "flight" in result:
        f = result["flight"]
        print(f"PX4: OFFBOARD at {f.get('offboard_t_s')} s by the {f.get('offboard')}, "
              f"setpoints on the ground {f.get('setpoints_while_landed')}")
    return 0 if summary["reached_goal"] else 1


def run_px4(args: argparse.Namespace, scenario_path: Path, scenario) -> int:
    """``--px4 DIR``: the scenario flown by PX4 SITL (companion/tools/px4_sitl_demo.py)."""
    from companion.tools.demo_scoring import demo_result, score
    from companion.tools.px4_sitl_demo import Px4Files, run_px4_demo
    if args.drop_rate or args.signing_key or args.stub_autopilot != "ardupilot":
        raise CompanionError("--px4 flies PX4's SITL: not with --drop-rate, --signing-key or "
                             "--stub-autopilot")
    started = time.monotonic()
    with tempfile.TemporaryDirectory(prefix="companion-demo-px4-") as tmp:
        workdir = Path(args.keep or tmp).resolve()
        workdir.mkdir(parents=True, exist_ok=True)
        files = Px4Files(workdir, None)
        report, truth, flight = run_task_tree(run_px4_demo(
            scenario_path, scenario, files, Path(args.px4).resolve(), args.seed,
            args.px4_offboard or "operator", kill_at_north_m=args.px4_kill_at_north))
        summary, arrays = score(report, truth, scenario, args.seed)
    result = demo_result(summary, arrays.pop("nees"), scenario)
    result["aggregate"]["wall_time_s"] = round(time.monotonic() - started, 2)
    result["flight"] = flight
    if args.json:
        write_json(args.json, result)
    print_summary(result, sys.stdout)
    print(f"PX4 SITL: OFFBOARD at {flight.get('offboard_t_s')} s by the {flight.get('offboard')}")
    return 0 if summary["reached_goal"] else 1


def px4_flight(report: dict, truth: list[dict]) -> dict:
    """The PX4 demo's facts (companion/tools/px4_gcs.py), with the stub's count of setpoints
    received while the vehicle stood on the ground."""
    flight = dict(report.get("px4_flight") or {})
    landed = [row["setpoints_while_landed"] for row in truth if "setpoints_while_landed" in row]
    flight["setpoints_while_landed"] = max(landed) if landed else None
    return flight
