"""``companion demo --autopilot PATH``: the demo flown by ArduPilot's own SITL instead of the stub.

Processes, each started here, bounded in time and stopped by its own handle (SIGTERM, then
SIGKILL):

  arducopter                 the autopilot, in a fresh working directory, instance -I chosen free,
                             its SERIAL0-2 as UDP to loopback ports (ardupilot_sitl.py)
  sitl-stub --camera-only    the stub's camera as component 100, on SERIAL2
  companion run              the service on SERIAL1, up from boot (docs/real-vehicle.md's
                             workflow: take off in GUIDED with the service running)

and this process, the ground station on SERIAL0: it asks for its telemetry, waits for the EKF
(EKF_STATUS_REPORT can fly GUIDED, GPS_GLOBAL_ORIGIN known) and for the camera and the
service, sets GUIDED, arms (retrying through "PreArm: ..." refusals), sends NAV_TAKEOFF to
the configured altitude and leaves the flight to the service until it reports arrival.

Frames. The scenario has its own LOCAL_NED frame about world.origin. SITL's home is put at the
scenario's start, and ArduPilot sets the EKF origin where the vehicle gets its first GPS fix
(there). The service gets the goal as latitude/longitude and turns it into metres from that
origin itself; the camera places the scenario by the GPS_GLOBAL_ORIGIN it receives, and
scoring moves the service's track back by the origin the ground station receives (which must
lie within ORIGIN_TOLERANCE_M of the start, or the vehicle did not start where the scenario
says).

Truth: SITL's SIMSTATE, the simulated vehicle itself (not the EKF's estimate); see
flight_record.py.

Why over 400 lines: the four processes' start, the ground station's script and the kill-and-
restart variant are one sequence with one set of handles to stop; the SITL process itself, the
scoring and the files are already apart (ardupilot_sitl.py, demo_scoring.py, demo.py).
"""
from __future__ import annotations

import asyncio
import dataclasses
import json
import logging
import math
import signal
import sys
from dataclasses import dataclass
from pathlib import Path

import yaml

from companion.tools import ardupilot_sitl as sitl
from companion.mavlink import dialect
from companion.mavlink import codec, gcs_codec
from companion.mavlink.link import open_link
from companion.tools.child_lifetime import die_with_parent_hook
from companion.config.scenario import Scenario
from companion.config.service import config_to_dict, GoalConfig, load_config
from companion.core.flat_earth import to_lat_lon_deg
from companion.tools.demo import GCS_SYSTEM_ID, Child, DemoError, DemoFiles, demo_config, wait_for
from companion.tools.demo_scoring import read_report, read_truth
from companion.tools.flight_record import FlightRecorder, companion_setpoints, takeoff_checks
from companion.config.paths import resolve_config

log = logging.getLogger(__name__)

TELEMETRY_RATE_HZ = 10.0
GCS_STREAMS = (dialect.MSG_ID_ATTITUDE, dialect.MSG_ID_SIMSTATE,
               dialect.MSG_ID_GLOBAL_POSITION_INT, dialect.MSG_ID_LOCAL_POSITION_NED,
               dialect.MSG_ID_EXTENDED_SYS_STATE, dialect.MSG_ID_EKF_STATUS_REPORT)
# Budgets in the autopilot's seconds (divided by the speedup, plus a wall margin for start-up).
EKF_BUDGET_S = 120.0          # boot to a GUIDED-capable EKF: about 42 s with this binary
ARM_BUDGET_S = 60.0           # PreArm refusals after the EKF is ready
RESTART_BUDGET_S = 90.0
CLIMB_BUDGET_S = 60.0
WALL_MARGIN_S = 20.0
READY_TIMEOUT_S = 30.0
COMMAND_RETRY_S = 0.5
ORIGIN_REQUEST_S = 1.0
SETTLE_SPEED_MPS = 0.3
SETTLE_TIMEOUT_S = 5.0
ORIGIN_TOLERANCE_M = 1.0
ALTITUDE_REACHED = 0.95


