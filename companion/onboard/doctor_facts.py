"""``companion doctor``'s measurements: the received stream in, measured facts out (pure).

:class:`Observer` is fed every received message as the service's event (mavlink/inbound.py) and
the doctor's own record of it (mavlink/doctor_codec.py), stamped with link time; it counts and
keeps, and :meth:`Observer.facts` hands back one frozen :class:`Facts` for
companion/onboard/doctor_checks.py to judge. The rules of the service are the pipeline's: the
vehicle is the pinned ids or the first autopilot heartbeat; obstacle reports count from the
vehicle's system, its autopilot or the configured camera component.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

from companion.config.service import CompanionConfig
from companion.mavlink import codec
from companion.mavlink import doctor_codec as dc
from companion.onboard.odometry_intake import PositionHealth

MEASURE_SETTLE_S = 1.0      # rates are measured from this long after the streams were asked


@dataclass(frozen=True)
class CameraFacts:
    component_id: int
    heartbeat: bool
    msgs_hz: dict[int, float]                  # OBSTACLE_DISTANCE(_3D) id -> messages a second
    frames_hz: float                           # distinct capture times a second
    ignored: dict[int, int]                    # obstacle reports from other components, counted
    layouts: tuple[dc.ObstacleLayout, ...]     # each distinct layout seen
    refused: dict[str, int]                    # why reports gave no observation, counted
    observations: int
    range_min_m: float | None
    range_max_m: float | None


@dataclass(frozen=True)
class Facts:
    listened_s: float
    measured_s: float                          # the span the rates are measured over
    vehicle: dc.HeartbeatInfo | None
    other_autopilots: tuple[tuple[int, int], ...]
    firmware: dc.FirmwareVersion | None
    rates_hz: dict[int, float]                 # message id -> measured from the vehicle
    streams_asked: bool
    origin: tuple[float, float] | None         # EKF origin lat, lon (deg)
    gps: codec.GpsFix | None
    ekf_flags: int | None
    position_trusted: bool                     # the service's own rule (odometry_intake)
    camera: CameraFacts
    round_trips_ms: tuple[float, ...]          # TIMESYNC, each answered request
    timesync_sent: int
    signed: int                                # vehicle packets with a signature
    unsigned: int
    signature_rejected: int
    params: dict[str, float]
    params_asked: tuple[str, ...]


@dataclass
class _Counts:
    by_id: dict[int, int] = field(default_factory=dict)

    def add(self, msg_id: int) -> None:
        self.by_id[msg_id] = self.by_id.get(msg_id, 0) + 1


class Observer:
    """Feed it (``observe``), tell it what was asked (``streams_asked_at``, ``asked_params``,
    ``round_trip``), then read :meth:`facts`."""

    def __init__(self, config: CompanionConfig, start_s: float) -> None:
        self.config = config
        link = config.link
        self.pinned = (link.vehicle_system_id, link.vehicle_component_id)
        self.start_s = start_s
        self.vehicle: dc.HeartbeatInfo | None = None
        self.others: set[tuple[int, int]] = set()
        self.firmware: dc.FirmwareVersion | None = None
        self.measure_from_s: float | None = None
        self._rates = _Counts()
        self._camera_msgs = _Counts()
        self._frame_times: set[float] = set()
        self._ignored: dict[int, int] = {}
        self._camera_heartbeat = False
        self._layouts: dict[tuple, dc.ObstacleLayout] = {}
        self._refused: dict[str, int] = {}
        self._observations = 0
        self._ranges: list[float] = []
        self.origin: tuple[float, float] | None = None
        self.gps: codec.GpsFix | None = None
        self.ekf_flags: int | None = None
        # the autopilot's position judged by the service's 'auto' rule, whatever the config says
        self.position = PositionHealth(dataclasses.replace(config.estimator,
                                                           position_fusion="auto"))
        self.round_trips_ms: list[float] = []
        self.timesync_sent = 0
        self.signed = self.unsigned = 0
        self.params: dict[str, float] = {}
        self.params_asked: tuple[str, ...] = ()

    # ------------------------------------------------------------ what we did
    def streams_asked_at(self, t_s: float) -> None:
        """The streams were (re)asked at ``t_s``: the rates are measured from a settle later."""
        self.measure_from_s = t_s + MEASURE_SETTLE_S
        self._rates = _Counts()
        self._camera_msgs = _Counts()
        self._frame_times = set()

    def round_trip(self, round_trip_ns: int) -> None:
        self.round_trips_ms.append(round_trip_ns / 1e6)

    # ------------------------------------------------------------ what came
    def is_vehicle(self, source: tuple[int, int]) -> bool:
        return self.vehicle is not None and source == (self.vehicle.system_id,
                                                       self.vehicle.component_id)

    def observe(self, t_s: float, msg_id: int, source: tuple[int, int], signed: bool,
                event, fact) -> None:
        """One received message: its id, sender, whether it was signed, the service's event
        and the doctor's record of it (either may be None)."""
        if isinstance(fact, dc.HeartbeatInfo):
            self._on_heartbeat(fact)
        if self.vehicle is None or source[0] != self.vehicle.system_id:
            return
        camera_id = self.config.link.camera_component_id
        if source[1] == camera_id and isinstance(fact, dc.HeartbeatInfo):
            self._camera_heartbeat = True
        if source[1] in (self.vehicle.component_id, camera_id):
            self._on_obstacles(t_s, msg_id, event, fact)
        elif isinstance(fact, dc.ObstacleLayout) and source[1] != self.config.link.component_id:
            self._ignored[source[1]] = self._ignored.get(source[1], 0) + 1
        if not self.is_vehicle(source):
            return
        self.signed += signed
        self.unsigned += not signed
        if self.measure_from_s is not None and t_s >= self.measure_from_s:
            self._rates.add(msg_id)
        if isinstance(fact, dc.FirmwareVersion):
            self.firmware = fact
        elif isinstance(fact, dc.ParamReading):
            self.params[fact.name] = fact.value
        elif isinstance(event, codec.GeoReference) and event.kind == "origin":
            self.origin = (event.lat_deg, event.lon_deg)
        elif isinstance(event, (codec.GpsFix, codec.EkfStatus)):
            self.position.note(event, t_s)
            if isinstance(event, codec.GpsFix):
                self.gps = event
            else:
                self.ekf_flags = event.flags

    def _on_heartbeat(self, hb: dc.HeartbeatInfo) -> None:
        if hb.autopilot == codec.mavlink.MAV_AUTOPILOT_INVALID:
            return
        source = (hb.system_id, hb.component_id)
        sys_pin, comp_pin = self.pinned
        pinned_ok = (sys_pin is None or hb.system_id == sys_pin) and \
            (comp_pin is None or hb.component_id == comp_pin)
        if self.vehicle is None and pinned_ok:
            self.vehicle = hb
        elif self.is_vehicle(source):
            self.vehicle = hb                   # the latest: its mode now
        else:
            self.others.add(source)

    def _on_obstacles(self, t_s: float, msg_id: int, event, fact) -> None:
        if isinstance(fact, dc.ObstacleLayout):
            key = (fact.msg_id, fact.frame, fact.angle_offset_deg, fact.increment_deg, fact.count,
                   fact.min_distance_m, fact.max_distance_m)
            self._layouts.setdefault(key, fact)
            if self.measure_from_s is None or t_s >= self.measure_from_s:
                self._camera_msgs.add(msg_id)
        if isinstance(event, codec.ObstacleFrame):
            if self.measure_from_s is None or t_s >= self.measure_from_s:
                self._frame_times.add(event.t_s)
            if event.rejected:
                self._refused[event.rejected] = self._refused.get(event.rejected, 0) + 1
            self._observations += len(event.observations)
            self._ranges.extend(o.range_m for o in event.observations)

    # ------------------------------------------------------------ the result
    def facts(self, end_s: float, signature_rejected: int = 0) -> Facts:
        since = self.measure_from_s if self.measure_from_s is not None else self.start_s
        span_s = max(end_s - since, 0.0)

        def rates(counts: _Counts) -> dict[int, float]:
            return {m: (n / span_s if span_s > 0 else 0.0) for m, n in counts.by_id.items()}
        ranges = self._ranges
        camera = CameraFacts(self.config.link.camera_component_id, self._camera_heartbeat,
                             rates(self._camera_msgs),
                             len(self._frame_times) / span_s if span_s > 0 else 0.0,
                             dict(self._ignored), tuple(self._layouts.values()),
                             dict(self._refused), self._observations,
                             min(ranges) if ranges else None, max(ranges) if ranges else None)
        return Facts(
            listened_s=end_s - self.start_s, measured_s=span_s, vehicle=self.vehicle,
            other_autopilots=tuple(sorted(self.others)), firmware=self.firmware,
            rates_hz=rates(self._rates), streams_asked=self.measure_from_s is not None,
            origin=self.origin, gps=self.gps, ekf_flags=self.ekf_flags,
            position_trusted=self.position.aided(end_s),
            camera=camera, round_trips_ms=tuple(self.round_trips_ms),
            timesync_sent=self.timesync_sent, signed=self.signed, unsigned=self.unsigned,
            signature_rejected=signature_rejected, params=dict(self.params),
            params_asked=self.params_asked)

