"""``companion demo --px4 DIR``: the demo flown by PX4's own SITL with its SIH simulator.

DIR is a PX4 SITL build (a folder holding ``bin/px4`` and ``etc/``, e.g. PX4-Autopilot's
build/px4_sitl_default), built by the user outside this repository. Processes, each started here
and stopped by its own handle:

  px4                        SIH quadrotor (airframe 10040 sihsim_quadx), instance 0, home at
                             the scenario's start (PX4_HOME_LAT/LON/ALT), in WORKDIR/px4
  sitl-stub --camera-only    the stub's camera as component 100
  companion run              the service, up from boot

PX4 instance 0 sends its normal-mode MAVLink to UDP 14550 (this process: the ground station,
companion/tools/px4_gcs.py) and its onboard-mode MAVLink to UDP 14540, where a router here
(``Router``, as mavlink-router on a companion computer) passes every datagram between PX4, the
service and the camera. The service and the camera find the scenario frame as in the ArduPilot
demo: the goal as latitude/longitude, the camera by GPS_GLOBAL_ORIGIN.

Truth: HIL_STATE_QUATERNION, which PX4's SITL fills from its ground-truth topics (the simulated
vehicle, not EKF2's estimate), asked for on the ground station's link.
"""
from __future__ import annotations

import asyncio
import json
import logging
import math
import os
import signal
import sys
from dataclasses import dataclass
from pathlib import Path

import yaml

from companion.config.scenario import Scenario
from companion.config.service import config_to_dict
from companion.core.flat_earth import to_lat_lon_deg, to_north_east_m
from companion.mavlink import codec, px4_modes
from companion.mavlink.link import open_link
from companion.tools import px4_gcs
from companion.tools.autopilot_demo import (in_scenario_frame, service_config, spawn_in,
                                            wait_for_camera_port)
from companion.tools.child_lifetime import die_with_parent_hook
from companion.tools.demo import GCS_SYSTEM_ID, Child, DemoError, DemoFiles, wait_for
from companion.tools.demo_scoring import read_report, read_truth
from companion.tools.flight_record import companion_setpoints, takeoff_checks

log = logging.getLogger(__name__)

LOOPBACK = "127.0.0.1"
GCS_PORT, ONBOARD_PORT = 14550, 14540        # PX4 SITL instance 0's remote ports
MSG_ID_HIL_STATE_QUATERNION = 115
TRUTH_RATE_HZ = 10.0
BOOT_BUDGET_S = 180.0          # PX4 boot to armable (about 35 s with SIH), wall
SIH_QUADX = "10040"
RESTART_AFTER_S = 3.0          # vehicle seconds held before the new service starts


def check_dir(directory: Path) -> None:
    if not (directory / "bin" / "px4").is_file() or not (directory / "etc").is_dir():
        raise DemoError(f"--px4 {directory}: expected a PX4 SITL build (bin/px4 and etc/), "
                        "e.g. PX4-Autopilot/build/px4_sitl_default")


@dataclass(frozen=True)
class Px4Files(DemoFiles):
    @property
    def px4_dir(self) -> Path:
        return self.workdir / "px4"


class Router(asyncio.DatagramProtocol):
    """Every datagram from one peer to all the others (PX4's onboard port, the service, the
    camera), as mavlink-router does."""

    def __init__(self, fixed: list[tuple[str, int]]) -> None:
        self.peers = set(fixed)
        self.transport = None

    def connection_made(self, transport) -> None:
        self.transport = transport

    def datagram_received(self, data: bytes, addr) -> None:
        self.peers.add(addr)
        for peer in self.peers:
            if peer != addr:
                self.transport.sendto(data, peer)


class Truth:
    """HIL_STATE_QUATERNION (PX4's ground truth) as the stub demo's truth records."""

    def __init__(self, path: Path, scenario: Scenario, view: px4_gcs.Px4View) -> None:
        self.file = open(path, "w", encoding="utf-8")
        self.scenario, self.view = scenario, view
        self.origin_ne_m: tuple[float, float] | None = None
        self.landed_state: int | None = None
        self.north_m: float | None = None
        self.speed_mps = 0.0

    def on_message(self, msg) -> None:
        origin = self.scenario.world.origin
        kind = msg.get_type()
        if kind == "EXTENDED_SYS_STATE":
            self.landed_state = int(msg.landed_state)
        elif kind == "GPS_GLOBAL_ORIGIN":
            self.origin_ne_m = to_north_east_m(origin.lat_deg, origin.lon_deg, msg.latitude / 1e7,
                                               msg.longitude / 1e7)
        elif kind == "HIL_STATE_QUATERNION" and self.view.t_s is not None:
            north, east = to_north_east_m(origin.lat_deg, origin.lon_deg, msg.lat / 1e7,
                                          msg.lon / 1e7)
            self.north_m, self.speed_mps = north, math.hypot(msg.vx, msg.vy) / 100.0
            w, x, y, z = msg.attitude_quaternion
            yaw = math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))
            obstacles = [{"id": ob.id, "north_m": ob.north_m, "east_m": ob.east_m,
                          "radius_m": ob.radius_m} for ob in self.scenario.world.obstacles]
            mode = self.view.custom_mode
            self.file.write(json.dumps({
                "t_s": self.view.t_s, "north_m": north, "east_m": east, "yaw_rad": yaw,
                "speed_mps": math.hypot(msg.vx, msg.vy) / 100.0, "armed": self.view.armed,
                "mode": px4_modes.mode_name(mode) if mode is not None else None,
                "alt_m": msg.alt / 1000.0 - origin.alt_m, "landed_state": self.landed_state,
                "obstacles": obstacles}) + "\n")

    def close(self) -> None:
        self.file.close()