@dataclass(frozen=True)
class AutopilotSetup:
    binary: Path
    defaults: Path
    takeoff_alt_m: float = 10.0
    service_start: str = "boot"     # boot (the docs' workflow) | airborne (started at altitude)
    base_config: str | Path = "config/companion.yaml"   # the settings the scenario's go over
    # Crash and restart (issue 31): SIGKILL the service once the true position passes this
    # north (scenario frame), wait for ArduCopter's GUIDED timeout to stop the vehicle and
    # ``restart_after_s`` of vehicle time more, start a new service (its tlog PATH.restarted);
    # what happened goes to WORKDIR/crash.json
    kill_at_north_m: float | None = None
    restart_after_s: float = 3.0
    shaped: bool = True         # roll-outs as ArduCopter flies setpoints (service_config)


@dataclass(frozen=True)
class AutopilotFiles(DemoFiles):
    """The stub demo's files (truth log, report, config; tlog always kept here), and SITL's."""

    @property
    def sitl_dir(self) -> Path:
        return self.workdir / "sitl"

    @property
    def status_texts(self) -> Path:
        return self.workdir / "autopilot-statustext.txt"


def sitl_home(scenario: Scenario) -> sitl.Home:
    origin, start = scenario.world.origin, scenario.world.start
    lat, lon = to_lat_lon_deg(origin.lat_deg, origin.lon_deg, start.north_m, start.east_m)
    return sitl.Home(lat, lon, origin.alt_m, start.yaw_deg % 360.0)


# ArduCopter 4.6's velocity response (AC_PosControl shape_vel_accel_xy: the acceleration changes
# at PSC_JERK_XY 5 m/s^3 by default) and the lead that makes up its ~0.3 s yaw lag (README,
# issue 27; tests/core/test_ardupilot_response.py replays a recorded flight with them).
ARDUCOPTER_JERK_MPS3 = 5.0
ARDUCOPTER_YAW_LEAD_S = 0.5


def service_config(scenario: Scenario, takeoff_alt_m: float,
                   base_config: str | Path = "config/companion.yaml", shaped: bool = True):
    """The stub demo's service settings, with the goal as latitude/longitude (the service turns
    it into metres with the EKF origin it asks the autopilot for, as an operator's geo goal) and
    the takeoff altitude the ground station will send. ``shaped`` False: the roll-outs and yaw
    of the stub demo (no jerk limit, no yaw lead), whatever the base says."""
    config = demo_config(scenario, base_config, keep_shaping=shaped)
    commanding = config.commanding
    if shaped:
        # ArduCopter's response, where the base leaves it null (README, issue 27: the ceiling
        # flight at x10, 8.71 m unshaped, 11.47 m shaped)
        commanding = dataclasses.replace(
            commanding,
            max_jerk_mps3=ARDUCOPTER_JERK_MPS3 if commanding.max_jerk_mps3 is None
            else commanding.max_jerk_mps3,
            yaw_lead_s=ARDUCOPTER_YAW_LEAD_S if commanding.yaw_lead_s is None
            else commanding.yaw_lead_s)
    config = dataclasses.replace(config, commanding=commanding,
                                 estimator=vehicle_noise_of_the_autopilot(config.estimator))
    origin, goal = scenario.world.origin, scenario.world.goal
    lat_deg, lon_deg = to_lat_lon_deg(origin.lat_deg, origin.lon_deg, goal.north_m, goal.east_m)
    return dataclasses.replace(
        config, goal=GoalConfig(radius_m=goal.radius_m, lat_deg=lat_deg, lon_deg=lon_deg),
        flight=dataclasses.replace(config.flight, takeoff_alt_m=takeoff_alt_m))


