"""``companion demo``: the stub, the companion daemon and a ground station, over loopback.

Three processes, nothing shared but sockets: ``sitl-stub`` (the vehicle and its camera), ``companion
run`` (the daemon, on the stub's UDP port) and this one, a ground station on the stub's TCP port
that sets GUIDED and arms. When the companion reports arrival, both children get SIGTERM and the
flight is scored like ``companion simulate``: truth from the stub's truth log, the estimate from
the companion's report, aligned on the vehicle's time since boot (companion/tools/demo_scoring.py).

Lock-step (the default): the stub steps only when the companion has caught up, so the flight is
the same whatever the machine's load. The stub holds t = 0 until the companion's first ODOMETRY;
the ground station sets the streams the companion will ask for, GUIDED and arms in that hold, and
only then starts the companion, so every run starts from the same instant. Scored from the
companion's report at arrival (later ones depend on when the children were stopped).

(over 400 lines: the processes' start, the ground station's commands and the stop are one
sequence, read together.)
"""
from __future__ import annotations

import asyncio
import dataclasses
import logging
import signal
import sys
from dataclasses import dataclass
from pathlib import Path

import yaml

from companion.mavlink import codec
from companion.mavlink.link import open_link
from companion.tools.child_lifetime import die_with_parent_hook
from companion.config.scenario import Scenario
from companion.config.secrets import read_signing_key
from companion.config.service import CompanionConfig, config_to_dict, GoalConfig, load_user_config
from companion.errors import CompanionError
from companion.daemon.streams import STREAMS
from companion.sim.simulation import perception_delay_s
from companion.tools import demo_depth, px4_gcs
from companion.tools.demo_scoring import read_report, read_truth, wait_until_settled

log = logging.getLogger(__name__)

GCS_SYSTEM_ID = 255
READY_TIMEOUT_S = 20.0
COMMAND_RETRY_S = 0.5
COMMAND_TIMEOUT_S = 15.0
STOP_TIMEOUT_S = 5.0
POLL_S = 0.1
TAKEOFF_ALT_M = 10.0             # NAV_TAKEOFF altitude above home (docs/real-vehicle.md workflow)
TAKEOFF_ATTEMPTS = 3
CLIMB_EVIDENCE_M = 1.0           # LOCAL_POSITION_NED this far up: the takeoff is under way
TAKEOFF_CLIMB_SIM_S = 10.0       # spool-up (2.5 s) and the first metre, with margin: simulated s
TAKEOFF_RETRY_SIM_S = 2.0        # NAV_TAKEOFF resent this often (simulated s) until accepted
LOCKSTEP_MIN_REAL_TIME_FACTOR = 5.0   # the flight's wall deadline in lock-step assumes this
DEPTH_MIN_REAL_TIME_FACTOR = 0.5      # ... and with depth images (1.4x measured, loaded VM)


class DemoError(CompanionError):
    """The demo could not run: a child died, a deadline passed, a command was refused."""


@dataclass(frozen=True)
class DemoFiles:
    workdir: Path
    tlog: Path | None

    @property
    def truth(self) -> Path:
        return self.workdir / "truth.jsonl"

    @property
    def report(self) -> Path:
        return self.workdir / "companion-report.json"

    @property
    def config(self) -> Path:
        return self.workdir / "companion.yaml"


