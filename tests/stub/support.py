"""Helpers for the stub's end-to-end tests: start `sitl-stub` as a real subprocess, talk to it with
a plain pymavlink client, wait on conditions with deadlines (never sleep to synchronise)."""
from __future__ import annotations

import json
import os
import select
import signal
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

os.environ["MAVLINK20"] = "1"
from pymavlink import mavutil  # noqa: E402

mavutil.set_dialect("ardupilotmega")
mavlink = mavutil.mavlink

REPO = Path(__file__).resolve().parents[2]
PAPER = REPO / "config" / "scenarios" / "paper.yaml"
READY_TIMEOUT_S = 20.0
EXIT_TIMEOUT_S = 10.0


@dataclass
class Stub:
    proc: subprocess.Popen
    tcp_port: int | None
    udp_port: int | None
    stderr_path: Path
    depth_port: int | None = None      # --depth-tcp's (the READY line's depth=)

    def stop(self) -> int:
        """SIGTERM and wait (bounded) for the exit code."""
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
        try:
            return self.proc.wait(timeout=EXIT_TIMEOUT_S)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait(timeout=EXIT_TIMEOUT_S)
            raise AssertionError("stub did not exit within %.0f s of SIGTERM" % EXIT_TIMEOUT_S)

    def stderr(self) -> str:
        return self.stderr_path.read_text(errors="replace")


def stub_command(*args: str) -> list[str]:
    return [sys.executable, "-m", "sitl_stub", *args]


def start_stub(tmp_path: Path, *args: str, scenario: Path = PAPER) -> Stub:
    """Start the stub on 127.0.0.1 port 0 (unless args say otherwise) and parse its READY line."""
    argv = ["--scenario", str(scenario)]
    if "--tcp" not in args:
        argv += ["--tcp", "127.0.0.1:0"]
    argv += list(args)
    err = tmp_path / f"stub-stderr-{time.monotonic_ns()}.txt"
    proc = subprocess.Popen(stub_command(*argv), stdout=subprocess.PIPE,
                            stderr=open(err, "w"), text=True, cwd=REPO)
    line = _read_line(proc, READY_TIMEOUT_S)
    if not line.startswith("SITL_STUB READY "):
        proc.kill()
        raise AssertionError(f"no READY line, got {line!r}; stderr:\n{err.read_text()}")
    fields = dict(part.split("=", 1) for part in line.split()[2:])
    return Stub(proc=proc, tcp_port=_port(fields["tcp"]), udp_port=_port(fields["udp"]),
                stderr_path=err, depth_port=_port(fields.get("depth", "-")))


def _port(text: str) -> int | None:
    return None if text == "-" else int(text.rsplit(":", 1)[1])


def _read_line(proc: subprocess.Popen, timeout_s: float) -> str:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        ready, _, _ = select.select([proc.stdout], [], [], max(0.0, deadline - time.monotonic()))
        if ready:
            return proc.stdout.readline().strip()
        if proc.poll() is not None:
            break
    return ""


def connect_tcp(port: int, source_system: int = 255):
    conn = mavutil.mavlink_connection(f"tcp:127.0.0.1:{port}", source_system=source_system,
                                      source_component=190, autoreconnect=False)
    conn.target_system, conn.target_component = 1, 1
    return conn


def connect_udp(port: int, source_system: int = 255):
    """A udpout client: it sends first, the stub then treats its address as a client."""
    conn = mavutil.mavlink_connection(f"udpout:127.0.0.1:{port}", source_system=source_system,
                                      source_component=190)
    conn.target_system, conn.target_component = 1, 1
    return conn


def wait_for(conn, predicate: Callable[[object], bool], timeout_s: float, types=None,
             on_message: Callable[[object], None] | None = None):
    """First message (optionally of `types`) satisfying predicate before the deadline, else None."""
    deadline = time.monotonic() + timeout_s
    while True:
        remaining = deadline - time.monotonic()
        if remaining <= 0:
            return None
        msg = conn.recv_match(type=types, blocking=True, timeout=min(remaining, 0.5))
        if msg is None:
            continue
        if on_message is not None:
            on_message(msg)
        if predicate(msg):
            return msg


def wait_heartbeat(conn, timeout_s: float = 10.0, component: int = 1):
    return wait_for(conn, lambda m: m.get_srcComponent() == component, timeout_s, "HEARTBEAT")


def command(conn, cmd: int, *params: float, timeout_s: float = 5.0, target_component: int = 1):
    """COMMAND_LONG and its COMMAND_ACK (None if none arrived in time)."""
    p = list(params) + [0.0] * (7 - len(params))
    conn.mav.command_long_send(1, target_component, cmd, 0, *p)
    return wait_for(conn, lambda m: m.command == cmd, timeout_s, "COMMAND_ACK")


def send_velocity(conn, vn: float, ve: float, yaw: float = 0.0, mask: int = 0x09C7,
                  frame: int = mavlink.MAV_FRAME_LOCAL_NED) -> None:
    conn.mav.set_position_target_local_ned_send(0, 1, 1, frame, mask, 0, 0, 0, vn, ve, 0,
                                                0, 0, 0, yaw, 0)


def arm_guided(conn, takeoff_alt_m: float | None = 10.0) -> None:
    """GUIDED, arm and (unless None) NAV_TAKEOFF, waiting until the altitude is reached: an
    ArduCopter ignores velocity targets on the ground (and disarms after DISARM_DELAY)."""
    ack = command(conn, mavlink.MAV_CMD_DO_SET_MODE, mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, 4)
    assert ack is not None and ack.result == mavlink.MAV_RESULT_ACCEPTED
    ack = command(conn, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1)
    assert ack is not None and ack.result == mavlink.MAV_RESULT_ACCEPTED
    if takeoff_alt_m is None:
        return
    ack = command(conn, mavlink.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, 0, 0, 0, takeoff_alt_m)
    assert ack is not None and ack.result == mavlink.MAV_RESULT_ACCEPTED
    assert wait_for(conn, lambda m: m.z <= -(takeoff_alt_m - 0.3), 60.0,
                    "LOCAL_POSITION_NED") is not None, "takeoff did not reach its altitude"


def read_truth_log(path: Path) -> list[dict]:
    """Every complete record; a last line without its newline is one the stub is still writing
    (read mid-flight, the JSON was cut at char 817 once under load), so it is left for later."""
    text = path.read_text()
    complete = text if text.endswith("\n") else text[:text.rfind("\n") + 1]
    return [json.loads(line) for line in complete.splitlines() if line.strip()]


def wait_until(condition: Callable[[], bool], timeout_s: float, poll_s: float = 0.05) -> bool:
    """Poll a cheap condition (e.g. a file's content) until true or the deadline passes."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if condition():
            return True
        select.select([], [], [], poll_s)
    return condition()
