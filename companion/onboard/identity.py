"""Which vehicle is ours, what its heartbeat says, and whether it may be commanded now.

The vehicle is the first heartbeat from an autopilot with the wanted component id (or the pinned
ids, ``link.vehicle_system_id`` and ``link.vehicle_component_id``); other autopilots are named
once and ignored; the camera's heartbeat is no obstacle data (safety/liveness.py). Commanding is
allowed while the vehicle's last heartbeat says armed and in the steering mode (GUIDED; OFFBOARD on
PX4: the dialect, onboard/autopilot_dialect.py, from ``link.autopilot`` and the heartbeat's
autopilot field) and is fresh on the link clock.
"""
from __future__ import annotations

import logging

from companion.mavlink import codec
from companion.onboard import autopilot_dialect
from companion.onboard.outputs import StreamsWanted

log = logging.getLogger(__name__)


class VehicleIdentity:
    """Our vehicle's ids, armed state and mode, and the link's state by its heartbeats.

    ``pipeline``: the pipeline this part serves (its config, liveness, clock, flight phase,
    mission and commander are read when a heartbeat comes, not copied here).
    """

    def __init__(self, pipeline) -> None:
        self._pipeline = pipeline
        link = pipeline.config.link
        self.vehicle: tuple[int, int] | None = (
            (link.vehicle_system_id, link.vehicle_component_id or codec.MAV_COMP_ID_AUTOPILOT1)
            if link.vehicle_system_id is not None and link.vehicle_component_id is not None
            else None)
        self.other_vehicles: set[int] = set()
        self.armed = False
        self.custom_mode: int | None = None
        # pinned, or ArduPilot until the vehicle's heartbeat says otherwise ('auto')
        self.dialect = autopilot_dialect.resolve(link.autopilot, None, link.guided_custom_mode)
        self._dialect_adopted = False
        self.link_lost = False
        self._allowed = False

    def from_vehicle_system(self, event) -> bool:
        return self.vehicle is not None and event.system_id == self.vehicle[0]

    def is_vehicle(self, event) -> bool:
        return (event.system_id, event.component_id) == self.vehicle

    @property
    def steering(self) -> bool:
        """The vehicle's last heartbeat says the steering mode (GUIDED, OFFBOARD on PX4)."""
        return self.dialect.steering(self.custom_mode)

    def commanding_allowed(self, t_link_s: float) -> bool:
        """Armed, in the steering mode, and the vehicle's heartbeat is fresh: setpoints may be
        sent."""
        p = self._pipeline
        return (self.vehicle is not None and self.armed and self.steering
                and p.liveness.heartbeat_fresh(t_link_s))

    def on_heartbeat(self, t_link_s: float, hb: codec.Heartbeat, out: list) -> None:
        p = self._pipeline
        link = p.config.link
        wanted_component = link.vehicle_component_id or codec.MAV_COMP_ID_AUTOPILOT1
        if self.vehicle is None and hb.is_autopilot and hb.component_id == wanted_component \
                and link.vehicle_system_id in (None, hb.system_id):
            self.vehicle = (hb.system_id, hb.component_id)
            log.info("vehicle found: system %d component %d", *self.vehicle)
            out.append(StreamsWanted("vehicle found"))
            if p.mission is not None:
                out.extend(p.mission.on_vehicle(t_link_s, self.vehicle))
        if self.vehicle is not None and (hb.system_id, hb.component_id) == self.vehicle:
            if self.link_lost:
                self.link_lost = False
                log.info("vehicle heartbeat back: resync")
                out.append(StreamsWanted("heartbeat back"))
            p.liveness.on_vehicle_heartbeat(t_link_s)
            p.clock.on_vehicle_heartbeat()
            if not self._dialect_adopted:
                self._adopt_dialect(hb.autopilot)
            self.armed, self.custom_mode = hb.armed, hb.custom_mode
            if self.dialect.name == "px4":
                p.offboard.on_armed(hb.armed)
                p.offboard.on_mode(self.steering)
            p.look_around.on_heartbeat(hb.armed)
            p.phase.on_armed(hb.armed)
            p.commander.note_phase()
            self.note_allowed(t_link_s)
        elif self.vehicle is not None and hb.system_id == self.vehicle[0] \
                and hb.component_id == link.camera_component_id:
            pass        # the camera's heartbeat is no obstacle data (safety/liveness.py)
        elif hb.is_autopilot and (self.vehicle is None or hb.system_id != self.vehicle[0]):
            if hb.system_id not in self.other_vehicles:
                self.other_vehicles.add(hb.system_id)
                log.info("ignoring another vehicle: system %d", hb.system_id)

    def _adopt_dialect(self, heartbeat_autopilot: int) -> None:
        link = self._pipeline.config.link
        self._dialect_adopted = True
        self.dialect = autopilot_dialect.resolve(link.autopilot, heartbeat_autopilot,
                                                 link.guided_custom_mode)
        if self._pipeline.mission is not None:
            self._pipeline.mission.home_seq = self.dialect.home_seq
        if self.dialect.name == "px4":
            log.info("autopilot PX4 (link.autopilot %s, heartbeat autopilot %d): steering in "
                     "OFFBOARD, entered by the %s (px4.offboard)", link.autopilot,
                     heartbeat_autopilot, self._pipeline.config.px4.offboard)

    def check_heartbeat_age(self, t_link_s: float) -> None:
        """Before every message: a heartbeat gone stale stops commanding (said once)."""
        liveness = self._pipeline.liveness
        last = liveness.heartbeat_link_s
        if last is None or self.link_lost:
            return
        if not liveness.heartbeat_fresh(t_link_s):
            self.link_lost = True
            log.warning("vehicle heartbeat lost for %.1f s: commanding stopped",
                        t_link_s - last)
            self.note_allowed(t_link_s)

    def note_allowed(self, t_link_s: float) -> None:
        allowed = self.commanding_allowed(t_link_s)
        if allowed != self._allowed:
            self._allowed = allowed
            if allowed:
                log.info("vehicle armed in %s: commanding", self.dialect.steering_name)
            else:
                log.info("commanding stopped (armed %s, mode %s, link %s)", self.armed,
                         self.custom_mode if self.dialect.name == "ardupilot"
                         else self.dialect.mode_name(self.custom_mode),
                         "lost" if self.link_lost else "up")
