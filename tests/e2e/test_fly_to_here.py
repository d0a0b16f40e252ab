"""Issue 18: a ground station's "fly to here" mid-flight changes the service's goal (STATUSTEXT
"new goal"); one outside the bounds is refused with a STATUSTEXT saying why. Lock-step.

ArduPilot routes a message addressed to the autopilot (1, 1) to no other link
(MAVLink_routing.cpp; observed with the 4.6 SITL: a SET_POSITION_TARGET_GLOBAL_INT or COMMAND_INT
to 1/1 from SERIAL0 never reaches SERIAL1), so the companion sees a ground station's commands only
where it shares their link. Here the ground station and the companion share a UDP hub in front of
the stub (what a router on the companion computer is to them), which forwards every datagram to
every other peer.
"""
from __future__ import annotations

import json
import math
import os
import select
import socket
import threading
import time

os.environ["MAVLINK20"] = "1"
from pymavlink import mavutil  # noqa: E402

from sitl_stub.world import load_scenario  # noqa: E402
from tests.e2e.support import (PAPER, GroundStation, start_companion, start_stub,  # noqa: E402
                               wait_until, write_config)
from tests.stub.support import read_truth_log  # noqa: E402

FLY_TO_NE_M = (100.0, 40.0)
FIRST_GOAL_NE_M = (300.0, 0.0)


class UdpHub:
    """Every datagram from a peer goes to the stub and to every other peer; the stub's to all.

    ``inject(trigger, packets)``: once a message from the stub satisfies ``trigger``, the
    packets go to the stub and every peer right after it, in the hub's own thread: the flight
    is lock-step at ~100x real time, and a test that watched and reacted would arrive late."""

    def __init__(self, stub_port: int) -> None:
        self.front = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.front.bind(("127.0.0.1", 0))
        self.back = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.back.bind(("127.0.0.1", 0))
        self.stub = ("127.0.0.1", stub_port)
        self.peers: set[tuple] = set()
        self._parser = mavutil.mavlink.MAVLink(None)
        self._trigger = None
        self._packets: list[bytes] = []
        self.injected_after = None
        self._stop = False
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def inject(self, trigger, packets: list[bytes]) -> None:
        self._packets, self._trigger = packets, trigger

    def _maybe_inject(self, data: bytes) -> None:
        if self._trigger is None:
            return
        for msg in self._parser.parse_buffer(data) or []:
            if self._trigger(msg):
                self._trigger, self.injected_after = None, msg
                for packet in self._packets:
                    self.back.sendto(packet, self.stub)
                    for peer in list(self.peers):
                        self.front.sendto(packet, peer)
                return

    @property
    def port(self) -> int:
        return self.front.getsockname()[1]

    def _run(self) -> None:
        while not self._stop:
            ready, _, _ = select.select([self.front, self.back], [], [], 0.1)
            for sock in ready:
                data, addr = sock.recvfrom(65535)
                if sock is self.front:
                    self.peers.add(addr)
                    self.back.sendto(data, self.stub)
                    others = [p for p in self.peers if p != addr]
                else:
                    others = list(self.peers)
                for peer in others:
                    self.front.sendto(data, peer)
                if sock is self.back:
                    self._maybe_inject(data)

    def close(self) -> None:
        self._stop = True
        self._thread.join(timeout=2)
        self.front.close()
        self.back.close()


def statustexts(conn, wanted: list[str], timeout_s: float, until_north_m=None) -> list[str]:
    seen = []
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline and not all(any(w in s for s in seen) for w in wanted):
        msg = conn.recv_match(type="STATUSTEXT", blocking=True, timeout=0.2)
        if msg is not None and msg.get_srcComponent() == 191:
            seen.append(msg.text)
    return seen