def demo_config(scenario: Scenario, base_path: str | Path = "config/companion.yaml",
                signing_key_file: Path | None = None,
                keep_shaping: bool = False) -> CompanionConfig:
    """The companion's settings for a scenario: its estimator, avoidance, goal and limits;
    signed traffic with the key in ``signing_key_file`` (an absolute path) if given.
    ``keep_shaping``: the base's commanding.max_jerk_mps3 and yaw_lead_s stay (beside a real
    autopilot); else both are off, as the stub's truth needs."""
    base = load_user_config(base_path)
    if signing_key_file is not None:
        base = dataclasses.replace(base, link=dataclasses.replace(
            base.link, signing_key_file=str(signing_key_file)))
    goal = scenario.world.goal
    estimator = scenario.estimator_config(flown_as="multicopter")
    commanding = dataclasses.replace(
        base.commanding, cruise_speed_mps=scenario.vehicle.speed_mps,
        max_speed_mps=max(base.commanding.max_speed_mps, scenario.vehicle.speed_mps),
        max_turn_rate_deg_s=scenario.vehicle.max_turn_rate_deg_s,
        max_accel_mps2=scenario.vehicle.max_accel_mps2,
        # the stub's truth changes its velocity within max_accel at once, and its nose reaches a
        # setpoint's yaw within the step
        max_jerk_mps3=base.commanding.max_jerk_mps3 if keep_shaping else None,
        yaw_lead_s=base.commanding.yaw_lead_s if keep_shaping else None,
        perception_delay_s=perception_delay_s(estimator, scenario))
    return dataclasses.replace(base, estimator=estimator,
                               avoidance=scenario.avoidance, commanding=commanding,
                               goal=GoalConfig(goal.north_m, goal.east_m, goal.radius_m),
                               flight=dataclasses.replace(base.flight, takeoff_alt_m=TAKEOFF_ALT_M),
                               perception=scenario_perception(scenario))


def scenario_perception(scenario: Scenario):
    """The scenario's perception section, its sensor's vertical view filled in; for the depth
    form its cameras' rate, mounts and stereo figures (the service reads the frames: --depth)."""
    perception = scenario.perception
    if perception.camera_vfov_deg is None:
        perception = dataclasses.replace(perception, camera_vfov_deg=scenario.sensor.vfov_deg)
    if (sensor := scenario.sensor).form == "depth":
        perception = dataclasses.replace(perception, depth=dataclasses.replace(
            perception.depth, rate_hz=sensor.depth.rate_hz, cameras=sensor.cameras,
            baseline_m=sensor.depth.baseline_m, subpixel=sensor.depth.subpixel))
    return perception


class Child:
    """A subprocess whose stderr goes to a file, so a crash can be explained."""

    def __init__(self, name: str, proc: asyncio.subprocess.Process, stderr_path: Path) -> None:
        self.name, self.proc, self.stderr_path = name, proc, stderr_path

    def stderr_tail(self, lines: int = 15) -> str:
        try:
            text = self.stderr_path.read_text(errors="replace")
        except OSError:
            return ""
        return "\n".join(text.strip().splitlines()[-lines:])

    def check_alive(self) -> None:
        if self.proc.returncode is not None:
            raise DemoError(f"{self.name} exited early with code {self.proc.returncode}:\n"
                            f"{self.stderr_tail()}")

    async def stop(self) -> int | None:
        """SIGTERM, then SIGKILL after STOP_TIMEOUT_S. Returns the exit code."""
        if self.proc.returncode is None:
            self.proc.send_signal(signal.SIGTERM)
            try:
                async with asyncio.timeout(STOP_TIMEOUT_S):
                    await self.proc.wait()
            except TimeoutError:
                log.warning("%s ignored SIGTERM: killing it", self.name)
                self.proc.kill()
                await self.proc.wait()
        return self.proc.returncode


async def spawn(name: str, args: list[str], workdir: Path, stdout=None) -> Child:
    stderr_path = workdir / f"{name}.stderr"
    with open(stderr_path, "wb") as err:
        proc = await asyncio.create_subprocess_exec(*args, stdout=stdout, stderr=err,
                                                    stdin=asyncio.subprocess.DEVNULL,
                                                    preexec_fn=die_with_parent_hook())
    return Child(name, proc, stderr_path)


async def wait_for_ready(stub: Child, addresses: dict | None = None) -> tuple[int, int]:
    """The stub's READY line -> (tcp port, udp port); ``addresses`` gets all it names."""
    try:
        async with asyncio.timeout(READY_TIMEOUT_S):
            while line := await stub.proc.stdout.readline():
                text = line.decode(errors="replace").strip()
                if text.startswith("SITL_STUB READY"):
                    ports = dict(part.split("=", 1) for part in text.split()[2:])
                    if addresses is not None:
                        addresses.update(ports)
                    return int(ports["tcp"].rpartition(":")[2]), int(ports["udp"].rpartition(":")[2])
    except TimeoutError:
        raise DemoError(f"sitl-stub not ready after {READY_TIMEOUT_S:.0f} s:\n"
                        f"{stub.stderr_tail()}") from None
    await stub.proc.wait()
    stub.check_alive()
    raise DemoError("sitl-stub closed its stdout without a READY line")


