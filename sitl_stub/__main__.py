"""sitl-stub: the paper's 2D model behind an ArduCopter-like MAVLink face.

    sitl-stub --scenario PATH [--tcp HOST:PORT|none] [--udp HOST:PORT] [--speedup N] [--seed S]
              [--truth-log PATH] [--drop-rate P] [--sysid N] [--signing-key FILE] [--streams-off]
              [--lockstep] [--lockstep-timeout-s S] [--route] [--depth-tcp HOST:PORT]
    sitl-stub --camera-only --connect URL --scenario PATH [--seed S] [--sysid N]
              [--ekf-origin N,E] [--sectors]     # the camera alone, beside any autopilot

Prints exactly one line to stdout once listening: `SITL_STUB READY tcp=HOST:PORT udp=HOST:PORT`
(`-` for a disabled endpoint), followed by ` depth=HOST:PORT` with --depth-tcp (the depth
cameras' frame stream of a sensor.form depth scenario, docs/depth.md). Logs go to stderr. Exit 0 on SIGTERM/SIGINT, 2 on a bad scenario,
bad option or a port that cannot be bound.
"""
from __future__ import annotations

import argparse
import asyncio
import collections
import json
import logging
import math
import signal
import sys
import time
from dataclasses import dataclass
from pathlib import Path

from .autopilot import Autopilot
from .camera_component import CameraComponent
from .links import COMPONENTS, Endpoint, LinkError, LinkHub, open_links, parse_endpoint
from .routing import Router
from .lockstep import (DEFAULT_TIMEOUT_S, MSG_ID_ODOMETRY, SAMPLE_IDS, LockstepGate,
                       LockstepOptions, odometry_last)
from .params import ParamTable
from .sim import Simulation
from .streams import STREAMABLE
from .telemetry import COMP_AUTOPILOT, MODE_NAMES
from . import shapes
from .world import Scenario, ScenarioError, load_scenario, obstacles_at

log = logging.getLogger("sitl_stub")

EXIT_USAGE = 2
INBOX_LIMIT = 10_000
MAX_LAG_S = 0.5   # wall seconds behind schedule before the schedule is rebased (logged)
RESEND_BEFORE_PEER_S = 1.0
RESENT_BEFORE_PEER = (0, 30, 32)     # HEARTBEAT, ATTITUDE, LOCAL_POSITION_NED


class ShutdownRequested(Exception):
    """Raised by the stop task when SIGTERM/SIGINT arrives."""


@dataclass(frozen=True)
class Options:
    scenario: Scenario
    tcp: Endpoint | None
    udp: Endpoint | None
    speedup: float
    seed: int
    truth_log: Path | None
    drop_rate: float
    sysid: int
    signing_key: bytes | None
    streams_off: bool
    lockstep: LockstepOptions | None = None
    route: bool = False
    boot_intervals: tuple[tuple[int, float], ...] = ()     # (message id, Hz) every link starts with
    depth_tcp: Endpoint | None = None       # the depth stream's server (sensor.form depth)


def _extent_record(world, obstacle_id: int) -> dict:
    """height_m / base_m of an obstacle, wall or building in the truth log, only where the
    scenario gives them (a 2D world's lines stay as they were)."""
    for item in world.obstacles + world.shapes:
        if item.obstacle_id == obstacle_id:
            out = {} if item.height_m is None else {"height_m": item.height_m}
            return {**out, "base_m": item.base_m} if item.base_m > 0.0 else out
    return {}


