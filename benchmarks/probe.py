"""External latency probe: this process plays the vehicle and the camera to a `companion run`
child over UDP loopback, and times each OBSTACLE_DISTANCE_3D it sends until the setpoint that
answers it comes back (two loopback hops plus the daemon). Also the bare loopback round trip
between two Python processes (an echo child), to say how much of that is the wire.

The probe speaks MAVLink through pymavlink alone (like sitl_stub, it does not use companion's
codec); it only borrows companion's demo settings so the daemon runs as it does in a demo.
"""
from __future__ import annotations

import math
import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import yaml

os.environ.setdefault("MAVLINK20", "1")
from pymavlink.dialects.v20 import ardupilotmega as mavlink  # noqa: E402

GUIDED = 4                       # ArduCopter custom mode
CAMERA_COMPONENT = 100
START_TIMEOUT_S = 30.0
REPLY_TIMEOUT_S = 0.25
HEARTBEAT_PERIOD_S = 0.25
STEP_MS = 100                    # vehicle time between odometry samples (10 Hz)
# Two static obstacles in body FRD (forward, right) metres, as the paper's world shows them
# from its start: one ahead, one off to the side. Reports alternate between them.
OBSTACLES_FRD_M = ((1, 30.0, 3.0), (2, 38.0, -6.0))
ECHO_SCRIPT = """
import socket, sys
s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
s.bind(("127.0.0.1", 0))
print(s.getsockname()[1], flush=True)
while True:
    data, addr = s.recvfrom(2048)
    if data == b"stop":
        break
    s.sendto(data, addr)
"""


def percentiles_ms(samples_ns: list[int]) -> dict:
    values = np.asarray(samples_ns, dtype=float) / 1e6
    if not len(values):
        return {"p50": None, "p99": None, "max": None, "samples": 0}
    p50, p99 = np.percentile(values, [50, 99])
    return {"p50": float(p50), "p99": float(p99), "max": float(values.max()),
            "samples": int(len(values))}


def loopback_rtt(samples: int) -> dict:
    """Round trip of a 40-byte datagram to a Python echo process and back, in ms."""
    echo = subprocess.Popen([sys.executable, "-c", ECHO_SCRIPT], stdout=subprocess.PIPE,
                            stdin=subprocess.DEVNULL)
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    try:
        port = int(echo.stdout.readline())
        sock.settimeout(1.0)
        addr = ("127.0.0.1", port)
        payload = bytes(40)
        rtts = []
        for i in range(samples + 50):
            start = time.perf_counter_ns()
            sock.sendto(payload, addr)
            sock.recvfrom(2048)
            if i >= 50:                       # the first ones warm both processes up
                rtts.append(time.perf_counter_ns() - start)
        sock.sendto(b"stop", addr)
        echo.wait(timeout=5)
    finally:
        sock.close()
        if echo.poll() is None:
            echo.kill()
            echo.wait()
    return percentiles_ms(rtts)


class _Packets:
    """pymavlink's send() writes here; we take the bytes and send them ourselves."""

    def __init__(self) -> None:
        self.last = b""

    def write(self, data: bytes) -> None:
        self.last = bytes(data)


