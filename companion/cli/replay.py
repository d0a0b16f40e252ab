"""``companion replay``: a tlog through the live daemon's estimator and avoidance, offline."""
from __future__ import annotations

import argparse
import dataclasses
import sys
from pathlib import Path

from companion.config.service import load_config
from companion.config.paths import resolve_config
from companion.tools.report import write_json

DEFAULT_CONFIG = "config/companion.yaml"


def add_parser(sub) -> None:
    p = sub.add_parser(
        "replay", help="replay a tlog through the estimator and avoidance; compare with what "
                       "the companion sent",
        description="Feeds the recorded inbound messages, in order and on their own clocks, "
                    "through the same code as `companion run`. Writes the estimated track, the "
                    "map, urgency events and the setpoints it would send; if the tlog holds "
                    "what a companion sent, compares them.")
    p.add_argument("tlog", metavar="FILE.tlog")
    p.add_argument("--config", help="companion settings (default: FILE.config.yaml written "
                   f"beside the tlog by `companion run`, else {DEFAULT_CONFIG})")
    p.add_argument("--goal", metavar="NORTH,EAST[,RADIUS] | geo:LAT,LON[,RADIUS]",
                   help="override the config's goal")
    p.add_argument("--sysid", type=int, help="the vehicle's system id (default: the first "
                   "autopilot heartbeat)")
    p.add_argument("--depth", metavar="SOURCE",
                   help="the flight's depth frames (realsense-bag:FILE, rosbag:PATH:TOPIC, as "
                        "companion depth-record wrote them): taken in as the lock-step service "
                        "took them, those of time t before the position of t")
    p.add_argument("--json", metavar="PATH", help="everything, with the comparison, as JSON")
    p.add_argument("--csv", metavar="PATH", help="the estimated track as CSV")
    p.add_argument("--plot", metavar="PATH", help="the estimated track and map as a PNG")
    p.set_defaults(handler=run)


def choose_config(args: argparse.Namespace):
    from companion.cli.run import parse_goal
    from companion.daemon.replay import sidecar_config_path
    if args.config:
        path = resolve_config(args.config)
    elif sidecar_config_path(args.tlog).exists():
        path = sidecar_config_path(args.tlog)
    else:
        path = resolve_config(DEFAULT_CONFIG)
    config = load_config(path)
    if args.goal:
        config = dataclasses.replace(config, goal=parse_goal(args.goal))
    if args.sysid is not None:
        config = dataclasses.replace(config, link=dataclasses.replace(
            config.link, vehicle_system_id=args.sysid))
    if getattr(args, "depth", None):
        from companion.cli.run import with_depth_source
        config = with_depth_source(config, args.depth)
    return config, path


def run(args: argparse.Namespace) -> int:
    from tqdm import tqdm

    from companion.tools.replay import plot_replay, replay_tlog, report, write_track_csv
    config, config_path = choose_config(args)
    tlog = Path(args.tlog)
    if not tlog.is_file():
        print(f"companion replay: {tlog}: no such file", file=sys.stderr)
        return 2
    size = tlog.stat().st_size
    from companion.depth.frames import DepthSourceError
    depth = None
    if getattr(args, "depth", None):
        from companion.depth.open import open_depth_source
        depth = open_depth_source(config.perception.depth.source)
    with tqdm(total=size, unit="B", unit_scale=True, desc="replay",
              disable=not sys.stderr.isatty()) as bar:
        try:
            result = replay_tlog(tlog, config, progress=bar.update, depth=depth)
        except DepthSourceError as exc:
            print(f"companion replay: {exc}", file=sys.stderr)
            return 2
    data = report(result)
    data["config_file"] = str(config_path)
    if args.json:
        write_json(args.json, data)
    if args.csv:
        write_track_csv(args.csv, result)
    if args.plot and result.pipeline.track:
        plot_replay(args.plot, result)
    print_replay_summary(data, sys.stdout)
    if result.messages == 0:
        print(f"companion replay: {tlog}: nothing readable", file=sys.stderr)
        return 1
    return 0


def print_replay_summary(data: dict, out) -> None:
    rate = data["messages_per_s"]
    lines = [
        f"{data['file']}: {data['messages']} messages ({data['inbound_messages']} inbound) over "
        f"{data['log_duration_s']:.1f} s of log, replayed in {data['wall_s']:.2f} s"
        + (f" ({rate:,.0f} messages/s)" if rate else ""),
        f"config: {data['config_file']}",
        f"vehicle: {data['vehicle']}   track: {len(data['track']['t_s'])} poses   "
        f"landmarks: {len(data['landmarks'])}   urgency events: {len(data['urgency_events'])}   "
        f"setpoints: {len(data['setpoints'])}",
    ]
    if data["setpoints_compared"] or data["poses_compared"]:
        diff = data["max_position_difference_m"]
        lines.append(
            f"against the recording: setpoints compared {data['setpoints_compared']}, "
            f"mismatched {data['setpoints_mismatched']}, unmatched {data['setpoints_unmatched']}; "
            f"poses compared {data['poses_compared']}, max difference "
            + (f"{diff:.3g} m" if diff is not None else "n/a"))
    lines += [f"note: {note}" for note in data["notes"]]
    out.write("\n".join(lines) + "\n")
