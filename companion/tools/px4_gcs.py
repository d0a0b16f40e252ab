"""The demo's ground station for a PX4 vehicle (``companion demo --stub-autopilot px4``, ``--px4``).

PX4's workflow, as an operator flies it with QGroundControl beside the service:
1. the service runs from the vehicle's boot (in lock-step it drives the stub's clock);
2. arm, resent while PX4 answers TEMPORARILY_REJECTED (its preflight checks take ~35 s after
   boot: the estimator converging);
3. MAV_CMD_NAV_TAKEOFF with param7 an AMSL altitude (home's AMSL, read from GLOBAL_POSITION_INT
   alt - relative_alt, plus the take-off height); PX4 climbs in AUTO.TAKEOFF and then holds
   (AUTO.LOITER);
4. OFFBOARD: with ``px4.offboard: operator`` this ground station switches, resent while PX4
   refuses (it wants the service's setpoint stream for over a second first); with 'companion'
   it only watches the service ask for it;
5. the service flies to the goal; its report says arrival.
Facts kept for the result: when OFFBOARD came and who asked, the modes seen.
"""
from __future__ import annotations

import asyncio
import dataclasses
import logging
import math
from dataclasses import dataclass, field

from companion.mavlink import codec, px4_modes

log = logging.getLogger(__name__)

# The stub's PX4 face in the demo: arming refused for 5 s after boot, not PX4 SIH's 35 s: the
# paper's world is GPS-denied, and the service, up from boot, would dead-reckon on the ground
# for 35 s (its pose spread grows, unaided) before the flight even starts.
STUB_ARGS = ("--px4-arm-delay-s", "5")
RETRY_S = 0.5                  # wall seconds: an unanswered command is resent
RETRY_SIM_S = 0.5              # vehicle seconds between resends of a refused command
MODE_WAIT_S = 120.0            # wall seconds for a mode to come (takeoff done, OFFBOARD)


@dataclass
class Px4View:
    """What the ground station has seen of the vehicle (updated by ``watch``)."""
    custom_mode: int | None = None
    armed: bool = False
    home_amsl_m: float | None = None
    t_s: float | None = None                       # the vehicle's latest time since boot
    modes: list = field(default_factory=list)      # [(vehicle s, mode name, armed)] on change
    samples: list = field(default_factory=list)    # (wall s, vehicle s)
    acks: asyncio.Queue = field(default_factory=lambda: asyncio.Queue(maxsize=64))

    def on_message(self, msg, wall_s: float) -> None:
        t_s = codec.vehicle_time_s(msg)
        if t_s is not None and msg.get_srcComponent() == 1:    # the autopilot's clock only
            self.t_s = t_s
            self.samples.append((wall_s, t_s))
        event = codec.decode(msg)
        if isinstance(event, codec.Heartbeat) and event.component_id == 1 and event.is_autopilot:
            if (event.custom_mode, event.armed) != (self.custom_mode, self.armed):
                self.modes.append((self.t_s, px4_modes.mode_name(event.custom_mode),
                                   event.armed))
            self.custom_mode, self.armed = event.custom_mode, event.armed
        elif isinstance(event, codec.CommandAck) and not self.acks.full():
            self.acks.put_nowait(event)
        elif msg.get_type() == "GLOBAL_POSITION_INT" and msg.get_srcComponent() == 1:
            self.home_amsl_m = msg.alt / 1000.0 - msg.relative_alt / 1000.0


async def watch(link, view: Px4View) -> None:
    loop = asyncio.get_running_loop()
    while True:
        view.on_message((await link.inbox.get()).msg, loop.time())


async def command(link, view: Px4View, factory, name: str, timeout_s: float, check) -> None:
    """Send until accepted; after a refusal, again once RETRY_SIM_S of vehicle time has passed
    (at most RETRY_S of wall time: in lock-step the vehicle's clock runs far faster)."""
    async with asyncio.timeout(timeout_s):
        while True:
            check()
            link.send(factory())
            try:
                async with asyncio.timeout(RETRY_S):
                    while True:
                        ack = await view.acks.get()
                        if codec.is_ack_for(ack, name):
                            break
            except TimeoutError:
                continue
            if ack.accepted:
                return
            log.info("%s refused (result %d) at %.1f s: resending", name, ack.result,
                     view.t_s or 0.0)
            await wait_vehicle_time(view, RETRY_SIM_S, RETRY_S)


