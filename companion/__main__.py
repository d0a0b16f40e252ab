"""Command-line entry point: ``companion <command> ...``.

The only place that configures logging, calls asyncio.run() (inside the commands' ``main``) and
turns errors into exit codes.
"""
from __future__ import annotations

import os

# One BLAS thread, set before numpy loads. The matrices here are small (a few hundred rows): a
# threaded BLAS gains nothing on them, and on a busy 2-core companion computer its spinning
# threads made a 200-landmark update 180x slower (22 ms instead of 0.12 ms, benchmarks/run.py).
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import importlib
import logging
import sys

from companion.errors import CompanionError

# Each module has add_parser(subparsers) and run(args) -> int.
COMMANDS = ("simulate", "campaign", "run", "demo", "replay", "view", "depth_record")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="companion", description=(
        "Companion-computer obstacle avoidance for MAVLink drones (EKF-SLAM + collision cone)."))
    parser.add_argument("-v", "--verbose", action="count", default=0,
                        help="more logging (-v info, -vv debug)")
    sub = parser.add_subparsers(dest="command", required=True)
    for name in COMMANDS:
        importlib.import_module(f"companion.cli.{name}").add_parser(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    level = {0: logging.WARNING, 1: logging.INFO}.get(args.verbose, logging.DEBUG)
    logging.basicConfig(level=level, stream=sys.stderr,
                        format="%(asctime)s %(levelname)s %(name)s: %(message)s")
    try:
        return args.handler(args)
    except CompanionError as exc:
        print(f"companion: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        return 130


if __name__ == "__main__":
    sys.exit(main())
