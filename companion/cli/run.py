"""``companion run``: the daemon beside the autopilot (estimate, avoid, command over MAVLink)."""
from __future__ import annotations

import argparse
import asyncio
import dataclasses
import math
import sys

from companion.config.service import SHIPPED_CONFIG, CompanionConfig, GoalConfig, load_user_config
from companion.config.loader import MAX_MAGNITUDE, FieldError
from companion.errors import CompanionError, ConfigError
from companion.config.paths import resolve_config

DEFAULT_CONFIG = SHIPPED_CONFIG


def add_parser(sub) -> None:
    p = sub.add_parser(
        "run", help="the companion daemon: connect to the vehicle and fly it around obstacles",
        description="Connects to the autopilot, estimates pose and obstacle map (EKF-SLAM) from its "
                    "odometry and the camera's obstacle reports, and while the vehicle is armed in "
                    "GUIDED sends velocity setpoints toward the goal, deflected by the collision "
                    "cone. SIGINT/SIGTERM stop it cleanly.")
    p.add_argument("--connect", required=True, metavar="URL",
                   help="udpin:HOST:PORT, udpout:HOST:PORT, tcp:HOST:PORT, tcpin:HOST:PORT or "
                        "/dev/ttyX:BAUD")
    p.add_argument("--config", default=DEFAULT_CONFIG,
                   help=f"YAML settings: only the keys that differ from the shipped "
                   f"{DEFAULT_CONFIG}, which holds every other (default: that file itself)")
    p.add_argument("--goal", metavar="NORTH,EAST[,RADIUS] | geo:LAT,LON[,RADIUS]",
                   help="goal in LOCAL_NED metres from the EKF origin, or as latitude,longitude in "
                        "degrees after 'geo:' (converted with the vehicle's EKF origin), or 'mission' "
                        "(fly the autopilot's mission, NAV_WAYPOINT items, in GUIDED); "
                        "overrides the config's goal")
    p.add_argument("--tlog", metavar="PATH",
                   help="record every message received and sent (PATH.config.yaml gets the config)")
    p.add_argument("--tlog-max-mb", type=float, metavar="MB",
                   help="rotate the tlog at this size: PATH.1 .. PATH.3 kept, the oldest dropped "
                        "(at most 4 x MB on disk; default: one file, unbounded)")
    p.add_argument("--report", metavar="PATH",
                   help="write the estimated track, map and events as JSON (at start, arrival, exit)")
    p.add_argument("--sysid", type=int, help="pin the vehicle's system id")
    p.add_argument("--lockstep", action="store_true",
                   help="against `sitl-stub --lockstep`: one ODOMETRY per odometry sample, and "
                        "the vehicle's clock for heartbeats, timeouts and the tlog")
    p.add_argument("--param-overlay", metavar="PATH",
                   help="where parameters set from a ground station (PARAM_SET) are kept and read "
                        "back at start (default: CONFIG.params.yaml beside --config; 'none': "
                        "not kept)")
    p.add_argument("--depth", metavar="SOURCE",
                   help="read depth frames and perceive obstacles from them: stub:HOST:PORT "
                        "(sitl-stub --depth-tcp), rosbag:PATH:TOPIC, realsense-bag:FILE or "
                        "realsense[:SERIAL] (the last three need the extra 'depth'); overrides "
                        "perception.depth.source (docs/depth-perception.md)")
    p.add_argument("--view-feed", metavar="HOST:PORT",
                   help="send the live state to `companion view --source udp:HOST:PORT` "
                        "(UDP, 10 Hz; nothing waits for the view)")
    p.set_defaults(handler=run)


GEO_PREFIX = "geo:"