def test_fly_to_here_mid_flight_changes_the_goal_and_one_out_of_bounds_is_refused(tmp_path):
    origin = load_scenario(PAPER).world.origin
    truth_path, report = tmp_path / "truth.jsonl", tmp_path / "r.json"
    stub, tcp_port, udp_port = start_stub(tmp_path, "--seed", "5", "--truth-log", str(truth_path),
                                          lockstep=True)
    hub = UdpHub(udp_port)
    processes = [stub]
    try:
        # lock-step flies at ~100x: the urgency notices of seconds of flight come within one wall
        # second, and the limiter (2 a second) would keep the refusal from the ground station
        config = write_config(tmp_path, goal=FIRST_GOAL_NE_M, safety={"statustext_per_s": 50})
        companion = start_companion(tmp_path, f"udpout:127.0.0.1:{hub.port}", config,
                                    "--report", str(report), lockstep=True)
        processes.append(companion)
        wait_until(lambda: report.exists(), 30.0, "the daemon's estimator")
        shared = mavutil.mavlink_connection(f"udpout:127.0.0.1:{hub.port}", source_system=255,
                                            source_component=190)
        shared.mav.heartbeat_send(mavutil.mavlink.MAV_TYPE_GCS, 8, 0, 0, 4)
        # the ground station's two requests, as it would send them on the shared link
        encoder = mavutil.mavlink.MAVLink(None, srcSystem=255, srcComponent=190)
        lat, lon = origin.to_lat_lon_deg(*FLY_TO_NE_M)
        far_lat, far_lon = origin.to_lat_lon_deg(5000.0, 0.0)
        frame = mavutil.mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT
        packets = [
            encoder.set_position_target_global_int_encode(
                0, 1, 1, frame, 0x0FF8, int(round(lat * 1e7)), int(round(lon * 1e7)), 10.0,
                0, 0, 0, 0, 0, 0, 0, 0).pack(encoder),
            encoder.command_int_encode(
                1, 1, frame, mavutil.mavlink.MAV_CMD_DO_REPOSITION, 0, 0, -1, 0, 0, 0,
                int(round(far_lat * 1e7)), int(round(far_lon * 1e7)), 10.0).pack(encoder)]
        # mid-flight: 45 m north, past obstacle 1, on the way to (300, 0)
        hub.inject(lambda m: m.get_type() == "LOCAL_POSITION_NED" and m.x > 45.0, packets)
        gcs = GroundStation(tcp_port)
        gcs.fly_from_the_ground()
        texts = statustexts(shared, ["new goal", "goal refused"], 60.0)
        wait_until(lambda: json.loads(report.read_text()).get("arrived"), 120.0,
                   "arrival at the new goal")
        gcs.close()
        shared.close()
    finally:
        for process in reversed(processes):
            if process.proc.poll() is None:
                process.stop()
        hub.close()
    assert hub.injected_after is not None and hub.injected_after.z < -5.0   # airborne
    assert "companion: new goal N 100 E 40 m" in texts, texts
    refused = [t for t in texts if "goal refused" in t]
    assert refused and "5000 m from origin > 1000" in refused[0], texts
    result = json.loads(report.read_text())
    assert math.hypot(result["goal_ne_m"][0] - 100.0, result["goal_ne_m"][1] - 40.0) < 0.05
    assert result["counters"].get("goal_refused") == 1
    truth = [r for r in read_truth_log(truth_path) if r["armed"]]
    arrival = min(truth, key=lambda r: abs(r["t_s"] - result["arrival_t_s"]))
    assert math.hypot(arrival["north_m"] - 100.0, arrival["east_m"] - 40.0) <= 2.0 + 2.0
    assert max(r["north_m"] for r in truth) < 150.0             # the first goal was given up
    flying = [r for r in truth if r["t_s"] <= result["arrival_t_s"] and r["up_m"] > 5.0]
    assert min(math.hypot(r["north_m"] - o["north_m"], r["east_m"] - o["east_m"])
               for r in flying for o in r["obstacles"]) >= 9.5
