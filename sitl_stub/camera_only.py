"""`sitl-stub --camera-only --connect URL --scenario PATH`: the stub's camera beside any autopilot.

One MAVLink link (pymavlink's connection strings: udpin:, udpout:, tcp:, tcpin:, a serial
device), one blocking loop: receive with a short timeout, hand every message to
:class:`~sitl_stub.external_camera.ExternalCamera`, send what it returns as (vehicle system id,
component 100). Once the link is open it calls ``on_ready(url)`` with the port actually bound
(for a udpin/tcpin port 0): ``__main__`` prints `SITL_STUB CAMERA READY connect=URL`.
SIGTERM/SIGINT: return after logging its counters.
"""
from __future__ import annotations

import logging
import os
import signal
import time
from dataclasses import dataclass
from typing import Callable

os.environ.setdefault("MAVLINK20", "1")   # before mavutil picks its dialect: MAVLink 2 framing
from pymavlink import mavutil  # noqa: E402

from . import telemetry as tm  # noqa: E402
from .external_camera import ExternalCamera, Placement  # noqa: E402
from .sim import STREAM_CAMERA, make_rng  # noqa: E402
from .world import Scenario  # noqa: E402

log = logging.getLogger("sitl_stub.camera")

RECEIVE_TIMEOUT_S = 0.05


@dataclass(frozen=True)
class CameraOptions:
    scenario: Scenario
    connect: str
    seed: int
    sysid: int | None
    placement: Placement | None
    sectors: bool | None


def parse_placement(text: str | None) -> Placement | None:
    """'N,E' (metres of the scenario frame where the autopilot's LOCAL_NED origin is) or None."""
    if text is None:
        return None
    try:
        north_m, east_m = (float(v) for v in text.split(","))
    except ValueError:
        raise ValueError(f"--ekf-origin: expected NORTH,EAST in metres, got {text!r}") from None
    return Placement(north_m, east_m, "--ekf-origin")


def _bound_url(conn, url: str) -> str:
    """The URL with the port actually bound (udpin:HOST:0 -> udpin:HOST:PORT)."""
    sock = getattr(conn, "port", None) or getattr(conn, "listen_sock", None)
    kind = url.partition(":")[0]
    if kind in ("udpin", "udp", "tcpin") and hasattr(sock, "getsockname"):
        host, port = sock.getsockname()[:2]
        return f"{kind}:{host}:{port}"
    return url


class CameraLinkError(Exception):
    """The camera's link could not be opened."""


def run_camera(opts: CameraOptions, on_ready: Callable[[str], None]) -> None:
    stop = []
    for sig in (signal.SIGTERM, signal.SIGINT):
        signal.signal(sig, lambda *_: stop.append(True))
    try:
        conn = mavutil.mavlink_connection(opts.connect, source_system=opts.sysid or 1,
                                          source_component=tm.COMP_CAMERA, autoreconnect=True)
    except OSError as exc:
        raise CameraLinkError(f"cannot open {opts.connect}: {exc.strerror or exc}") from exc
    cam = ExternalCamera(opts.scenario, make_rng(opts.seed, STREAM_CAMERA), opts.sysid,
                         opts.placement, opts.sectors)
    log.info("camera for scenario %r (%s): %g Hz, fov %.0f deg, range %.0f m, sectors %s, seed %d",
             opts.scenario.name, opts.scenario.path, cam.cfg.rate_hz,
             cam.cfg.fov_rad * 57.29577951308232, cam.cfg.max_range_m,
             "on" if cam.sectors else "off", opts.seed)
    on_ready(_bound_url(conn, opts.connect))
    sent = bad = 0
    try:
        while not stop:
            msg = conn.recv_match(blocking=True, timeout=RECEIVE_TIMEOUT_S)
            now = time.monotonic()
            out = []
            if msg is not None:
                if msg.get_type() == "BAD_DATA":
                    bad += 1
                else:
                    out = cam.handle(msg, now)
            out += cam.poll(now)
            if out:
                conn.mav.srcSystem = cam.sysid
                for item in out:
                    conn.mav.send(item)
                sent += len(out)
    finally:
        log.info("camera stopped: %s; sent %d, bad data %d", cam.counters, sent, bad)
        conn.close()