class TruthLog:
    """JSON lines of the true state; flushed at least once per wall-clock second and on close."""

    def __init__(self, path: Path) -> None:
        self._file = open(path, "w", encoding="utf-8")
        self._last_flush = time.monotonic()
        self._shapes_written = False

    def write(self, t_s: float, sim: Simulation, ap: Autopilot) -> None:
        truth, odom = sim.truth, sim.odometry
        record = {
            "t_s": round(t_s, 6), "north_m": truth.north_m, "east_m": truth.east_m,
            "yaw_rad": truth.yaw_rad, "speed_mps": truth.speed_mps, "armed": ap.armed,
            "mode": MODE_NAMES.get(ap.mode, str(ap.mode)),
            "vel_north_mps": truth.vel_north_mps, "vel_east_mps": truth.vel_east_mps,
            "up_m": truth.up_m, "vel_up_mps": truth.vel_up_mps, "landed": ap.flight.land_complete,
            "obstacles": [{"id": i, "north_m": n, "east_m": e, "radius_m": r,
                           **_extent_record(sim.scenario.world, i)}
                          for i, n, e, r in obstacles_at(sim.scenario.world.obstacles, t_s)],
            # the stub's own distance to the nearest wall or building surface (negative: inside)
            "shape_clearance_m": min((shapes.surface_distance_m(truth.north_m, truth.east_m,
                                                                list(shape.outline))
                                      for shape in sim.scenario.world.shapes), default=None),
            "odom_north_m": odom.north_m, "odom_east_m": odom.east_m, "odom_yaw_rad": odom.yaw_rad,
        }
        if not self._shapes_written:      # static: once, on the first line (a viewer reads it)
            record["shapes"] = [{"id": shape.obstacle_id, "kind": shape.kind,
                                 "outline": [list(point) for point in shape.outline],
                                 **_extent_record(sim.scenario.world, shape.obstacle_id)}
                                for shape in sim.scenario.world.shapes]
            self._shapes_written = True
        self._file.write(json.dumps(record) + "\n")
        now = time.monotonic()
        if now - self._last_flush >= 1.0:
            self._file.flush()
            self._last_flush = now

    def close(self) -> None:
        self._file.flush()
        self._file.close()


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="sitl-stub", description=__doc__.split("\n\n")[0])
    p.add_argument("--scenario", required=True, help="scenario YAML (config/scenarios/README.md)")
    p.add_argument("--tcp", default="127.0.0.1:5760", help="TCP server HOST:PORT, or none")
    p.add_argument("--udp", default="none", help="UDP endpoint HOST:PORT (udpin-like); default none")
    p.add_argument("--speedup", type=float, default=1.0, help="simulated time / wall time")
    p.add_argument("--seed", type=int, default=0, help="seed of every random stream")
    p.add_argument("--truth-log", default=None, help="write the true state as JSON lines here")
    p.add_argument("--drop-rate", type=float, default=0.0, help="drop probability per datagram/message")
    p.add_argument("--sysid", type=int, default=None, help="MAVLink system id (SYSID_THISMAV), default 1")
    p.add_argument("--signing-key", default=None, help="file with a 32-byte key as 64 hex chars")
    p.add_argument("--streams-off", action="store_true",
                   help="all SRn_* stream rates 0: no telemetry until a client asks")
    p.add_argument("--route", action="store_true",
                   help="route MAVLink between clients as ArduPilot does (sitl_stub/routing.py): "
                        "a ground station reaches the companion's component through the stub")
    p.add_argument("--message-rate", action="append", default=[], metavar="MSG_ID:HZ",
                   help="a message every link starts with at this rate (repeatable): as the "
                        "SRn_ parameters of a companion's port on a real vehicle; applied at "
                        "t=0 after the boot burst, as a SET_MESSAGE_INTERVAL then would be "
                        "(a link's own requests change only its own rates)")
    p.add_argument("--lockstep", action="store_true",
                   help="step only when the companion's ODOMETRY says it has caught up "
                        "(docs/sitl_stub.md); --speedup paces the free-run fallback")
    p.add_argument("--lockstep-timeout-s", type=float, default=DEFAULT_TIMEOUT_S,
                   help=f"wall seconds to wait for the companion before free-running "
                        f"(default {DEFAULT_TIMEOUT_S:g})")
    p.add_argument("--lockstep-overlap", action="store_true",
                   help="with --lockstep: step on the companion's answer to the sample before the "
                        "latest, so both compute at once; its setpoints take effect one step "
                        "(one control period) later (docs/sitl_stub.md)")
    p.add_argument("--depth-tcp", default="none", metavar="HOST:PORT",
                   help="serve the depth cameras' frames (a sensor.form depth scenario) on this "
                        "local TCP address, docs/depth.md (port 0: any; default none)")
    p.add_argument("--log-level", default="INFO", help="stderr log level (default INFO)")
    cam = p.add_argument_group("camera only: the stub's camera beside any autopilot")
    cam.add_argument("--camera-only", action="store_true",
                     help="no vehicle: be the camera (component 100) of the autopilot at --connect")
    cam.add_argument("--connect", metavar="URL",
                     help="the autopilot's link: udpin:HOST:PORT, udpout:, tcp:, tcpin:, /dev/ttyX")
    cam.add_argument("--ekf-origin", metavar="N,E",
                     help="where the autopilot's LOCAL_NED origin lies in the scenario frame (m); "
                          "default: from its GPS_GLOBAL_ORIGIN and world.origin")
    cam.add_argument("--sectors", action="store_true",
                     help="also the 72-sector OBSTACLE_DISTANCE (default: sensor.sector_message)")
    return p