class FakeVehicle:
    """A hovering autopilot (system 1, component 1, armed in GUIDED) and its camera."""

    def __init__(self, sock: socket.socket, daemon_addr) -> None:
        self.sock, self.addr = sock, daemon_addr
        self._out = _Packets()
        self._autopilot = mavlink.MAVLink(self._out, srcSystem=1, srcComponent=1)
        self._camera = mavlink.MAVLink(self._out, srcSystem=1, srcComponent=CAMERA_COMPONENT)
        self._parser = mavlink.MAVLink(None)
        self._parser.robust_parsing = True
        self._last_heartbeat_s = -math.inf
        self.t_ms = 1000

    def send(self, mav: mavlink.MAVLink, msg) -> None:
        mav.send(msg)
        self.sock.sendto(self._out.last, self.addr)

    def heartbeats(self) -> None:
        now = time.monotonic()
        if now - self._last_heartbeat_s < HEARTBEAT_PERIOD_S:
            return
        self._last_heartbeat_s = now
        base = (mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED | mavlink.MAV_MODE_FLAG_GUIDED_ENABLED
                | mavlink.MAV_MODE_FLAG_STABILIZE_ENABLED | mavlink.MAV_MODE_FLAG_SAFETY_ARMED)
        self.send(self._autopilot, mavlink.MAVLink_heartbeat_message(
            mavlink.MAV_TYPE_QUADROTOR, mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA, base, GUIDED,
            mavlink.MAV_STATE_ACTIVE, 3))
        self.send(self._camera, mavlink.MAVLink_heartbeat_message(
            mavlink.MAV_TYPE_CAMERA, mavlink.MAV_AUTOPILOT_INVALID, 0, 0,
            mavlink.MAV_STATE_ACTIVE, 3))

    def odometry(self) -> None:
        """ATTITUDE, EXTENDED_SYS_STATE (in the air: the daemon commands only then) and
        LOCAL_POSITION_NED of the same time: hovering 10 m up at (20, 0), facing north."""
        self.t_ms += STEP_MS
        self.send(self._autopilot, mavlink.MAVLink_attitude_message(
            self.t_ms, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0))
        self.send(self._autopilot, mavlink.MAVLink_extended_sys_state_message(
            mavlink.MAV_VTOL_STATE_MC, mavlink.MAV_LANDED_STATE_IN_AIR))
        self.send(self._autopilot, mavlink.MAVLink_local_position_ned_message(
            self.t_ms, 20.0, 0.0, -10.0, 0.0, 0.0, 0.0))

    def obstacle(self, index: int) -> int:
        """One OBSTACLE_DISTANCE_3D at the current time, then the camera's heartbeat; returns the
        report's send time (ns). The daemon holds a camera frame (the reports of one time) until
        a message that is not part of it arrives: the heartbeat closes it at once."""
        oid, forward_m, right_m = OBSTACLES_FRD_M[index % len(OBSTACLES_FRD_M)]
        self._camera.send(mavlink.MAVLink_obstacle_distance_3d_message(
            self.t_ms, mavlink.MAV_DISTANCE_SENSOR_UNKNOWN, mavlink.MAV_FRAME_BODY_FRD, oid,
            forward_m, right_m, 0.0, 0.2, 40.0))
        data = self._out.last
        self._camera.send(mavlink.MAVLink_heartbeat_message(
            mavlink.MAV_TYPE_CAMERA, mavlink.MAV_AUTOPILOT_INVALID, 0, 0,
            mavlink.MAV_STATE_ACTIVE, 3))
        closing = self._out.last
        start = time.perf_counter_ns()
        self.sock.sendto(data, self.addr)
        self.sock.sendto(closing, self.addr)
        return start

    def wait_for_setpoint(self, timeout_s: float = REPLY_TIMEOUT_S) -> int | None:
        """Receive until a SET_POSITION_TARGET_LOCAL_NED stamped with the current time arrives;
        returns its arrival time (ns), or None on timeout. Answers stream requests on the way."""
        deadline = time.monotonic() + timeout_s
        while (left := deadline - time.monotonic()) > 0:
            self.sock.settimeout(left)
            try:
                data = self.sock.recv(4096)
            except TimeoutError:
                return None
            arrived = time.perf_counter_ns()
            for msg in self._parser.parse_buffer(data) or []:
                kind = msg.get_type()
                if kind == "SET_POSITION_TARGET_LOCAL_NED" and msg.time_boot_ms == self.t_ms:
                    return arrived
                if kind == "COMMAND_LONG":
                    self.send(self._autopilot, mavlink.MAVLink_command_ack_message(
                        msg.command, mavlink.MAV_RESULT_ACCEPTED))
        return None


def run_probe(samples: int, workdir: Path, daemon_config: dict) -> dict:
    """Start `companion run` against a FakeVehicle and time ``samples`` obstacle reports.

    Returns the external latencies (ms percentiles) and the daemon's tlog path, so the caller can
    read the daemon's own view of the same reports.
    """
    config_path = workdir / "probe-companion.yaml"
    config_path.write_text(yaml.safe_dump(daemon_config))
    tlog = workdir / "probe.tlog"
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sock.bind(("127.0.0.1", 0))
    port = sock.getsockname()[1]
    with open(workdir / "probe-companion.stderr", "wb") as err:
        daemon = subprocess.Popen(
            [sys.executable, "-m", "companion", "run", "--connect", f"udpout:127.0.0.1:{port}",
             "--config", str(config_path), "--tlog", str(tlog)],
            stdout=subprocess.DEVNULL, stderr=err, stdin=subprocess.DEVNULL)
    latencies, missed = [], 0
    try:
        sock.settimeout(START_TIMEOUT_S)
        _, daemon_addr = sock.recvfrom(4096)          # its first heartbeat
        vehicle = FakeVehicle(sock, daemon_addr)
        warm = 0
        for _ in range(200):                          # until it commands (found, armed, camera)
            vehicle.heartbeats()
            vehicle.odometry()
            if vehicle.wait_for_setpoint(0.05) is not None:
                vehicle.obstacle(warm)
                if vehicle.wait_for_setpoint() is not None:
                    warm += 1
                    if warm >= 20:
                        break
        else:
            raise RuntimeError(f"the probe's daemon never commanded:\n{_tail(workdir)}")
        for i in range(samples):
            vehicle.heartbeats()
            vehicle.odometry()
            vehicle.wait_for_setpoint()               # the odometry's own decision
            sent = vehicle.obstacle(i)
            arrived = vehicle.wait_for_setpoint()
            if arrived is None:
                missed += 1
            else:
                latencies.append(arrived - sent)
    finally:
        sock.close()
        daemon.send_signal(signal.SIGTERM)
        try:
            daemon.wait(timeout=10)
        except subprocess.TimeoutExpired:
            daemon.kill()
            daemon.wait()
    return {"external_ms": percentiles_ms(latencies), "missed": missed, "tlog": str(tlog)}


def _tail(workdir: Path) -> str:
    try:
        return "\n".join((workdir / "probe-companion.stderr").read_text().splitlines()[-10:])
    except OSError:
        return ""
