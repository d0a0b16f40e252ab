"""What the demo's ground station knows of an ArduPilot SITL flight, and the checks made on it.

:class:`FlightRecorder` folds the autopilot's messages (SERIAL0) into the vehicle's state and
writes the truth log the stub demo's scoring reads: one JSON line per SIMSTATE, the simulated
vehicle's true position in the scenario frame, stamped with the time_boot_ms of the ATTITUDE
sent just before it (ArduPilot sends messages of one interval together, ATTITUDE first), with
the autopilot's own altitude, landed state, arming and mode beside it.

:func:`takeoff_checks` compares the companion's setpoints (its tlog) with the vehicle's state
when each was decided: the landed state and altitude the ground station saw at that vehicle
time, and the altitude (LOCAL_POSITION_NED) and landed state (EXTENDED_SYS_STATE, if the
service asked for it) the service itself had received just before sending it.
"""
from __future__ import annotations

import json
import logging
import math
from bisect import bisect_right
from dataclasses import dataclass, field
from pathlib import Path

from companion.mavlink import codec, gcs_codec
from companion.mavlink.tlog import TlogReader
from companion.config.scenario import Scenario
from companion.core.flat_earth import to_north_east_m

log = logging.getLogger(__name__)

LANDED_ALT_M = 0.5            # below this above home, with no landed state: on the ground
ON_GROUND = 1                 # MAV_LANDED_STATE_ON_GROUND
COPTER_MODES = {0: "STABILIZE", 2: "ALT_HOLD", 3: "AUTO", 4: "GUIDED", 5: "LOITER", 6: "RTL",
                9: "LAND", 16: "POSHOLD", 17: "BRAKE"}


@dataclass
class VehicleState:
    vehicle: tuple[int, int] | None = None
    t_s: float | None = None                  # latest ATTITUDE time_boot_ms
    armed: bool = False
    custom_mode: int | None = None
    armed_t_s: float | None = None            # first arming
    disarmed_t_s: float | None = None         # first disarm after that
    relative_alt_m: float | None = None
    local: gcs_codec.LocalAltitude | None = None
    speed_mps: float = 0.0
    landed_state: int | None = None
    ekf_ready: bool = False
    origin_ne_m: tuple[float, float] | None = None   # the EKF origin in the scenario frame
    camera_seen: bool = False
    north_m: float | None = None              # the truth (SIMSTATE), scenario frame
    status_texts: list[str] = field(default_factory=list)


class FlightRecorder:
    """The ground station's state of the vehicle, and the truth log it writes."""

    def __init__(self, truth_path: Path, scenario: Scenario, camera_component_id: int,
                 guided_custom_mode: int) -> None:
        self.scenario = scenario
        self.guided_custom_mode = guided_custom_mode
        self.state = VehicleState()
        self._camera_component_id = camera_component_id
        self._file = open(truth_path, "w", encoding="utf-8")   # noqa: SIM115 - close()
        self.records = 0

    def close(self) -> None:
        self._file.close()

    def on_message(self, msg) -> codec.CommandAck | None:
        """Fold one message in; returns it as a CommandAck when it is one for us."""
        event = codec.decode(msg)
        s = self.state
        if isinstance(event, codec.Heartbeat):
            self._on_heartbeat(event)
            return None
        if s.vehicle is None or codec.source(msg) != s.vehicle:
            return None
        if isinstance(event, codec.CommandAck):
            return event
        if isinstance(event, codec.StatusText):
            s.status_texts.append(f"{s.t_s if s.t_s is not None else 0.0:.1f} s: {event.text}")
            log.info("autopilot: %s", event.text)
        elif isinstance(event, codec.Attitude):
            s.t_s = event.t_s
        gcs = gcs_codec.decode_gcs(msg)
        if isinstance(gcs, gcs_codec.SimState):
            self._write_truth(gcs)
        elif isinstance(gcs, gcs_codec.GlobalPosition):
            s.relative_alt_m = gcs.relative_alt_m
            s.speed_mps = math.hypot(gcs.vel_north_mps, gcs.vel_east_mps)
        elif isinstance(gcs, gcs_codec.LocalAltitude):
            s.local = gcs
        elif isinstance(gcs, gcs_codec.LandedState):
            s.landed_state = gcs.state
        elif isinstance(gcs, gcs_codec.EkfStatus):
            s.ekf_ready = gcs.can_fly_guided
        elif isinstance(gcs, gcs_codec.GlobalOrigin):
            origin = self.scenario.world.origin
            s.origin_ne_m = to_north_east_m(origin.lat_deg, origin.lon_deg, gcs.lat_deg,
                                            gcs.lon_deg)
        return None

    def _on_heartbeat(self, hb: codec.Heartbeat) -> None:
        s = self.state
        if s.vehicle is None and hb.is_autopilot \
                and hb.component_id == codec.MAV_COMP_ID_AUTOPILOT1:
            s.vehicle = (hb.system_id, hb.component_id)
        if s.vehicle is None or hb.system_id != s.vehicle[0]:
            return
        if hb.component_id == self._camera_component_id:
            s.camera_seen = True
        elif hb.component_id == s.vehicle[1]:
            if hb.armed and s.armed_t_s is None:
                s.armed_t_s = s.t_s
            if s.armed and not hb.armed and s.armed_t_s is not None and s.disarmed_t_s is None:
                s.disarmed_t_s = s.t_s
            s.armed, s.custom_mode = hb.armed, hb.custom_mode

    def _write_truth(self, sim: gcs_codec.SimState) -> None:
        s = self.state
        if s.t_s is None:
            return
        origin = self.scenario.world.origin
        north_m, east_m = to_north_east_m(origin.lat_deg, origin.lon_deg, sim.lat_deg,
                                          sim.lon_deg)
        s.north_m = north_m
        record = {
            "t_s": s.t_s, "north_m": north_m, "east_m": east_m, "yaw_rad": sim.yaw_rad,
            "speed_mps": s.speed_mps, "armed": s.armed,
            "mode": COPTER_MODES.get(s.custom_mode, str(s.custom_mode)),
            "obstacles": self.obstacles_at(s.t_s),
            "alt_m": s.relative_alt_m, "landed_state": s.landed_state,
        }
        self._file.write(json.dumps(record) + "\n")
        self.records += 1
        if self.records % 50 == 0:
            self._file.flush()

    def obstacles_at(self, t_s: float) -> list[dict]:
        """The scenario's obstacles; movers start when the vehicle first arms (as the camera's)."""
        armed_t_s = self.state.armed_t_s
        motion_s = 0.0 if armed_t_s is None else max(0.0, t_s - armed_t_s)
        return [{"id": ob.id, "north_m": ob.north_m + ob.vel_north_mps * motion_s,
                 "east_m": ob.east_m + ob.vel_east_mps * motion_s, "radius_m": ob.radius_m}
                for ob in self.scenario.world.obstacles]

    def flush(self) -> None:
        self._file.flush()


