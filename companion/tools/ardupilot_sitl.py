"""ArduPilot's SITL binary as the demo starts it: its own instance, loopback-only MAVLink links.

ArduPilot SITL's own TCP ports (5760 + 10 I and up, SERIAL0-2) listen on every interface
(``UARTDriver::_tcp_start_connection`` binds INADDR_ANY). The demo keeps its links on loopback
instead: ``--serialN udpclient:127.0.0.1:PORT`` makes SITL send each serial port's MAVLink to a
UDP port on 127.0.0.1, where the ground station, the companion (``udpin:``) and the camera
listen; they answer to SITL's source port, as behind mavlink-router. What SITL still binds
itself is its RC input (UDP 5501 + 10 I on all interfaces), which is why the instance ``-I`` is
chosen free.
"""
from __future__ import annotations

import os
import random
import socket
from dataclasses import dataclass
from pathlib import Path

from companion.errors import CompanionError

RC_IN_BASE_PORT = 5501         # SITL_cmdline: RC input, UDP, + 10 per instance
TCP_BASE_PORT = 5760           # SERIAL0 (5762 SERIAL1, 5763 SERIAL2), + 10 per instance
INSTANCES = 100
LOOPBACK = "127.0.0.1"
FRAME_MODEL = "+"              # the quadcopter of Tools/autotest/default_params/copter.parm


@dataclass(frozen=True)
class SitlLinks:
    """Loopback UDP ports SITL's SERIAL0 (ground station), SERIAL1 (companion) and SERIAL2
    (camera) send to."""
    gcs_port: int
    companion_port: int
    camera_port: int


@dataclass(frozen=True)
class Home:
    lat_deg: float
    lon_deg: float
    alt_m: float
    yaw_deg: float


def check_files(binary: Path, defaults: Path) -> None:
    """Clear errors before anything starts: the binary runs, the defaults file reads."""
    if not binary.is_file():
        raise CompanionError(f"--autopilot {binary}: no such file (the ArduCopter SITL binary)")
    if not os.access(binary, os.X_OK):
        raise CompanionError(f"--autopilot {binary}: not executable (chmod +x it)")
    if not defaults.is_file():
        raise CompanionError(f"--autopilot-defaults {defaults}: no such file (a .parm file, "
                             "e.g. Tools/autotest/default_params/copter.parm)")


def _free(kind: int, host: str, port: int) -> bool:
    with socket.socket(socket.AF_INET, kind) as sock:
        try:
            sock.bind((host, port))
        except OSError:
            return False
    return True


def free_instance(seed: int | None = None) -> int:
    """An instance whose RC input port (and, for anyone starting SITL the usual way, TCP ports)
    nobody holds; tried from a random start so that two demos rarely race for one."""
    start = random.Random(seed if seed is not None else os.getpid()).randrange(INSTANCES)
    for k in range(INSTANCES):
        instance = (start + k) % INSTANCES
        if _free(socket.SOCK_DGRAM, "0.0.0.0", RC_IN_BASE_PORT + 10 * instance) and all(
                _free(socket.SOCK_STREAM, LOOPBACK, TCP_BASE_PORT + 10 * instance + n)
                for n in (0, 2, 3)):
            return instance
    raise CompanionError(f"no free SITL instance: UDP {RC_IN_BASE_PORT}+10*I taken for all "
                         f"I < {INSTANCES}")


def free_udp_port() -> int:
    """A loopback UDP port free now (the companion binds it next)."""
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
        sock.bind((LOOPBACK, 0))
        return sock.getsockname()[1]


def sitl_command(binary: Path, defaults: Path, instance: int, home: Home, speedup: float,
                 links: SitlLinks) -> list[str]:
    return [str(binary), "--model", FRAME_MODEL, "--speedup", f"{speedup:g}",
            "--defaults", str(defaults), "-I", str(instance),
            "--home", f"{home.lat_deg:.9f},{home.lon_deg:.9f},{home.alt_m:.2f},{home.yaw_deg:g}",
            "--serial0", f"udpclient:{LOOPBACK}:{links.gcs_port}",
            "--serial1", f"udpclient:{LOOPBACK}:{links.companion_port}",
            "--serial2", f"udpclient:{LOOPBACK}:{links.camera_port}"]