async def wait_for(condition, what: str, timeout_s: float, children: list[Child]):
    """Poll ``condition()`` until it returns something truthy; children must stay alive."""
    try:
        async with asyncio.timeout(timeout_s):
            while True:
                for child in children:
                    child.check_alive()
                if result := condition():
                    return result
                await asyncio.sleep(POLL_S)
    except TimeoutError:
        tails = "".join(f"\n--- {child.name}, last lines:\n{child.stderr_tail()}"
                        for child in children)
        raise DemoError(f"timed out after {timeout_s:.0f} s waiting for {what}{tails}") from None


async def command_until_accepted(link, msg_factory, name: str, children: list[Child],
                                 timeout_s: float = COMMAND_TIMEOUT_S,
                                 retry_s: float = COMMAND_RETRY_S, is_answer=None) -> None:
    """Send a command every ``retry_s`` until its COMMAND_ACK says accepted."""
    is_answer = is_answer or (lambda ack: codec.is_ack_for(ack, name))
    try:
        async with asyncio.timeout(timeout_s):
            while True:
                for child in children:
                    child.check_alive()
                link.send(msg_factory())
                try:
                    async with asyncio.timeout(retry_s):
                        while True:
                            event = codec.decode((await link.inbox.get()).msg)
                            if isinstance(event, codec.CommandAck) and is_answer(event):
                                if event.accepted:
                                    return
                                log.info("%s refused (result %d): retrying", name, event.result)
                                break
                except TimeoutError:
                    pass
    except TimeoutError:
        raise DemoError(f"the vehicle did not accept {name} within {timeout_s:.0f} s") from None


async def ground_station(tcp_port: int, files: DemoFiles, scenario: Scenario, speedup: float,
                         children: list[Child], config: CompanionConfig,
                         start_companion=None) -> tuple[dict, list]:
    """Set GUIDED, arm, take off, and wait for the companion to report arrival; returns its
    report and the (wall s, vehicle s) pairs seen after the takeoff. ``start_companion``
    (lock-step): a coroutine function starting the companion, called once the takeoff is
    accepted, while the stub still holds the vehicle's time at 0 (so the companion is up from
    the vehicle's boot, as in docs/real-vehicle.md)."""
    key = read_signing_key(config.link)
    async with open_link(f"tcp:127.0.0.1:{tcp_port}",
                         codec.Encoder(GCS_SYSTEM_ID, codec.MAV_COMP_ID_MISSIONPLANNER, key),
                         signing_key=key) as link:
        async with asyncio.TaskGroup() as tg:
            receiver = tg.create_task(link.run(), name="gcs-receive")
            if start_companion is None:
                await wait_for(lambda: read_report(files.report), "the companion's estimator",
                               READY_TIMEOUT_S, children)
            else:
                await set_companion_streams(link, config, children)
            await command_until_accepted(
                link, lambda: codec.set_mode(1, 1, config.link.guided_custom_mode), "set_mode",
                children)
            # resend well within DISARM_DELAY (10 s simulated): a lost takeoff must not let the
            # vehicle disarm on the ground before the next one
            await take_off(link, TAKEOFF_ALT_M, children,
                           max(COMMAND_TIMEOUT_S / 3, TAKEOFF_CLIMB_SIM_S / speedup),
                           min(COMMAND_RETRY_S, TAKEOFF_RETRY_SIM_S / speedup))
            clock = tg.create_task(track_vehicle_time(link, samples := []), name="gcs-clock")
            flight_sim_s = scenario.mission.max_time_s + 30.0      # the climb included
            if start_companion is not None:
                await start_companion()
                flight_s = flight_sim_s / (DEPTH_MIN_REAL_TIME_FACTOR
                                           if scenario.sensor.form == "depth"
                                           else LOCKSTEP_MIN_REAL_TIME_FACTOR) + 30.0
            else:
                flight_s = flight_sim_s / speedup + 30.0
            report = await wait_for(
                lambda: (r := read_report(files.report)) and r.get("arrived") and r,
                "the vehicle to arrive", flight_s, children)
            await wait_until_settled(files.truth)
            receiver.cancel()
            clock.cancel()
    return report, samples