# What the filter is told of the vehicle's own odometry comes from the real-vehicle config, not
# from the scenario: the scenario's noise section is the stub's truth, but here ArduCopter's EKF
# makes the velocity and the yaw. (Measured on the paper flight: ATTITUDE yaw 1.3 deg off SITL's
# SIMSTATE throughout, while the scenario's 0.5 deg compass noise let the filter's yaw sigma settle
# at 0.15 deg: NEES 88, in band 16%.) The camera is still the stub's, so its R stays the scenario's.
VEHICLE_NOISE_KEYS = ("vel_north_sigma_mps", "vel_east_sigma_mps", "yaw_rate_sigma_deg_s",
                      "yaw_sigma_deg", "yaw_bias_sigma_deg", "yaw_bias_tau_s",
                      "initial_yaw_sigma_deg")


def vehicle_noise_of_the_autopilot(estimator, base_path: str = "config/companion.yaml"):
    base = load_config(resolve_config(base_path)).estimator
    return dataclasses.replace(estimator, **{k: getattr(base, k) for k in VEHICLE_NOISE_KEYS})


async def spawn_in(name: str, args: list[str], cwd: Path, log_dir: Path,
                   stdout=asyncio.subprocess.DEVNULL) -> Child:
    """A child in ``cwd`` whose stderr goes to LOG_DIR/NAME.stderr (stdout too, if "merge")."""
    stderr_path = log_dir / f"{name}.stderr"
    with open(stderr_path, "wb") as err:
        proc = await asyncio.create_subprocess_exec(
            *args, stdout=err if stdout == "merge" else stdout, stderr=err, cwd=cwd,
            stdin=asyncio.subprocess.DEVNULL,
            # SIGTERM when the demo dies, even by SIGKILL or a test's timeout: no SITL left
            # running at ten times real time with nobody to stop it
            preexec_fn=die_with_parent_hook())
    return Child(name, proc, stderr_path)


async def wait_for_camera_port(camera: Child) -> int:
    try:
        async with asyncio.timeout(READY_TIMEOUT_S):
            while line := await camera.proc.stdout.readline():
                text = line.decode(errors="replace").strip()
                if text.startswith("SITL_STUB CAMERA READY"):
                    return int(text.rpartition(":")[2])
    except TimeoutError:
        pass
    raise DemoError(f"the camera did not come up:\n{camera.stderr_tail()}")


class GroundStation:
    """SERIAL0: the recorder's inbox, acknowledged commands, our heartbeat."""

    def __init__(self, link, recorder: FlightRecorder, children: list[Child]) -> None:
        self.link, self.recorder, self.children = link, recorder, children
        self.acks: asyncio.Queue[codec.CommandAck] = asyncio.Queue(maxsize=64)

    async def receive(self) -> None:
        while True:
            ack = self.recorder.on_message((await self.link.inbox.get()).msg)
            if ack is not None and not self.acks.full():
                self.acks.put_nowait(ack)

    async def heartbeats(self) -> None:
        while True:
            self.link.send(codec.gcs_heartbeat())
            await asyncio.sleep(1.0)

    async def command(self, factory, answers, name: str, timeout_s: float) -> None:
        """Send until accepted; refusals are retried (their reason comes as STATUSTEXT)."""
        try:
            async with asyncio.timeout(timeout_s):
                while True:
                    for child in self.children:
                        child.check_alive()
                    while not self.acks.empty():
                        self.acks.get_nowait()
                    self.link.send(factory())
                    if await self._answer(answers, name):
                        return
        except TimeoutError:
            texts = "\n".join(self.recorder.state.status_texts[-5:])
            raise DemoError(f"the autopilot did not accept {name} within {timeout_s:.0f} s; "
                            f"its last messages:\n{texts}") from None

    async def _answer(self, answers, name: str) -> bool:
        try:
            async with asyncio.timeout(COMMAND_RETRY_S):
                while True:
                    ack = await self.acks.get()
                    if answers(ack):
                        if not ack.accepted:
                            log.info("%s refused (result %d): retrying", name, ack.result)
                            await asyncio.sleep(COMMAND_RETRY_S)
                        return ack.accepted
        except TimeoutError:
            return False

    async def request_streams(self) -> None:
        sysid, compid = self.recorder.state.vehicle
        for msg_id in GCS_STREAMS:
            await self.command(lambda m=msg_id: codec.set_message_interval(
                sysid, compid, m, TELEMETRY_RATE_HZ), codec.is_set_message_interval_ack,
                f"SET_MESSAGE_INTERVAL {msg_id}", READY_TIMEOUT_S)


