"""``companion doctor``: the first command on a real vehicle (argparse and printing only)."""
from __future__ import annotations

import argparse
import json
import sys
from dataclasses import asdict

from companion.cli.run import DEFAULT_CONFIG, run_task_tree
from companion.config.paths import resolve_config
from companion.config.service import load_user_config

MARKS = {"ok": "ok  ", "warn": "WARN", "fail": "FAIL"}


def add_parser(sub) -> None:
    p = sub.add_parser(
        "doctor", help="listen to the vehicle and say whether the service can fly it",
        description="Connects as `companion run` would, asks for the streams the service needs, "
                    "reads the autopilot's parameters, listens for --seconds, then prints a "
                    "checklist with what it measured. It never commands the vehicle (no mode, "
                    "no arming, no setpoint, no parameter set). Exit 0: ready; 1: a blocker, "
                    "each named with what to do (docs/doctor.md).")
    p.add_argument("--connect", required=True, metavar="URL",
                   help="udpin:HOST:PORT, udpout:HOST:PORT, tcp:HOST:PORT, tcpin:HOST:PORT or "
                        "/dev/ttyX:BAUD (as companion run)")
    p.add_argument("--config", default=DEFAULT_CONFIG,
                   help=f"the service's YAML settings, as companion run takes them (layered over "
                        f"{DEFAULT_CONFIG})")
    p.add_argument("--seconds", type=float, default=10.0,
                   help="how long to listen (default 10; rates are measured after the streams "
                        "are asked)")
    p.add_argument("--json", action="store_true", help="the checklist and the facts as JSON")
    p.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    from companion.daemon.doctor import diagnose
    from companion.onboard.doctor_checks import blockers
    if not args.seconds > 0:
        print("companion: --seconds must be > 0", file=sys.stderr)
        return 2
    path = resolve_config(args.config)
    config = load_user_config(path)
    facts, checks = run_task_tree(diagnose(config, args.connect, args.seconds, str(path)))
    failed = blockers(checks)
    if args.json:
        print(json.dumps({"ready": not failed, "checks": [asdict(c) for c in checks],
                          "facts": asdict(facts)}, indent=1, default=str))
    else:
        print(f"companion doctor: {args.connect}, {facts.listened_s:.0f} s")
        width = max(len(c.name) for c in checks)
        for check in checks:
            print(f"  {MARKS[check.status]}  {check.name:<{width}}  {check.measured}")
            if check.todo and check.status != "ok":
                print(f"        {'':<{width}}  -> {check.todo}")
        if failed:
            print(f"NOT READY: {len(failed)} blocker{'s' if len(failed) > 1 else ''}: "
                  + "; ".join(c.name for c in failed))
        else:
            print("READY: no blockers" + (f" ({sum(c.status == 'warn' for c in checks)} "
                                          "warnings)" if any(c.status == "warn" for c in checks)
                                          else ""))
    return 1 if failed else 0
