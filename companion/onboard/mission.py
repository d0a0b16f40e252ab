"""The vehicle's mission, downloaded and flown waypoint by waypoint. Pure: no I/O, time passed in.

``MissionDownload`` is the client side of the MAVLink mission protocol's download
(mavlink.io/en/services/mission.html): MISSION_REQUEST_LIST -> MISSION_COUNT, then
MISSION_REQUEST_INT seq -> MISSION_ITEM_INT seq for every item in order, then MISSION_ACK
(ACCEPTED). A request that goes unanswered for ``item_timeout_s`` (the protocol's default 1.5 s)
is sent again, at most ``retries`` (5) times; then the download is abandoned and the autopilot
told so (MISSION_ACK OPERATION_CANCELLED). An error MISSION_ACK from the autopilot (e.g. DENIED
while a ground station uploads) abandons it too; the caller may start again.

``build_plan`` turns the items into waypoints the companion flies: ArduPilot keeps home as item 0
(not flown); NAV_WAYPOINT in a global frame (latitude/longitude, the altitude ignored: the
companion holds its own) or MAV_FRAME_LOCAL_NED (metres from the EKF origin); its param1 is the
hold time in seconds (ArduCopter: loiter there that long before the next; negative or not finite:
0, named), its param2 the acceptance radius (0: the configured one). Everything else is named and
skipped, never guessed.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

from companion.mavlink import mission_codec as mc

HOME_SEQ = 0                       # ArduPilot: item 0 is home


@dataclass(frozen=True)
class DownloadParams:
    item_timeout_s: float = 1.5
    retries: int = 5


class MissionDownload:
    """One download from ``vehicle`` (system, component) to us (``own``: system, component)."""

    def __init__(self, vehicle: tuple[int, int], own_component: int,
                 params: DownloadParams = DownloadParams()) -> None:
        self.vehicle = vehicle
        self.own_component = own_component
        self.params = params
        self.state = "idle"            # idle | count | items | done | failed
        self.items: list[mc.MissionItem] = []
        self.count: int | None = None
        self.failure: str | None = None
        self.resends = 0
        self._pending: mc.MissionRequest | None = None
        self._sent_t_s = 0.0
        self._tries = 0

    @property
    def active(self) -> bool:
        return self.state in ("count", "items")

    def start(self, t_s: float) -> list[mc.MissionRequest]:
        self.state, self.items, self.count, self.failure = "count", [], None, None
        return self._send(t_s, mc.RequestList(*self.vehicle))

    def _send(self, t_s: float, request: mc.MissionRequest) -> list[mc.MissionRequest]:
        self._pending, self._sent_t_s, self._tries = request, t_s, 0
        return [request]

    def _for_us(self, event) -> bool:
        return ((event.system_id, event.component_id) == self.vehicle
                and event.mission_type == mc.MISSION_TYPE_MISSION
                and event.target_component in (0, self.own_component))

    def on_event(self, t_s: float, event) -> list[mc.MissionRequest]:
        """A MISSION_COUNT, MISSION_ITEM_INT or MISSION_ACK from the vehicle."""
        if not self.active or not self._for_us(event):
            return []
        if isinstance(event, mc.MissionCount) and self.state == "count":
            self.count = event.count
            if event.count == 0:
                return self._finish()
            self.state = "items"
            return self._send(t_s, mc.RequestItem(*self.vehicle, 0))
        if isinstance(event, mc.MissionItem) and self.state == "items":
            if event.seq != len(self.items):
                return []              # a duplicate or a stray: the pending request stands
            self.items.append(event)
            if len(self.items) == self.count:
                return self._finish()
            return self._send(t_s, mc.RequestItem(*self.vehicle, len(self.items)))
        if isinstance(event, mc.MissionAck) and event.result != mc.MISSION_ACCEPTED:
            self.state, self.failure = "failed", f"autopilot refused (MISSION_ACK {event.result})"
            self._pending = None
        return []

    def _finish(self) -> list[mc.MissionRequest]:
        self.state, self._pending = "done", None
        return [mc.AckDownload(*self.vehicle, mc.MISSION_ACCEPTED)]

    def tick(self, t_s: float) -> list[mc.MissionRequest]:
        """Resend the pending request after the timeout; give up after the retries."""
        if not self.active or self._pending is None:
            return []
        if t_s - self._sent_t_s < self.params.item_timeout_s:
            return []
        if self._tries >= self.params.retries:
            what = "count" if self.state == "count" else f"item {len(self.items)}"
            self.state, self.failure, self._pending = "failed", f"no answer for the {what}", None
            return [mc.AckDownload(*self.vehicle, mc.MISSION_OPERATION_CANCELLED)]
        self._tries += 1
        self.resends += 1
        self._sent_t_s = t_s
        return [self._pending]


@dataclass(frozen=True)
class Waypoint:
    """A NAV_WAYPOINT to fly: ``lat_deg``/``lon_deg`` (global) or ``north_m``/``east_m``."""
    seq: int
    radius_m: float
    lat_deg: float | None = None
    lon_deg: float | None = None
    north_m: float | None = None
    east_m: float | None = None
    hold_s: float = 0.0                # NAV_WAYPOINT param1

    @property
    def is_geographic(self) -> bool:
        return self.lat_deg is not None


@dataclass(frozen=True)
class MissionPlan:
    waypoints: tuple[Waypoint, ...]
    skipped: tuple[str, ...] = field(default=())     # "seq: what and why", for logs and notices


def build_plan(items: list[mc.MissionItem], default_radius_m: float,
               home_seq: int | None = HOME_SEQ) -> MissionPlan:
    """``home_seq``: the item that is home (ArduPilot 0); None: every item is the mission's
    (PX4 keeps home apart, in HOME_POSITION)."""
    waypoints: list[Waypoint] = []
    skipped: list[str] = []
    for item in items:
        if item.seq == home_seq:
            continue                   # home, as ArduPilot stores it
        # short for a STATUSTEXT ("companion: skip 4: DO_CHANGE_SPEED not flown"); the
        # longest command names are cut at 50 characters by the codec
        name = mc.command_name(item.command).removeprefix("MAV_CMD_")
        if item.command != mc.CMD_NAV_WAYPOINT:
            skipped.append(f"{item.seq}: {name} not flown")
            continue
        radius = item.params[1] if item.params[1] > 0.0 else default_radius_m
        hold_s = item.params[0]
        if not (math.isfinite(hold_s) and hold_s >= 0.0):
            skipped.append(f"{item.seq}: hold {hold_s} s not flown (0 s)")
            hold_s = 0.0
        if item.frame in mc.GLOBAL_FRAMES:
            if item.x == 0 and item.y == 0:
                skipped.append(f"{item.seq}: {name} at 0, 0 not flown")
                continue
            if not (-90.0 <= item.lat_deg <= 90.0 and -180.0 <= item.lon_deg <= 180.0):
                skipped.append(f"{item.seq}: {name} lat/lon out of range")
                continue
            waypoints.append(Waypoint(item.seq, radius, lat_deg=item.lat_deg,
                                      lon_deg=item.lon_deg, hold_s=hold_s))
        elif item.frame in mc.LOCAL_FRAMES:
            waypoints.append(Waypoint(item.seq, radius, north_m=item.north_m,
                                      east_m=item.east_m, hold_s=hold_s))
        else:
            frame = mc.frame_name(item.frame).removeprefix("MAV_FRAME_")
            skipped.append(f"{item.seq}: frame {frame} not flown")
    return MissionPlan(tuple(waypoints), tuple(skipped))