async def fly(gcs: GroundStation, files: AutopilotFiles, scenario: Scenario, speedup: float,
              setup: AutopilotSetup, start_service) -> dict:
    """The ground station's part, from the first heartbeat to the service's arrival."""
    state, children = gcs.recorder.state, gcs.children
    budget = lambda sim_s: sim_s / speedup + WALL_MARGIN_S  # noqa: E731
    await wait_for(lambda: state.vehicle, "the autopilot's heartbeat", READY_TIMEOUT_S, children)
    await gcs.request_streams()
    sysid, compid = state.vehicle
    last_origin_request = [-math.inf]

    def ekf_ready() -> bool:
        now = asyncio.get_running_loop().time()
        if state.origin_ne_m is None and now - last_origin_request[0] > ORIGIN_REQUEST_S:
            last_origin_request[0] = now
            gcs.link.send(codec.request_message(sysid, compid,
                                                    dialect.MSG_ID_GPS_GLOBAL_ORIGIN))
        return state.ekf_ready and state.origin_ne_m is not None and state.local is not None

    await wait_for(ekf_ready, "the EKF (EKF_STATUS_REPORT, GPS_GLOBAL_ORIGIN)",
                   budget(EKF_BUDGET_S), children)
    start = scenario.world.start
    offset_m = math.hypot(state.origin_ne_m[0] - start.north_m, state.origin_ne_m[1] - start.east_m)
    if offset_m > ORIGIN_TOLERANCE_M:
        raise DemoError(f"the EKF origin is {offset_m:.1f} m from the scenario's start (SITL's "
                        "home): the vehicle did not start where the scenario says")
    log.info("EKF ready at %.1f s; origin at north %.2f m, east %.2f m of the scenario frame",
             state.t_s, *state.origin_ne_m)
    if setup.service_start == "boot":
        await wait_for(lambda: read_report(files.report), "the service's estimator",
                       READY_TIMEOUT_S, children)
    await wait_for(lambda: state.camera_seen, "the camera's heartbeat", READY_TIMEOUT_S, children)
    guided = gcs.recorder.guided_custom_mode
    await gcs.command(lambda: codec.set_mode(sysid, compid, guided),
                      lambda ack: codec.is_ack_for(ack, "set_mode"), "GUIDED", READY_TIMEOUT_S)
    await gcs.command(lambda: codec.arm(sysid, compid), lambda ack: codec.is_ack_for(ack, "arm"),
                      "arming", budget(ARM_BUDGET_S))
    await gcs.command(lambda: codec.takeoff(sysid, compid, setup.takeoff_alt_m),
                      lambda ack: codec.is_ack_for(ack, "takeoff"), "NAV_TAKEOFF", READY_TIMEOUT_S)
    log.info("armed in GUIDED at %.1f s, taking off to %.1f m", state.t_s, setup.takeoff_alt_m)
    if setup.service_start == "airborne":
        await wait_for(lambda: _not_disarmed(state) and (state.relative_alt_m or 0.0)
                       >= ALTITUDE_REACHED * setup.takeoff_alt_m,
                       "the takeoff altitude", budget(CLIMB_BUDGET_S), children)
        children.append(await start_service())
    if setup.kill_at_north_m is not None:
        await kill_and_restart(gcs, files, setup, start_service, budget)
    flight_s = scenario.mission.max_time_s + CLIMB_BUDGET_S
    if setup.kill_at_north_m is not None:
        # the new process's start (its interpreter under load: tens of s of vehicle time at x10)
        # and its look round before flying on (restart.look_around, up to its look_timeout_s)
        flight_s += RESTART_BUDGET_S
    report = await wait_for(
        lambda: _not_disarmed(state) and (r := read_report(files.report)) and r.get("arrived")
        and r, "the service to report arrival", budget(flight_s), children)
    await _settle(state)
    return report