def parse_goal(text: str) -> GoalConfig:
    """'NORTH,EAST[,RADIUS]' (metres), 'geo:LAT,LON[,RADIUS]' (degrees, RFC 5870's form) or
    'mission[:RADIUS]' (the autopilot's mission; RADIUS for waypoints without their own)."""
    if text.strip().lower().split(":")[0] == "mission":
        _, _, radius_text = text.strip().partition(":")
        try:
            radius_m = float(radius_text) if radius_text else 2.0
            return GoalConfig(mission=True, radius_m=radius_m)
        except (ValueError, FieldError):
            raise ConfigError(f"--goal: expected mission or mission:RADIUS (metres > 0), "
                              f"got {text!r}") from None
    geographic = text.strip().lower().startswith(GEO_PREFIX)
    body = text.strip()[len(GEO_PREFIX):] if geographic else text
    form = "geo:LAT,LON or geo:LAT,LON,RADIUS (degrees, metres)" if geographic else \
        "NORTH,EAST or NORTH,EAST,RADIUS in metres (or geo:LAT,LON)"
    try:
        values = [float(v) for v in body.split(",")]
    except ValueError:
        values = []
    if len(values) not in (2, 3):
        raise ConfigError(f"--goal: expected {form}, got {text!r}")
    if not all(math.isfinite(v) for v in values):
        raise ConfigError(f"--goal: expected finite numbers, got {text!r}")
    if any(abs(v) > MAX_MAGNITUDE for v in values):
        raise ConfigError(f"--goal: expected metres of sane magnitude (|value| <= "
                          f"{MAX_MAGNITUDE:g}), got {text!r}")
    radius = {"radius_m": values[2]} if len(values) == 3 else {}
    try:
        if geographic:
            return GoalConfig(lat_deg=values[0], lon_deg=values[1], **radius)
        return GoalConfig(north_m=values[0], east_m=values[1], **radius)
    except FieldError as exc:
        raise ConfigError(f"--goal: {exc.key}: {exc.problem}") from None


def effective_config(args: argparse.Namespace) -> CompanionConfig:
    """The config file, layered over the shipped one, with the command line's overrides applied."""
    config = load_user_config(args.config)
    if args.goal:
        goal = parse_goal(args.goal)
        if goal.mission and config.goal is not None and config.goal.mission:
            # --goal mission keeps the file's mission settings (the recheck)
            goal = dataclasses.replace(goal, mission_recheck_s=config.goal.mission_recheck_s)
        config = dataclasses.replace(config, goal=goal)
    if config.goal is None:
        raise ConfigError(f"{args.config}: goal: not set; give --goal NORTH,EAST (or "
                          "--goal geo:LAT,LON) or a goal: section")
    if getattr(args, "depth", None):
        config = with_depth_source(config, args.depth)
    if getattr(args, "sysid", None) is not None:
        config = dataclasses.replace(config, link=dataclasses.replace(
            config.link, vehicle_system_id=args.sysid))
    return config


def with_depth_source(config: CompanionConfig, source: str) -> CompanionConfig:
    """The config with perception.depth.source replaced (``--depth``), checked."""
    try:
        depth = dataclasses.replace(config.perception.depth, source=source)
    except FieldError as exc:
        raise ConfigError(f"--depth: {exc.problem}") from None
    return dataclasses.replace(config, perception=dataclasses.replace(config.perception,
                                                                      depth=depth))


def run(args: argparse.Namespace) -> int:
    from companion.daemon.param_overlay import apply_overlay, overlay_path
    from companion.daemon.service import run_service
    from companion.view.feed import parse_address
    config = effective_config(args)
    overlay = None
    where = getattr(args, "param_overlay", None)
    if where is None or where.lower() != "none":
        config, overlay = apply_overlay(
            config, where if where is not None else overlay_path(resolve_config(args.config)))
    view_feed = parse_address(args.view_feed, "--view-feed") if args.view_feed else None
    try:
        max_bytes = None if args.tlog_max_mb is None else int(args.tlog_max_mb * 1e6)
        if max_bytes is not None and max_bytes <= 0:
            print("companion: --tlog-max-mb must be > 0", file=sys.stderr)
            return 2
        run_task_tree(run_service(config, args.connect, args.tlog, args.report,
                                  lockstep=args.lockstep, view_feed=view_feed,
                                  overlay=overlay, tlog_max_bytes=max_bytes))
    except CompanionError as exc:
        print(f"companion: {exc}", file=sys.stderr)
        return 2
    return 0


def run_task_tree(coro):
    """asyncio.run(coro); a CompanionError raised inside its task tree (a link, a child process)
    comes out as itself, to be said plainly; anything else is our bug and keeps its traceback."""
    try:
        return asyncio.run(coro)
    except BaseExceptionGroup as group:
        match, rest = group.split(CompanionError)
        if match is None or rest is not None:
            raise
        raise _first_leaf(match) from None


def _first_leaf(group: BaseExceptionGroup) -> BaseException:
    first = group.exceptions[0]
    return _first_leaf(first) if isinstance(first, BaseExceptionGroup) else first