async def set_companion_streams(link, config: CompanionConfig, children: list[Child]) -> None:
    """SET_MESSAGE_INTERVAL for what the companion will ask, before it runs: its own requests
    then change nothing, wherever in the flight they land."""
    for msg_id, key in STREAMS:
        rate_hz = getattr(config.streams, key)
        await command_until_accepted(
            link, lambda: codec.set_message_interval(1, 1, msg_id, rate_hz),
            "set_message_interval", children, is_answer=codec.is_set_message_interval_ack)


async def track_vehicle_time(link, samples: list) -> None:
    """(wall s, vehicle s) of every message with a time_boot_ms, until cancelled."""
    loop = asyncio.get_running_loop()
    while True:
        t_s = codec.vehicle_time_s((await link.inbox.get()).msg)
        if t_s is not None:
            samples.append((loop.time(), t_s))


async def take_off(link, alt_m: float, children: list[Child], climb_timeout_s: float,
                   retry_s: float = COMMAND_RETRY_S) -> None:
    """Arm, then NAV_TAKEOFF to ``alt_m`` until it is accepted or the vehicle is seen climbing:
    the companion, up since boot, commands once the climb is over. The climb counts as much as
    the ACK: an ACK lost on a lossy link makes the resent takeoff look refused (ArduCopter refuses
    a second one in the air). ArduCopter disarms a vehicle left idle on the ground for
    DISARM_DELAY, and at a high speedup those 10 s pass quickly: nothing in time, arm again."""
    for attempt in range(1, TAKEOFF_ATTEMPTS + 1):
        await command_until_accepted(link, lambda: codec.arm(1, 1), "arm", children,
                                     retry_s=retry_s)
        if await wait_for_takeoff(link, lambda: codec.takeoff(1, 1, alt_m), climb_timeout_s,
                                  children, retry_s):
            log.info("GUIDED, armed, taking off to %.0f m", alt_m)
            return
        log.warning("NAV_TAKEOFF neither accepted nor climbing (attempt %d): arming again",
                    attempt)
    raise DemoError(f"the vehicle did not take off to {alt_m:.0f} m in {TAKEOFF_ATTEMPTS} tries")


async def wait_for_takeoff(link, takeoff_factory, timeout_s: float, children: list[Child],
                           retry_s: float) -> bool:
    """Send NAV_TAKEOFF every ``retry_s``; True once it is accepted or LOCAL_POSITION_NED (if the
    link carries it) shows the vehicle CLIMB_EVIDENCE_M up; False after ``timeout_s``."""
    try:
        async with asyncio.timeout(timeout_s):
            while True:
                for child in children:
                    child.check_alive()
                link.send(takeoff_factory())
                try:
                    async with asyncio.timeout(retry_s):
                        while True:
                            event = codec.decode((await link.inbox.get()).msg)
                            if isinstance(event, codec.CommandAck) and \
                                    codec.is_ack_for(event, "takeoff") and event.accepted:
                                return True
                            elif isinstance(event, codec.LocalPosition) and \
                                    event.component_id == codec.MAV_COMP_ID_AUTOPILOT1 and \
                                    event.down_m < -CLIMB_EVIDENCE_M:
                                return True
                except TimeoutError:
                    pass
    except TimeoutError:
        return False