STOPPED_SPEED_MPS = 0.1


async def kill_and_restart(gcs: GroundStation, files: AutopilotFiles, setup: AutopilotSetup,
                           start_service, budget) -> None:
    """SIGKILL the service past ``setup.kill_at_north_m``, let the GUIDED timeout stop the
    vehicle, start a new service; the times to WORKDIR/crash.json."""
    state, children = gcs.recorder.state, gcs.children
    await wait_for(lambda: _not_disarmed(state) and state.north_m is not None
                   and state.north_m >= setup.kill_at_north_m,
                   f"the vehicle past north {setup.kill_at_north_m} m", budget(120.0), children)
    service = next(c for c in children if c.name == "companion")
    service.proc.kill()
    await service.proc.wait()
    children.remove(service)
    killed = {"killed_t_s": state.t_s, "killed_north_m": state.north_m,
              "killed_speed_mps": state.speed_mps}
    log.info("service killed (SIGKILL) at %.1f s, north %.1f m", state.t_s, state.north_m)
    await wait_for(lambda: _not_disarmed(state) and state.t_s > killed["killed_t_s"] + 3.0
                   and state.speed_mps < STOPPED_SPEED_MPS,
                   "the vehicle stopped by the GUIDED timeout", budget(60.0), children)
    stopped_t_s = state.t_s
    await wait_for(lambda: state.t_s >= stopped_t_s + setup.restart_after_s,
                   "the restart delay", budget(30.0), children)
    restarted_t_s = state.t_s
    children.append(await start_service(tlog=files.tlog.with_name(files.tlog.name + ".restarted"),
                                        name="companion-restarted"))
    log.info("service restarted at %.1f s", restarted_t_s)
    (files.workdir / "crash.json").write_text(json.dumps(
        {**killed, "stopped_t_s": stopped_t_s, "restarted_t_s": restarted_t_s}))


def _not_disarmed(state) -> bool:
    if state.disarmed_t_s is not None:
        texts = "\n".join(state.status_texts[-5:])
        raise DemoError(f"the vehicle disarmed at {state.disarmed_t_s:.1f} s (armed at "
                        f"{state.armed_t_s:.1f} s, {state.relative_alt_m or 0.0:.1f} m above home) "
                        "before the service arrived (ArduCopter disarms a vehicle left on the "
                        "ground for DISARM_DELAY, as when a velocity setpoint replaces its "
                        f"takeoff); the autopilot's last messages:\n{texts}")
    return True


async def _settle(state) -> None:
    try:
        async with asyncio.timeout(SETTLE_TIMEOUT_S):
            while state.speed_mps > SETTLE_SPEED_MPS:
                await asyncio.sleep(0.05)
    except TimeoutError:
        log.info("vehicle still moving %.0f s after arrival; scoring anyway", SETTLE_TIMEOUT_S)


