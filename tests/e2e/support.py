"""End-to-end helpers: the stub and the companion as real subprocesses on 127.0.0.1 (port 0), a
pymavlink ground station, a UDP relay we can cut, and waits on conditions with deadlines."""
from __future__ import annotations

import os
import select
import signal
import socket
import subprocess
import sys
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import yaml

os.environ["MAVLINK20"] = "1"
from pymavlink import mavutil  # noqa: E402

from companion.mavlink.tlog import TlogReader  # noqa: E402
from companion.config.service import config_to_dict, load_config  # noqa: E402

REPO = Path(__file__).resolve().parents[2]
PAPER = REPO / "config" / "scenarios" / "paper.yaml"
GUIDED, LOITER = 4, 5
TAKEOFF_ALT_M = 10.0


def wait_until(condition: Callable[[], object], timeout_s: float, what: str, poll_s: float = 0.05):
    """Poll until ``condition()`` is truthy; fail with ``what`` after the deadline."""
    deadline = time.monotonic() + timeout_s
    while True:
        result = condition()
        if result:
            return result
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out after {timeout_s} s waiting for {what}")
        time.sleep(poll_s)


@dataclass
class Process:
    proc: subprocess.Popen
    stderr_path: Path

    def stderr(self) -> str:
        return self.stderr_path.read_text(errors="replace")

    def stop(self, timeout_s: float = 10.0) -> tuple[int, float]:
        """SIGTERM; returns (exit code, seconds it took)."""
        started = time.monotonic()
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
        try:
            code = self.proc.wait(timeout=timeout_s)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()
            raise AssertionError(f"no exit within {timeout_s} s of SIGTERM:\n{self.stderr()}")
        return code, time.monotonic() - started


def spawn(tmp_path: Path, name: str, argv: list[str], stdout=subprocess.DEVNULL) -> Process:
    err = tmp_path / f"{name}-{time.monotonic_ns()}.stderr"
    with open(err, "w") as stderr:
        proc = subprocess.Popen(argv, stdout=stdout, stderr=stderr, stdin=subprocess.DEVNULL,
                                text=True, cwd=REPO)
    return Process(proc, err)


def start_stub(tmp_path: Path, *args: str, scenario: Path = PAPER,
               lockstep: bool = False) -> tuple[Process, int, int]:
    """sitl-stub on TCP and UDP port 0; returns (process, tcp port, udp port) from READY.
    ``lockstep``: the stub waits for the companion (start it with ``lockstep`` too): every test
    that flies does, so that a busy machine cannot change the flight."""
    stub = spawn(tmp_path, "stub", [sys.executable, "-m", "sitl_stub", "--scenario", str(scenario),
                                    "--tcp", "127.0.0.1:0", "--udp", "127.0.0.1:0", *args,
                                    *(["--lockstep"] if lockstep else [])],
                 stdout=subprocess.PIPE)
    ready, _, _ = select.select([stub.proc.stdout], [], [], 20.0)
    line = stub.proc.stdout.readline() if ready else ""
    if not line.startswith("SITL_STUB READY"):
        stub.proc.kill()
        raise AssertionError(f"stub not ready: {line!r}\n{stub.stderr()}")
    ports = dict(part.split("=", 1) for part in line.split()[2:])
    return stub, int(ports["tcp"].rsplit(":", 1)[1]), int(ports["udp"].rsplit(":", 1)[1])


def write_config(tmp_path: Path, goal=(180.0, 0.0), **sections) -> Path:
    """config/companion.yaml with a goal and some sections' keys overridden."""
    data = config_to_dict(load_config(REPO / "config" / "companion.yaml"))
    data["goal"] = {"north_m": goal[0], "east_m": goal[1], "radius_m": 2.0}
    for section, values in sections.items():
        data[section].update(values)
    path = tmp_path / "companion.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def start_companion(tmp_path: Path, url: str, config: Path, *extra: str,
                    lockstep: bool = False) -> Process:
    return spawn(tmp_path, "companion", [sys.executable, "-m", "companion", "-v", "run",
                                         "--connect", url, "--config", str(config), *extra,
                                         *(["--lockstep"] if lockstep else [])])


class GroundStation:
    """A pymavlink client on the stub's TCP port: modes and arming, acknowledged."""

    def __init__(self, tcp_port: int) -> None:
        self.conn = mavutil.mavlink_connection(f"tcp:127.0.0.1:{tcp_port}", source_system=255,
                                               source_component=190)
        self.conn.wait_heartbeat(timeout=10)

    def command(self, command: int, *params: float, timeout_s: float = 10.0) -> None:
        """COMMAND_LONG to the autopilot, resent every 0.5 s until accepted."""
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            self.conn.mav.command_long_send(1, 1, command, 0, *params, *[0] * (7 - len(params)))
            ack = self.conn.recv_match(type="COMMAND_ACK", blocking=True, timeout=0.5)
            if ack is not None and ack.command == command and ack.result == 0:
                return
        raise AssertionError(f"command {command} not accepted within {timeout_s} s")

    def set_mode(self, custom_mode: int) -> None:
        self.command(mavutil.mavlink.MAV_CMD_DO_SET_MODE, 1, custom_mode)

    def arm(self) -> None:
        self.command(mavutil.mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1)

    def takeoff(self, alt_m: float = TAKEOFF_ALT_M) -> None:
        """NAV_TAKEOFF (param7: metres above home); ArduCopter climbs in GUIDED."""
        self.command(mavutil.mavlink.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, 0, 0, 0, alt_m)

    def fly_from_the_ground(self, alt_m: float = TAKEOFF_ALT_M) -> None:
        """The docs' workflow: GUIDED, arm, NAV_TAKEOFF; the companion commands once airborne."""
        self.set_mode(GUIDED)
        self.arm()
        self.takeoff(alt_m)

    def close(self) -> None:
        self.conn.close()


def read_tlog(path: Path) -> list:
    """[(t_us, msg)] of everything readable so far (the daemon flushes twice a second)."""
    if not path.exists():
        return []
    return [(r.t_us, r.msg) for r in TlogReader(path)]


def companion_setpoints(records: list) -> list:
    return [m for _, m in records if m.get_srcComponent() == 191
            and m.get_type() == "SET_POSITION_TARGET_LOCAL_NED"]


@dataclass
class UdpRelay:
    """Forwards datagrams between a client (the companion) and the stub; ``cut`` drops all."""
    stub_port: int
    cut: bool = False
    front: socket.socket = field(default=None)
    back: socket.socket = field(default=None)
    _client: tuple | None = None
    _stop: bool = False

    def __post_init__(self) -> None:
        self.front = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.front.bind(("127.0.0.1", 0))
        self.back = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.back.bind(("127.0.0.1", 0))
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    @property
    def port(self) -> int:
        return self.front.getsockname()[1]

    def _run(self) -> None:
        while not self._stop:
            ready, _, _ = select.select([self.front, self.back], [], [], 0.1)
            for sock in ready:
                data, addr = sock.recvfrom(65535)
                if sock is self.front:
                    self._client = addr
                    if not self.cut:
                        self.back.sendto(data, ("127.0.0.1", self.stub_port))
                elif self._client is not None and not self.cut:
                    self.front.sendto(data, self._client)

    def close(self) -> None:
        self._stop = True
        self._thread.join(timeout=2)
        self.front.close()
        self.back.close()
