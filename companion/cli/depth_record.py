"""``companion depth-record``: a flight's depth frames to bags (docs/depth.md).

    companion depth-record --scenario config/scenarios/depth.yaml --seconds 10 \\
        --rosbag out/flight-ros --realsense out/flight.db3
    companion depth-record --stub 127.0.0.1:PORT --frames 150 --rosbag out/demo-ros

From a scenario: flies it in-process (as ``companion simulate`` run with --seed) for at most
--seconds and records what its depth cameras render. From a stub: records --frames frames of a
running ``sitl-stub --depth-tcp`` stream (e.g. beside ``companion demo``).
"""
from __future__ import annotations

import argparse
import dataclasses
import sys

from companion.errors import CompanionError


def add_parser(sub) -> None:
    p = sub.add_parser("depth-record", help="record a flight's depth frames to ROS 2 / RealSense bags",
                       description=__doc__.split("\n\n")[0])
    src = p.add_mutually_exclusive_group(required=True)
    src.add_argument("--scenario", help="a sensor.form depth scenario, flown in-process")
    src.add_argument("--stub", metavar="HOST:PORT", help="a stub's depth stream (--depth-tcp)")
    p.add_argument("--seed", type=int, default=0, help="the run's seed (default 0)")
    p.add_argument("--seconds", type=float, default=10.0,
                   help="with --scenario: fly at most this long (default 10 s)")
    p.add_argument("--frames", type=int, default=150,
                   help="with --stub: record this many frames (default 150)")
    p.add_argument("--rosbag", metavar="DIR", help="write a ROS 2 bag (rosbags) into this new "
                                                   "directory: Image 16UC1 + CameraInfo")
    p.add_argument("--realsense", metavar="FILE.db3",
                   help="write the RealSense SDK's own bag (pyrealsense2; one file per camera)")
    p.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    if args.rosbag is None and args.realsense is None:
        raise CompanionError("depth-record: give --rosbag DIR and/or --realsense FILE.db3")
    from companion.tools.depth_bags import BagSink
    if args.scenario is not None:
        from companion.config.scenario import load_scenario
        scenario = load_scenario(args.scenario)
        if scenario.sensor.form != "depth":
            raise CompanionError(f"{args.scenario}: sensor.form is {scenario.sensor.form!r}; "
                                 "depth-record needs sensor.form: depth")
        if not args.seconds > 0:
            raise CompanionError(f"--seconds must be > 0, got {args.seconds}")
        sink = BagSink(args.rosbag, args.realsense, scenario.sensor.depth.rate_hz)
        mission = dataclasses.replace(scenario.mission,
                                      max_time_s=min(scenario.mission.max_time_s, args.seconds))
        from companion.sim.simulation import run_once
        try:
            run_once(dataclasses.replace(scenario, mission=mission), args.seed, depth_sink=sink)
        finally:
            sink.close()
    else:
        host, _, port = args.stub.rpartition(":")
        if not host or not port.isdigit() or args.frames < 1:
            raise CompanionError(f"--stub: expected HOST:PORT and --frames >= 1, got "
                                 f"{args.stub!r}, {args.frames}")
        sink = BagSink(args.rosbag, args.realsense)
        try:
            _record_stub(host, int(port), args.frames, sink)
        finally:
            sink.close()
    print(f"depth-record: {sink.frames} frames"
          + (f" -> {args.rosbag} (ROS 2)" if args.rosbag else "")
          + (f" -> {args.realsense} (RealSense)" if args.realsense else ""), file=sys.stdout)
    return 0


def _record_stub(host: str, port: int, frames: int, sink) -> None:
    """Read the stream in a thread at its own pace and write here: a bag writer slower than the
    stream (the SDK's, ~35 ms a frame on a loaded machine, against a lock-step flight's 20-30
    frames a second) must not make the stub drop frames for us (it does past 8 behind). The
    writers stay on this thread (rosbags' sqlite is bound to the thread that opened it)."""
    import queue
    import threading
    from companion.depth.open import read_stub
    pending: queue.SimpleQueue = queue.SimpleQueue()
    stop = threading.Event()
    END = object()

    def read() -> None:
        try:
            for sourced in read_stub(host, port):
                pending.put(sourced.frame)
                if stop.is_set():
                    break
        except BaseException as exc:          # handed to the writing side, raised there
            pending.put(exc)
        pending.put(END)

    reader = threading.Thread(target=read, name="depth-record-reader", daemon=True)
    reader.start()
    written = 0
    while written < frames:
        item = pending.get()
        if item is END:
            break
        if isinstance(item, BaseException):
            raise item
        sink([item])
        written += 1
    stop.set()