# ------------------------------------------------------------------ checks after the flight
def companion_setpoints(tlog: Path, component_id: int) -> list[dict]:
    """Every setpoint the service sent, with what it had last received from the vehicle."""
    out, up_m, landed = [], None, None
    for record in TlogReader(tlog):
        msg = record.msg
        if codec.sender_component(msg) == component_id and gcs_codec.is_setpoint(msg):
            out.append({"t_s": gcs_codec.setpoint_time_s(msg), "up_m": up_m,
                        "landed_state": landed})
            continue
        if codec.sender_component(msg) != codec.MAV_COMP_ID_AUTOPILOT1:
            continue
        event = gcs_codec.decode_gcs(msg)
        if isinstance(event, gcs_codec.LocalAltitude):
            up_m = event.up_m
        elif isinstance(event, gcs_codec.LandedState):
            landed = event.state
    return out


def _landed(landed_state: int | None, alt_m: float | None) -> bool:
    if landed_state not in (None, 0):
        return landed_state == ON_GROUND
    return alt_m is not None and alt_m < LANDED_ALT_M


def _landed_name(own: int | None, truth_row: dict | None) -> str | None:
    """The landed state the service had heard when it sent (its decision), else the ground
    station's at that time (a 10 Hz record that can lag by a message)."""
    state = own if own is not None else (truth_row["landed_state"] if truth_row else None)
    return None if state is None else gcs_codec.LANDED_STATE_NAMES.get(state, str(state))


def takeoff_checks(setpoints: list[dict], truth: list[dict], arrival_t_s: float | None) -> dict:
    """Setpoints while landed (by the ground station's view and by the service's own), the
    vehicle's state at the first setpoint, and whether it disarmed before arriving."""
    times = [r["t_s"] for r in truth]
    at = [truth[bisect_right(times, sp["t_s"]) - 1] if times and sp["t_s"] >= times[0] else None
          for sp in setpoints]
    landed_gcs = sum(1 for r in at if r is None or _landed(r["landed_state"], r["alt_m"]))
    landed_own = sum(1 for sp in setpoints if _landed(sp["landed_state"], sp["up_m"]))
    first = at[0] if at else None
    armed = [r for r in truth if r["armed"]]
    flown = [r["alt_m"] for r in truth if r["alt_m"] is not None]
    disarmed = [r["t_s"] for r in truth
                if armed and r["t_s"] > armed[0]["t_s"] and not r["armed"]
                and (arrival_t_s is None or r["t_s"] < arrival_t_s)]
    return {
        "setpoints": len(setpoints),
        "setpoints_while_landed": landed_gcs,
        "setpoints_while_landed_by_service_tlog": landed_own,
        "armed_t_s": armed[0]["t_s"] if armed else None,
        "first_setpoint_t_s": setpoints[0]["t_s"] if setpoints else None,
        "first_setpoint_alt_m": first["alt_m"] if first else None,
        "first_setpoint_landed_state": _landed_name(setpoints[0]["landed_state"] if setpoints
                                                    else None, first),
        "max_alt_m": max(flown) if flown else None,
        "disarmed_before_arrival_t_s": disarmed[0] if disarmed else None,
    }