def parse_options(argv: list[str] | None) -> Options:
    """Parse and check the command line. Raises ValueError/ScenarioError with clear messages."""
    args = build_parser().parse_args(argv)
    logging.basicConfig(stream=sys.stderr, level=args.log_level.upper(),
                        format="%(asctime)s %(levelname)s %(name)s: %(message)s")
    if not (args.speedup > 0 and args.speedup < 1e6):
        raise ValueError(f"--speedup must be > 0, got {args.speedup}")
    if not 0.0 <= args.drop_rate <= 1.0:
        raise ValueError(f"--drop-rate must be in [0, 1], got {args.drop_rate}")
    sysid = 1 if args.sysid is None else args.sysid
    if not 1 <= sysid <= 255:
        raise ValueError(f"--sysid must be in 1..255, got {sysid}")
    tcp = parse_endpoint(args.tcp, "tcp")
    udp = parse_endpoint(args.udp, "udp")
    if tcp is None and udp is None:
        raise ValueError("both --tcp and --udp are disabled: nothing to serve")
    key = _read_signing_key(args.signing_key) if args.signing_key else None
    if not args.lockstep_timeout_s > 0:
        raise ValueError(f"--lockstep-timeout-s must be > 0, got {args.lockstep_timeout_s}")
    lockstep = LockstepOptions(timeout_s=args.lockstep_timeout_s,
                               overlap=args.lockstep_overlap) if args.lockstep else None
    scenario = load_scenario(args.scenario)
    depth_tcp = parse_endpoint(args.depth_tcp, "depth-tcp")
    if depth_tcp is not None and scenario.sensor.form != "depth":
        raise ValueError(f"--depth-tcp: the scenario's camera is {scenario.sensor.form!r}; the "
                         "depth stream needs sensor.form: depth")
    return Options(scenario=scenario, tcp=tcp, udp=udp, speedup=args.speedup, depth_tcp=depth_tcp,
                   seed=args.seed, truth_log=Path(args.truth_log) if args.truth_log else None,
                   drop_rate=args.drop_rate, sysid=sysid, signing_key=key,
                   streams_off=args.streams_off, lockstep=lockstep, route=args.route,
                   boot_intervals=tuple(_message_rate(text) for text in args.message_rate))


def _message_rate(text: str) -> tuple[int, float]:
    msg_id, _, rate = text.partition(":")
    try:
        result = int(msg_id), float(rate)
    except ValueError:
        raise ValueError(f"--message-rate: expected MSG_ID:HZ, got {text!r}") from None
    if result[0] not in STREAMABLE or not (0.0 < result[1] <= 1000.0):
        raise ValueError(f"--message-rate: {text!r}: a streamable message id "
                         f"({', '.join(map(str, STREAMABLE))}) and 0 < HZ <= 1000")
    return result


def _read_signing_key(path: str) -> bytes:
    try:
        text = Path(path).read_text(encoding="ascii").strip()
    except (OSError, UnicodeDecodeError) as exc:
        raise ValueError(f"--signing-key {path}: cannot read: {exc}") from exc
    if len(text) != 64:
        raise ValueError(f"--signing-key {path}: expected 64 hex characters, got {len(text)}")
    try:
        return bytes.fromhex(text)
    except ValueError:
        raise ValueError(f"--signing-key {path}: not hexadecimal") from None


class WallPacer:
    """Paces steps at dt_s / speedup wall seconds; rebases (logged) when far behind."""

    def __init__(self, dt_s: float, speedup: float) -> None:
        self._loop = asyncio.get_running_loop()
        self._period_s = dt_s / speedup
        self.rebase(0)

    def rebase(self, step_index: int) -> None:
        self._wall0, self._base_step = self._loop.time(), step_index

    async def wait_for_step(self, step_index: int) -> None:
        due = self._wall0 + (step_index + 1 - self._base_step) * self._period_s
        delay = due - self._loop.time()
        if delay < -MAX_LAG_S:
            log.warning("falling behind wall clock by %.2f s; simulated time slows down", -delay)
            self.rebase(step_index)
            delay = 0.0
        await asyncio.sleep(max(0.0, delay))


