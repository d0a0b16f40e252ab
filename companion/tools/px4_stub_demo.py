"""The stub demo's ground station for the stub's PX4 face (``companion demo --stub-autopilot px4``):
companion/tools/demo.py's ``ground_station`` with PX4's workflow (companion/tools/px4_gcs.py) in
place of ArduCopter's. Apart from px4_gcs.py so that it may use demo.py's helpers."""
from __future__ import annotations

import asyncio

from companion.config.secrets import read_signing_key
from companion.mavlink import codec
from companion.mavlink.link import open_link
from companion.tools.demo import (GCS_SYSTEM_ID, LOCKSTEP_MIN_REAL_TIME_FACTOR, READY_TIMEOUT_S,
                                  TAKEOFF_ALT_M, DemoError, wait_for)
from companion.tools.demo_scoring import read_report, wait_until_settled
from companion.tools.px4_gcs import Px4View, fly_to_offboard, offboard_facts, watch


async def px4_ground_station(tcp_port: int, files, scenario, speedup: float, children: list,
                             config, start_companion=None, takeoff_above_home_m: float = TAKEOFF_ALT_M,
                             arm_timeout_s: float = 120.0) -> tuple[dict, list]:
    """The demo's ground station (companion/tools/demo.py ground_station) for PX4: the service
    up first (lock-step: it drives the stub), then the module docstring's steps; returns the
    companion's report at arrival (the PX4 facts added as ``px4_flight``) and the (wall s,
    vehicle s) samples."""
    def check() -> None:
        for child in children:
            child.check_alive()

    key = read_signing_key(config.link)
    view = Px4View()
    async with open_link(f"tcp:127.0.0.1:{tcp_port}",
                         codec.Encoder(GCS_SYSTEM_ID, codec.MAV_COMP_ID_MISSIONPLANNER, key),
                         signing_key=key) as link:
        async with asyncio.TaskGroup() as tg:
            receiver = tg.create_task(link.run(), name="gcs-receive")
            watcher = tg.create_task(watch(link, view), name="gcs-watch")
            if start_companion is not None:
                await start_companion()
            else:
                await wait_for(lambda: read_report(files.report), "the companion's estimator",
                               READY_TIMEOUT_S, children)
            try:
                facts = await fly_to_offboard(link, view, takeoff_above_home_m,
                                              config.px4.offboard, check, arm_timeout_s)
            except TimeoutError:
                raise DemoError(f"PX4 workflow stalled (modes seen: {view.modes})") from None
            flight_sim_s = scenario.mission.max_time_s + 30.0
            flight_s = flight_sim_s / (LOCKSTEP_MIN_REAL_TIME_FACTOR if start_companion
                                       else speedup) + 30.0
            report = await wait_for(
                lambda: (r := read_report(files.report)) and r.get("arrived") and r,
                "the vehicle to arrive", flight_s, children)
            await wait_until_settled(files.truth)
            receiver.cancel()
            watcher.cancel()
    facts.update(offboard_facts(view, report, None))
    return {**report, "px4_flight": facts}, view.samples