def px4_command(directory: Path, workdir: Path) -> tuple[list[str], dict]:
    env = dict(os.environ, PX4_SYS_AUTOSTART=SIH_QUADX, PX4_SIM_MODEL="sihsim_quadx",
               PX4_SIMULATOR="sihsim")
    return [str(directory / "bin" / "px4"), "-i", "0", "-d", "-w", str(workdir),
            str(directory / "etc")], env


async def run_px4_demo(scenario_path: Path, scenario: Scenario, files: Px4Files, directory: Path,
                       seed: int, offboard: str, takeoff_alt_m: float = 10.0,
                       kill_at_north_m: float | None = None) -> tuple[dict, list[dict], dict]:
    """Fly the scenario on PX4 SITL (SIH); returns (the service's report in the scenario frame,
    the truth records, the flight's facts). ``kill_at_north_m``: SIGKILL the service once the
    true position passes this north (scenario frame), let PX4's offboard-loss fallback
    (COM_OBL_RC_ACT 5, Hold, set here as docs/real-vehicle.md says) hold the vehicle, and start
    a new service (``restart``)."""
    check_dir(directory)
    config = px4_gcs.with_offboard(service_config(scenario, takeoff_alt_m, shaped=False),
                                   offboard)
    files.config.write_text(yaml.safe_dump(config_to_dict(config)))
    files.px4_dir.mkdir(parents=True, exist_ok=True)
    origin, start = scenario.world.origin, scenario.world.start
    home_lat, home_lon = to_lat_lon_deg(origin.lat_deg, origin.lon_deg, start.north_m,
                                        start.east_m)
    children: list[Child] = []
    here = Path.cwd()          # the children import this checkout's packages, as the stub demo's
    view = px4_gcs.Px4View()
    truth = Truth(files.truth, scenario, view)
    loop = asyncio.get_running_loop()
    service_port = ONBOARD_PORT + 1000
    router_transport, router = await loop.create_datagram_endpoint(
        lambda: Router([(LOOPBACK, service_port)]), local_addr=(LOOPBACK, ONBOARD_PORT))
    try:
        camera = await spawn_in("camera", [
            sys.executable, "-m", "sitl_stub", "--camera-only", "--scenario",
            str(Path(scenario_path).resolve()), "--connect", f"udpin:{LOOPBACK}:0",
            "--seed", str(seed)], here, files.workdir, stdout=asyncio.subprocess.PIPE)
        children.append(camera)
        router.peers.add((LOOPBACK, await wait_for_camera_port(camera)))   # it speaks second
        async def start_service(name: str = "companion") -> Child:
            return await spawn_in(name, [
                sys.executable, "-m", "companion", "-v", "run", "--connect",
                f"udpin:{LOOPBACK}:{service_port}", "--config", str(files.config),
                "--report", str(files.report), "--tlog", str(files.workdir / f"{name}.tlog")],
                here, files.workdir)

        children.append(await start_service())
        command, env = px4_command(directory, files.px4_dir)
        env.update(PX4_HOME_LAT=f"{home_lat:.7f}", PX4_HOME_LON=f"{home_lon:.7f}",
                   PX4_HOME_ALT=f"{origin.alt_m:.2f}")
        log.info("starting PX4 SITL (SIH): %s", " ".join(command))
        proc = await asyncio.create_subprocess_exec(
            *command, cwd=files.px4_dir, env=env, stdin=asyncio.subprocess.DEVNULL,
            stdout=open(files.workdir / "px4.stderr", "wb"), stderr=asyncio.subprocess.STDOUT,
            preexec_fn=die_with_parent_hook())        # no PX4 left running if we die
        children.append(Child("px4", proc, files.workdir / "px4.stderr"))
        encoder = codec.Encoder(GCS_SYSTEM_ID, codec.MAV_COMP_ID_MISSIONPLANNER)
        async with open_link(f"udpin:{LOOPBACK}:{GCS_PORT}", encoder) as link:
            async with asyncio.TaskGroup() as tg:
                tasks = [tg.create_task(link.run(), name="gcs-link"),
                         tg.create_task(watch(link, view, truth), name="gcs-watch")]
                try:
                    facts = await fly(link, view, files, scenario, children, offboard,
                                      takeoff_alt_m, truth, kill_at_north_m, start_service)
                finally:
                    for task in tasks:
                        task.cancel()
    finally:
        router_transport.close()
        codes = await asyncio.shield(asyncio.gather(*(c.stop() for c in reversed(children))))
        for child, code in zip(reversed(children), codes):
            if code not in (0, -signal.SIGTERM):
                log.warning("%s exited with %s", child.name, code)
        truth.close()
    report = read_report(files.report)
    if report is None or truth.origin_ne_m is None:
        raise DemoError("no report or no EKF origin: see the work directory's logs")
    facts["truth"] = "HIL_STATE_QUATERNION (PX4 SITL's ground truth)"
    facts["ekf_origin_ne_m"] = list(truth.origin_ne_m)
    facts.update(px4_gcs.offboard_facts(view, report, None))
    rows = read_truth(files.truth)
    # setpoints on the ground, by the ground station's view and the service's (flight_record.py)
    facts.update(takeoff_checks(companion_setpoints(files.workdir / "companion.tlog",
                                                    config.link.component_id), rows,
                                report.get("arrival_t_s")))
    return in_scenario_frame(report, truth.origin_ne_m), rows, facts