async def simulate(opts: Options, sim: Simulation, ap: Autopilot, cam: CameraComponent,
                   hub: LinkHub, inbox: collections.deque, truth_log: TruthLog | None,
                   lockstep: Lockstep | None = None, depth=None) -> None:
    """Step physics on simulated time, handle messages, emit telemetry. Runs until cancelled.
    ``depth``: (DepthRig, DepthServer): each step's depth frames go out before its MAVLink."""
    pacer = WallPacer(sim.dt_s, opts.speedup)

    def send_depth() -> None:
        if depth is not None:
            depth[1].send(depth[0].frames_due(sim))

    def handle_inbox() -> None:
        t_s = sim.t_s
        if lockstep is not None:
            lockstep.release(t_s, inbox)
        while inbox:
            name, msg = inbox.popleft()
            hub.broadcast(handle_safely(ap, name, msg, t_s))

    def emit(items: list) -> None:
        if lockstep is not None:
            items = lockstep.note_burst(odometry_last(items))
        hub.broadcast(items)

    def emit_step(t_s: float, head: list) -> None:
        """The step's messages. A link with its own stream rates (it asked: SET_MESSAGE_INTERVAL
        or REQUEST_DATA_STREAM) gets its own streams; the others share one set."""
        shared = ap.stream_items(ap.streams.shared, t_s)
        tail = ap.mission_ticks(t_s) + cam.periodic(t_s)
        own = ap.link_streams(t_s)
        if not own:
            emit(head + shared + tail)
            return
        for link, items in own.items():
            items = head + items + tail
            hub.broadcast(odometry_last(items) if lockstep is not None else items, only=link)
        items = head + shared + tail
        if lockstep is not None:
            items = lockstep.note_burst(odometry_last(items))
        hub.broadcast(items, exclude=frozenset(own))

    send_depth()
    emit_step(sim.t_s, [])
    for msg_id, rate_hz in opts.boot_intervals:
        ap.streams.shared.set_message_interval(msg_id, 1e6 / rate_hz)
    if truth_log is not None:
        truth_log.write(sim.t_s, sim, ap)
    while True:
        if lockstep is not None and not lockstep.gate.free_running:
            if not await lockstep.wait_for_peer(sim.t_s, handle_inbox):
                pacer.rebase(sim.step_index)
        else:
            await pacer.wait_for_step(sim.step_index)
            if lockstep is not None:
                lockstep.maybe_relock(sim.t_s)
        handle_inbox()
        sim.step(ap.demand(sim.t_s), ap.armed, ap.climb_limits())
        t_s = sim.t_s
        send_depth()
        emit_step(t_s, ap.after_step(t_s))
        if truth_log is not None:
            truth_log.write(t_s, sim, ap)