async def run_demo(scenario_path: Path, scenario: Scenario, files: DemoFiles, speedup: float,
                   seed: int, drop_rate: float, signing_key_file: Path | None = None,
                   lockstep: bool = True,
                   view_feed: str | None = None,
                   lockstep_overlap: bool = False,
                   base_config: str | Path = "config/companion.yaml",
                   stub_autopilot: str = "ardupilot", px4_offboard: str | None = None,
                   px4_station=None,
                   depth_record: Path | None = None) -> tuple[dict, dict, list[dict], list]:
    """Fly the scenario; returns (the companion's report, its config, the truth records, the
    ground station's (wall s, vehicle s) samples). A depth scenario's frames: --depth-tcp. With ``signing_key_file``, the stub, the companion and the ground station all sign.
    ``lockstep``: stub and companion in lock-step (module docstring); else the stub free-runs at
    ``speedup`` on the wall clock. ``view_feed``: HOST:PORT the companion sends its live state to
    (``companion view``). ``lockstep_overlap``: the stub steps on the companion's answer to the
    sample before the latest (``sitl-stub --lockstep-overlap``). ``base_config``: the service's
    settings the scenario's are laid over (demo_config). ``stub_autopilot`` 'px4': the stub's PX4
    face, ``px4_offboard`` who switches to OFFBOARD, ``px4_station`` its ground station
    (companion/tools/px4_stub_demo.py)."""
    px4 = stub_autopilot == "px4"
    config = px4_gcs.with_offboard(demo_config(scenario, base_config, signing_key_file),
                                   px4_offboard if px4 else None)
    read_signing_key(config.link)             # a bad key file fails here, before any child
    files.config.write_text(yaml.safe_dump(config_to_dict(config)))
    for stale in (files.report, files.truth):     # a kept workdir's last run must not score
        stale.unlink(missing_ok=True)
    children: list[Child] = []
    recorder = None           # --depth-record (companion/tools/demo_depth.py): stopped after
    try:
        stub_args = [sys.executable, "-m", "sitl_stub", "--scenario", str(scenario_path),
                     "--tcp", "127.0.0.1:0", "--udp", "127.0.0.1:0", "--speedup", str(speedup),
                     "--seed", str(seed), "--truth-log", str(files.truth)]
        # ArduCopter: the companion's link starts with the streams it will ask for (SRn_ of its
        # port), so its own requests change nothing wherever they land (PX4: its own defaults)
        stub_args += ["--autopilot", "px4", *px4_gcs.STUB_ARGS] if px4 else [
            f"--message-rate={msg_id}:{getattr(config.streams, key):g}" for msg_id, key in STREAMS]
        if drop_rate:
            stub_args += ["--drop-rate", str(drop_rate)]
        if signing_key_file is not None:
            stub_args += ["--signing-key", str(signing_key_file)]
        if lockstep:
            stub_args += ["--lockstep"] + (["--lockstep-overlap"] if lockstep_overlap else [])
        if scenario.sensor.form == "depth":       # the frames beside the MAVLink link
            stub_args += ["--depth-tcp", "127.0.0.1:0"]
        stub = await spawn("sitl-stub", stub_args, files.workdir, stdout=asyncio.subprocess.PIPE)
        children.append(stub)
        tcp_port, udp_port = await wait_for_ready(stub, addresses := {})
        companion_args = [sys.executable, "-m", "companion", "-v", "run",
                          "--connect", f"udpout:127.0.0.1:{udp_port}",
                          "--config", str(files.config), "--report", str(files.report)]
        if "depth" in addresses:
            companion_args += ["--depth", f"stub:{addresses['depth']}"]
            if depth_record is not None:
                recorder = await demo_depth.start_recorder(spawn, addresses["depth"],
                                                           depth_record, files.workdir, stub)
        if files.tlog:
            companion_args += ["--tlog", str(files.tlog)]
        if lockstep:
            companion_args += ["--lockstep"]
        if view_feed:
            companion_args += ["--view-feed", view_feed]

        async def start_companion() -> None:
            children.append(await spawn("companion", companion_args, files.workdir))
        if not lockstep:
            await start_companion()
        report, samples = await (px4_station if px4 else ground_station)(
            tcp_port, files, scenario, speedup, children, config,
            start_companion if lockstep else None)
    finally:
        # Stop the children together: one slow to exit must not double the wait for Ctrl-C.
        codes = await asyncio.shield(asyncio.gather(*(child.stop() for child in children)))
        for child, code in zip(children, codes):
            if code not in (0, -signal.SIGTERM):
                log.warning("%s exited with %s", child.name, code)
        if recorder is not None and await demo_depth.finish_recorder(recorder) != 0:
            log.warning("depth-record: %s", recorder.stderr_tail())
    final = report if lockstep else read_report(files.report) or report
    return final, config_to_dict(config), read_truth(files.truth), samples