async def watch(link, view: px4_gcs.Px4View, truth: Truth) -> None:
    while True:
        msg = (await link.inbox.get()).msg
        view.on_message(msg, asyncio.get_running_loop().time())
        truth.on_message(msg)


async def fly(link, view: px4_gcs.Px4View, files: Px4Files, scenario: Scenario,
              children: list[Child], offboard: str, takeoff_alt_m: float, truth: Truth,
              kill_at_north_m: float | None, start_service) -> dict:
    def check() -> None:
        for child in children:
            child.check_alive()

    await wait_for(lambda: view.t_s is not None, "PX4's telemetry", 60.0, children)
    link.send(codec.set_message_interval(1, 1, MSG_ID_HIL_STATE_QUATERNION, TRUTH_RATE_HZ))
    link.send(codec.request_message(1, 1, 49))            # GPS_GLOBAL_ORIGIN
    await wait_for(lambda: read_report(files.report), "the service's estimator", 60.0, children)
    for _ in range(3):                  # offboard loss: Hold (docs/real-vehicle.md section 8)
        link.send(px4_modes.param_set_int(1, 1, "COM_OBL_RC_ACT", 5))
    try:
        facts = await px4_gcs.fly_to_offboard(link, view, takeoff_alt_m, offboard, check,
                                              BOOT_BUDGET_S)
    except TimeoutError:
        raise DemoError(f"PX4 workflow stalled (modes seen: {view.modes})") from None
    link.send(codec.request_message(1, 1, 49))
    if kill_at_north_m is not None:
        facts.update(await kill_and_restart(view, truth, children, kill_at_north_m,
                                            start_service))
    await wait_for(lambda: (r := read_report(files.report)) and r.get("arrived") and r,
                   "the service to report arrival", scenario.mission.max_time_s + 60.0, children)
    return facts


async def kill_and_restart(view: px4_gcs.Px4View, truth: Truth, children: list[Child],
                           north_m: float, start_service) -> dict:
    """SIGKILL the service past ``north_m``; PX4 holds after COM_OF_LOSS_T; a new service after
    RESTART_AFTER_S of the vehicle held; OFFBOARD again once its stream flows (OFFBOARD is still
    the user's mode during the fallback)."""
    await wait_for(lambda: truth.north_m is not None and truth.north_m >= north_m,
                   f"the vehicle past north {north_m} m", 120.0, children)
    service = next(c for c in children if c.name == "companion")
    service.proc.kill()
    await service.proc.wait()
    children.remove(service)
    killed = {"killed_t_s": view.t_s, "killed_north_m": truth.north_m,
              "killed_speed_mps": truth.speed_mps}
    await wait_for(lambda: view.custom_mode not in (None, px4_modes.OFFBOARD),
                   "PX4's offboard-loss fallback", 30.0, children)
    fallback = px4_modes.mode_name(view.custom_mode)
    fallback_t_s = view.t_s
    await wait_for(lambda: truth.speed_mps < 0.2, "the vehicle held", 30.0, children)
    held_t_s = view.t_s
    await wait_for(lambda: view.t_s >= held_t_s + RESTART_AFTER_S, "the restart delay", 30.0,
                   children)
    children.append(await start_service("companion-restarted"))
    restarted_t_s = view.t_s
    await wait_for(lambda: view.custom_mode == px4_modes.OFFBOARD, "OFFBOARD again", 90.0,
                   children)
    return {**killed, "fallback": fallback, "fallback_t_s": fallback_t_s,
            "held_t_s": held_t_s, "restarted_t_s": restarted_t_s, "offboard_again_t_s": view.t_s}