class Lockstep:
    """The asyncio side of lock-step: wakes the stepping task, bounds its waits, re-sends the
    current step to a client that joins while the stub waits (it would have missed it)."""

    def __init__(self, options: LockstepOptions, hub: LinkHub, speedup: float) -> None:
        self.options = options
        self._speedup = speedup
        self.gate = LockstepGate(options.overlap)
        self._hub = hub
        self._wake = asyncio.Event()
        self._burst: list = []
        self._pending: dict[str, list] = {}   # overlap: a peer's messages since its last ODOMETRY
        self._answers: collections.deque = collections.deque()   # (t_ms, [(client, msg)])
        hub.on_delivered = self.gate.on_delivered
        hub.delivered_ids = frozenset(SAMPLE_IDS)      # all the gate looks at
        hub.on_odometry = self._on_odometry
        hub.on_client = self._on_client

    def note_burst(self, items: list) -> list:
        self._burst = items
        return items

    def wake(self) -> None:
        self._wake.set()

    def holds(self, client: str, msg) -> bool:
        """With ``overlap``: a peer's message is held with its answer (the messages up to and
        including its next ODOMETRY), which takes effect one step after the sample it answers,
        whenever it arrives: the same flight whatever the load."""
        if not self.options.overlap or not self.gate.is_peer(client):
            return False
        pending = self._pending.setdefault(client, [])
        if len(pending) >= INBOX_LIMIT:
            return False           # a peer that stopped answering: its messages go to the inbox
        pending.append((client, msg))
        if msg.id == MSG_ID_ODOMETRY:
            self._answers.append((int(round(msg.time_usec / 1000.0)), pending))
            self._pending[client] = []
        self._wake.set()
        return True

    def release(self, t_s: float, inbox: collections.deque) -> None:
        """Into the inbox: the held answers to samples at least one step old (all of them while
        free-running)."""
        limit_ms = math.inf if self.gate.free_running else \
            int(round(t_s * 1000.0)) - self.gate.lag_ms
        answers = self._answers
        while answers and answers[0][0] <= limit_ms:
            inbox.extend(answers.popleft()[1])

    def _on_odometry(self, client: str, msg) -> None:
        self.gate.on_odometry(client, msg)
        self._wake.set()

    def _on_client(self, name: str) -> None:
        self._hub.broadcast(self._burst, only=name)

    def _resend_sample(self) -> None:
        """Before the first peer: the step's heartbeat, ATTITUDE and position again, in case the
        first ones were lost (--drop-rate); duplicates are harmless (same time, not newer)."""
        self._hub.broadcast([(comp, msg) for comp, msg in self._burst
                             if msg.id in RESENT_BEFORE_PEER and comp == COMP_AUTOPILOT])

    async def wait_for_peer(self, t_s: float, handle_inbox) -> bool:
        """Until the peers have caught up; False (and free-running) after the bounded wait.
        Messages that arrive meanwhile are handled at once, at the current time."""
        gate = self.gate
        if gate.caught_up():
            return True
        gate.waits += 1
        loop = asyncio.get_running_loop()
        timeout_s = self.options.timeout_s if gate.has_peer else self.options.start_timeout_s
        deadline = loop.time() + timeout_s
        while True:
            handle_inbox()
            if gate.caught_up():
                return True
            remaining = deadline - loop.time()
            if remaining <= 0.0:
                break
            self._wake.clear()
            try:
                async with asyncio.timeout(remaining if gate.has_peer
                                           else min(remaining, RESEND_BEFORE_PEER_S)):
                    await self._wake.wait()
            except TimeoutError:
                if not gate.has_peer:
                    self._resend_sample()
        gate.timeouts += 1
        gate.free_running = True
        log.warning("lock-step: %s after %.1f s wall at t=%.1f s (simulated): free-running at "
                    "speedup %g until it catches up",
                    f"no answer ({gate.lagging()})" if gate.has_peer else "no companion ODOMETRY",
                    timeout_s, t_s, self._speedup)
        return False

    def maybe_relock(self, t_s: float) -> None:
        if self.gate.caught_up():
            self.gate.free_running = False
            log.info("lock-step: the companion caught up at t=%.1f s (simulated): locked", t_s)


def handle_safely(ap: Autopilot, name: str, msg, t_s: float) -> list:
    """ap.handle, but a message that trips a bug in a handler is logged and dropped.

    A departure from STYLE.md ("our bugs raise"): the stub faces arbitrary clients (ground
    stations, routers, fuzzers) and must give a clean refusal rather than die on one message.
    """
    try:
        return ap.handle(msg, t_s, link=name)
    except Exception:   # noqa: BLE001 - logged with traceback, never silent
        log.exception("error handling %s from %s; message dropped", msg.get_type(), name)
        return []


async def raise_on(stop: asyncio.Event) -> None:
    await stop.wait()
    raise ShutdownRequested()