async def run_autopilot_demo(scenario_path: Path, scenario: Scenario, files: AutopilotFiles,
                             speedup: float, seed: int,
                             setup: AutopilotSetup) -> tuple[dict, dict, list[dict], dict]:
    """Fly the scenario on ArduPilot SITL; returns (the service's report moved into the scenario
    frame, its config, the truth records, the takeoff checks)."""
    sitl.check_files(setup.binary, setup.defaults)
    config = service_config(scenario, setup.takeoff_alt_m, setup.base_config, setup.shaped)
    files.config.write_text(yaml.safe_dump(config_to_dict(config)))
    files.sitl_dir.mkdir(parents=True, exist_ok=False)
    recorder = FlightRecorder(files.truth, scenario, config.link.camera_component_id,
                              config.link.guided_custom_mode)
    children: list[Child] = []
    companion_port = sitl.free_udp_port()

    async def start_service(tlog: Path | None = None, name: str = "companion") -> Child:
        return await spawn_in(name, [
            sys.executable, "-m", "companion", "-v", "run",
            "--connect", f"udpin:{sitl.LOOPBACK}:{companion_port}", "--config", str(files.config),
            "--report", str(files.report), "--tlog", str(tlog or files.tlog)], files.workdir,
            files.workdir)

    try:
        camera = await spawn_in("camera", [
            sys.executable, "-m", "sitl_stub", "--camera-only", "--scenario",
            str(Path(scenario_path).resolve()),
            "--connect", f"udpin:{sitl.LOOPBACK}:0", "--seed", str(seed)],
            files.workdir, files.workdir, stdout=asyncio.subprocess.PIPE)
        children.append(camera)
        camera_port = await wait_for_camera_port(camera)
        if setup.service_start == "boot":
            children.append(await start_service())
        encoder = codec.Encoder(GCS_SYSTEM_ID, codec.MAV_COMP_ID_MISSIONPLANNER)
        async with open_link(f"udpin:{sitl.LOOPBACK}:0", encoder) as link:
            links = sitl.SitlLinks(link.local_address[1], companion_port, camera_port)
            instance = sitl.free_instance()
            command = sitl.sitl_command(setup.binary, setup.defaults, instance,
                                        sitl_home(scenario), speedup, links)
            log.info("starting ArduPilot SITL, instance %d: %s", instance, " ".join(command))
            children.append(await spawn_in("arducopter", command, files.sitl_dir, files.workdir,
                                           stdout="merge"))
            gcs = GroundStation(link, recorder, children)
            async with asyncio.TaskGroup() as tg:
                tasks = [tg.create_task(link.run(), name="gcs-link"),
                         tg.create_task(gcs.receive(), name="gcs-receive"),
                         tg.create_task(gcs.heartbeats(), name="gcs-heartbeat")]
                try:
                    report = await fly(gcs, files, scenario, speedup, setup, start_service)
                finally:
                    for task in tasks:
                        task.cancel()
    finally:
        codes = await asyncio.shield(asyncio.gather(*(c.stop() for c in reversed(children))))
        for child, code in zip(reversed(children), codes):
            if code not in (0, -signal.SIGTERM):
                log.warning("%s exited with %s", child.name, code)
        recorder.close()
        files.status_texts.write_text("\n".join(recorder.state.status_texts) + "\n")
    final = read_report(files.report) or report
    truth = read_truth(files.truth)
    checks = takeoff_checks(companion_setpoints(files.tlog, config.link.component_id), truth,
                            final.get("arrival_t_s"))
    checks["truth"] = "SIMSTATE (SITL's simulated vehicle)"
    checks["ekf_origin_ne_m"] = list(recorder.state.origin_ne_m)
    checks["takeoff_alt_m"] = setup.takeoff_alt_m
    checks["service_start"] = setup.service_start
    return (in_scenario_frame(final, recorder.state.origin_ne_m), config_to_dict(config), truth,
            checks)


def in_scenario_frame(report: dict, origin_ne_m: tuple[float, float]) -> dict:
    """The service's report (autopilot LOCAL_NED) with its track and map moved by the origin."""
    north0, east0 = origin_ne_m
    moved = dict(report)
    track = dict(report["track"])
    track["north_m"] = [n + north0 for n in track["north_m"]]
    track["east_m"] = [e + east0 for e in track["east_m"]]
    moved["track"] = track
    moved["landmarks"] = [dict(m, north_m=m["north_m"] + north0, east_m=m["east_m"] + east0)
                          for m in report["landmarks"]]
    return moved