async def wait_vehicle_time(view: Px4View, sim_s: float, wall_cap_s: float) -> None:
    since = view.t_s
    try:
        async with asyncio.timeout(wall_cap_s):
            while since is not None and view.t_s is not None and view.t_s < since + sim_s:
                await asyncio.sleep(0.005)
    except TimeoutError:
        pass


async def wait_mode(view: Px4View, modes: tuple[int, ...], what: str, timeout_s: float,
                    check) -> None:
    async with asyncio.timeout(timeout_s):
        while view.custom_mode not in modes:
            check()
            await asyncio.sleep(0.05)
    log.info("%s: %s at %.1f s", what, px4_modes.mode_name(view.custom_mode), view.t_s or 0.0)


async def wait_new_mode(view: Px4View, seen: int, names: tuple[str, ...], what: str,
                        check) -> None:
    """Until a mode change after ``view.modes[seen]`` to one of ``names``, armed."""
    async with asyncio.timeout(MODE_WAIT_S):
        while not any(name in names and armed for _, name, armed in view.modes[seen:]):
            check()
            await asyncio.sleep(0.05)
    log.info("%s: %s at %.1f s", what, view.modes[-1][1], view.t_s or 0.0)


async def switch_to_offboard(link, view: Px4View, check) -> None:
    """The operator's switch, judged by the heartbeat, not the COMMAND_ACK: PX4 1.15 answers
    TEMPORARILY_REJECTED without the offboard signal, later versions may answer ACCEPTED and
    then log "Switching to Offboard is currently not available" and stay. Resent every
    RETRY_SIM_S * 2 of vehicle time until OFFBOARD shows."""
    async with asyncio.timeout(MODE_WAIT_S):
        while view.custom_mode != px4_modes.OFFBOARD:
            check()
            link.send(px4_modes.set_mode(1, 1, px4_modes.OFFBOARD))
            await wait_vehicle_time(view, 2 * RETRY_SIM_S, 2 * RETRY_S)


async def fly_to_offboard(link, view: Px4View, takeoff_above_home_m: float, offboard: str,
                          check, arm_timeout_s: float) -> dict:
    """Steps 2-4 of the module docstring; returns the facts for the result."""
    async with asyncio.timeout(MODE_WAIT_S):
        while view.home_amsl_m is None:
            check()
            await asyncio.sleep(0.05)
    await command(link, view, lambda: codec.arm(1, 1), "arm", arm_timeout_s, check)
    armed_t_s = view.t_s
    target_amsl = view.home_amsl_m + takeoff_above_home_m
    seen = len(view.modes)
    await command(link, view, lambda: px4_modes.takeoff(1, 1, target_amsl), "takeoff", 30.0,
                  check)
    # the heartbeat may still show the mode before the take-off: wait for a new one
    await wait_new_mode(view, seen, ("AUTO.LOITER", "OFFBOARD"), "takeoff done", check)
    hold_t_s = next((t for t, name, armed in view.modes[seen:] if name == "AUTO.LOITER"
                     and armed), view.t_s)
    if offboard == "operator":
        await switch_to_offboard(link, view, check)
    await wait_mode(view, (px4_modes.OFFBOARD,), "OFFBOARD", MODE_WAIT_S, check)
    return {"autopilot": "px4", "offboard": offboard, "armed_t_s": armed_t_s,
            "takeoff_target_amsl_m": round(target_amsl, 2), "hold_t_s": hold_t_s,
            "offboard_t_s": next((t for t, name, armed in view.modes
                                  if name == "OFFBOARD" and armed), view.t_s)}


def with_offboard(config, offboard: str | None):
    """The demo's config with ``px4.offboard`` set (None: as the base config says)."""
    if offboard is None:
        return config
    return dataclasses.replace(config, px4=dataclasses.replace(config.px4, offboard=offboard))


def offboard_facts(view: Px4View, report: dict | None, truth: list[dict] | None) -> dict:
    """After the flight: the modes seen, the service's OFFBOARD requests, setpoints on the
    ground (the stub's count, when the vehicle is the stub)."""
    facts = {"modes": [[t, name, armed] for t, name, armed in view.modes]}
    if report is not None and report.get("offboard") is not None:
        facts["service_offboard"] = report["offboard"]
    if truth:
        landed = [row.get("setpoints_while_landed") for row in truth]
        facts["setpoints_while_landed"] = max((n for n in landed if n is not None), default=None)
    facts["home_amsl_m"] = None if view.home_amsl_m is None or not math.isfinite(
        view.home_amsl_m) else round(view.home_amsl_m, 2)
    return facts