async def run_stub(opts: Options) -> None:
    sim = Simulation(opts.scenario, seed=opts.seed)
    params = ParamTable(sysid=opts.sysid, streams_off=opts.streams_off)
    ap = Autopilot(sim, params, start_unix_s=time.time())
    cam = CameraComponent(sim)
    inbox: collections.deque = collections.deque()
    overflow = [0]

    lockstep: Lockstep | None = None
    router = Router(opts.sysid, COMPONENTS) if opts.route else None

    def on_message(name: str, msg) -> None:
        if router is not None:
            route = router.route(name, msg)
            if route.to:
                hub.forward(msg.get_msgbuf(), route.to)
            if not route.local:
                return
        if lockstep is not None and lockstep.holds(name, msg):
            return
        if len(inbox) >= INBOX_LIMIT:
            overflow[0] += 1
            return
        inbox.append((name, msg))
        if lockstep is not None:
            lockstep.wake()

    hub = LinkHub(opts.tcp, opts.udp, opts.sysid, on_message, drop_rate=opts.drop_rate,
                  seed=opts.seed, signing_key=opts.signing_key)
    ap.on_signing_request = hub.set_signing_key
    if router is not None:
        hub.on_client_gone = router.forget
    if opts.lockstep is not None:
        lockstep = Lockstep(opts.lockstep, hub, opts.speedup)
    stop = asyncio.Event()
    loop = asyncio.get_running_loop()
    for sig in (signal.SIGTERM, signal.SIGINT):
        loop.add_signal_handler(sig, stop.set)
    truth_log = TruthLog(opts.truth_log) if opts.truth_log else None
    depth = None
    ready_depth = ""
    if opts.depth_tcp is not None:
        from .depth_camera import DepthRig
        from .depth_stream import DepthServer
        depth = (DepthRig(sim, sim.rng_depth), DepthServer())
        try:
            host, port = await depth[1].start(opts.depth_tcp.host, opts.depth_tcp.port)
        except OSError as exc:
            raise LinkError(f"--depth-tcp {opts.depth_tcp.host}:{opts.depth_tcp.port}: "
                            f"cannot listen: {exc.strerror or exc}") from None
        ready_depth = f" depth={host}:{port}"
    try:
        async with open_links(hub):
            tcp = "%s:%d" % hub.tcp_address if hub.tcp_address else "-"
            udp = "%s:%d" % hub.udp_address if hub.udp_address else "-"
            log.info("scenario %r (%s): dt %.3f s, speedup %g, seed %d, drop rate %g, sysid %d, "
                     "signing %s, streams %s, lock-step %s", opts.scenario.name,
                     opts.scenario.path, sim.dt_s, opts.speedup, opts.seed, opts.drop_rate,
                     opts.sysid, "on" if opts.signing_key else "off",
                     "off" if opts.streams_off else "default",
                     f"on (timeout {opts.lockstep.timeout_s:g} s"
                     f"{', overlapped' if opts.lockstep.overlap else ''})" if opts.lockstep else "off")
            print(f"SITL_STUB READY tcp={tcp} udp={udp}{ready_depth}", flush=True)
            try:
                async with asyncio.TaskGroup() as tg:
                    tg.create_task(simulate(opts, sim, ap, cam, hub, inbox, truth_log,
                                            lockstep, depth), name="simulate")
                    tg.create_task(raise_on(stop), name="stop")
            except* ShutdownRequested:
                log.info("clean shutdown at t=%.2f s (simulated)", sim.t_s)
            log.info("link statistics: %s; inbox overflow %d", hub.statistics(), overflow[0])
            if lockstep is not None:
                log.info("lock-step: %d steps, %d waited for the companion, %d waits timed out",
                         sim.step_index, lockstep.gate.waits, lockstep.gate.timeouts)
    finally:
        if truth_log is not None:
            truth_log.close()
        if depth is not None:
            log.info("depth stream: %d frames sent, %d dropped", depth[1].sent, depth[1].dropped)
            await depth[1].close()


def parse_camera_options(args: argparse.Namespace):
    from .camera_only import CameraOptions, parse_placement
    if not args.connect:
        raise ValueError("--camera-only needs --connect URL (the autopilot's link)")
    if args.sysid is not None and not 1 <= args.sysid <= 255:
        raise ValueError(f"--sysid must be in 1..255, got {args.sysid}")
    return CameraOptions(scenario=load_scenario(args.scenario), connect=args.connect,
                         seed=args.seed, sysid=args.sysid,
                         placement=parse_placement(args.ekf_origin),
                         sectors=True if args.sectors else None)


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    if args.camera_only:
        logging.basicConfig(stream=sys.stderr, level=args.log_level.upper(),
                            format="%(asctime)s %(levelname)s %(name)s: %(message)s")
        try:
            cam_opts = parse_camera_options(args)
        except (ValueError, ScenarioError) as exc:
            print(f"sitl-stub: error: {exc}", file=sys.stderr, flush=True)
            return EXIT_USAGE
        from .camera_only import CameraLinkError, run_camera
        try:
            run_camera(cam_opts, lambda url: print(f"SITL_STUB CAMERA READY connect={url}",
                                                   flush=True))
        except CameraLinkError as exc:
            print(f"sitl-stub: error: {exc}", file=sys.stderr, flush=True)
            return EXIT_USAGE
        return 0
    try:
        opts = parse_options(argv)
    except (ValueError, ScenarioError) as exc:
        print(f"sitl-stub: error: {exc}", file=sys.stderr, flush=True)
        return EXIT_USAGE
    try:
        asyncio.run(run_stub(opts))
    except LinkError as exc:
        print(f"sitl-stub: error: {exc}", file=sys.stderr, flush=True)
        return EXIT_USAGE
    return 0


if __name__ == "__main__":
    sys.exit(main())
