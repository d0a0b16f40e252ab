"""``companion doctor``'s listening: the service's link and stream requests, for N seconds.

Wiring only. The link is the service's (mavlink/link.py, with its signing), the stream requests
the service's own (daemon/streams.py: SET_MESSAGE_INTERVAL acked and retried, REQUEST_DATA_STREAM
as the fallback, asked again when odometry stays away). Beside them the doctor asks for
AUTOPILOT_VERSION and the EKF origin (MAV_CMD_REQUEST_MESSAGE), reads the autopilot's parameters
(PARAM_REQUEST_READ, by its profile: onboard/doctor_params.py), sends TIMESYNC requests and our
HEARTBEAT. Everything it sends passes :func:`doctor_codec.is_listen_only`: it never commands the
vehicle (no mode, no arming, no setpoint, no parameter set). What it hears goes to the pure
Observer (onboard/doctor_facts.py); the verdicts are onboard/doctor_checks.py's.
"""
from __future__ import annotations

import asyncio
import contextlib
import logging
import time
from types import SimpleNamespace

from companion.config.secrets import read_signing_key
from companion.config.link import LinkConfig
from companion.config.service import CompanionConfig
from companion.daemon.streams import STREAMS, StreamRequests
from companion.errors import CompanionError
from companion.mavlink import codec, dialect
from companion.mavlink import doctor_codec as dc
from companion.mavlink.link import MavlinkLink, open_link
from companion.onboard import autopilot_dialect
from companion.onboard.doctor_checks import Check, evaluate
from companion.onboard.doctor_facts import Facts, Observer
from companion.onboard.doctor_params import profile_for
from companion.onboard.safety.timesync import TimeSync

log = logging.getLogger(__name__)

ASK_PERIOD_S = 0.5             # AUTOPILOT_VERSION, the origin, parameters, TIMESYNC: this often
MAX_ASKS = 6                   # AUTOPILOT_VERSION, the parameters: at most this many times
ORIGIN_EVERY = 2               # the EKF origin: every this many rounds, until it comes
PLACEHOLDER_SYSTEM_ID = 1


class ListenOnly:
    """The link as the stream requests see it: ``send`` refuses anything that could command."""

    def __init__(self, link: MavlinkLink) -> None:
        self._link = link
        self.now_us = link.now_us

    def send(self, msg):
        if not dc.is_listen_only(msg):
            raise CompanionError(f"doctor: refusing to send {msg.get_type()} (it never "
                                 "commands the vehicle)")
        return self._link.send(msg)


class _Vehicle:
    """What StreamRequests reads of the pipeline: the vehicle's ids, once heard, and the
    autopilot's dialect as the service's identity resolves it (PX4's streams are asked
    differently: daemon/streams.py)."""
    vehicle: tuple[int, int] | None = None
    needs_geo_reference = False

    def __init__(self, link: LinkConfig) -> None:
        self._link = link
        self.identity = SimpleNamespace(dialect=self.dialect_of(None))

    def dialect_of(self, heartbeat_autopilot: int | None) -> autopilot_dialect.Dialect:
        return autopilot_dialect.resolve(self._link.autopilot, heartbeat_autopilot,
                                         self._link.guided_custom_mode)


class Doctor:
    def __init__(self, config: CompanionConfig, link: MavlinkLink) -> None:
        self.config = config
        self.link = link
        self.out = ListenOnly(link)
        self.found = _Vehicle(config.link)
        self.streams = StreamRequests(config.streams, self.out, self.found)
        self.observer = Observer(config, link.now_us() / 1e6)
        self.streams.on_asked = self.observer.streams_asked_at
        self.timesync = TimeSync()
        link.on_connect = self.streams.wanted.set

    async def receive(self) -> None:
        while True:
            received = await self.link.inbox.get()
            msg = received.msg
            event, fact = codec.decode(msg), dc.decode(msg)
            source = (msg.get_srcSystem(), msg.get_srcComponent())
            self.observer.observe(received.t_us / 1e6, dc.message_id(msg), source,
                                  dc.is_signed(msg), event, fact)
            vehicle = self.observer.vehicle
            if vehicle is not None and self.found.vehicle is None:
                self.found.vehicle = (vehicle.system_id, vehicle.component_id)
                self.found.identity.dialect = self.found.dialect_of(vehicle.autopilot)
                if self.config.link.system_id is None:
                    self.link.encoder.system_id = vehicle.system_id
                log.info("vehicle %d/%d: asking for its streams", *self.found.vehicle)
                self.streams.want()
            self.streams.on_event(event)
            if isinstance(event, codec.TimeSyncReply) and self.observer.is_vehicle(source):
                sample = self.timesync.on_reply(event.tc1_ns, event.ts1_ns, time.time_ns())
                if sample is not None:
                    self.observer.round_trip(sample.round_trip_ns)

    async def heartbeat(self) -> None:
        while True:
            self.out.send(codec.heartbeat(codec.mavlink.MAV_STATE_STANDBY))
            await asyncio.sleep(1.0 / self.config.link.heartbeat_rate_hz)

    async def ask(self) -> None:
        """The one-off questions, asked again until answered (at most MAX_ASKS times; the EKF
        origin for as long as it takes), and a TIMESYNC request every ASK_PERIOD_S."""
        asked = {"version": 0, "params": 0}
        obs = self.observer
        rounds = 0
        while True:
            await asyncio.sleep(ASK_PERIOD_S)
            if self.found.vehicle is None:
                continue
            rounds += 1
            sysid, compid = self.found.vehicle
            if obs.firmware is None and asked["version"] < MAX_ASKS:
                asked["version"] += 1
                self.out.send(dc.request_autopilot_version(sysid, compid))
            if obs.origin is None and rounds % ORIGIN_EVERY == 1:
                # until it comes: ArduCopter sets it 30-40 s after boot (as the service asks)
                self.out.send(codec.request_message(sysid, compid,
                                                    dialect.MSG_ID_GPS_GLOBAL_ORIGIN))
            profile = profile_for(obs.vehicle.autopilot if obs.vehicle else None)
            if profile is not None:
                obs.params_asked = profile.params
                missing = [name for name in profile.params if name not in obs.params]
                if missing and asked["params"] < MAX_ASKS:
                    asked["params"] += 1
                    for name in missing:
                        self.out.send(dc.param_request_read(sysid, compid, name))
            self.out.send(codec.timesync_request(self.timesync.request(time.time_ns())))
            obs.timesync_sent += 1

    def facts(self) -> Facts:
        return self.observer.facts(self.link.now_us() / 1e6,
                                   self.link.statistics().signature_rejected)


async def diagnose(config: CompanionConfig, url: str, seconds: float,
                   source: str = "the config") -> tuple[Facts, list[Check]]:
    """Listen on ``url`` for ``seconds`` (asking as the service would), then judge."""
    signing_key = read_signing_key(config.link)
    encoder = codec.Encoder(config.link.system_id or PLACEHOLDER_SYSTEM_ID,
                            config.link.component_id, signing_key)
    async with open_link(url, encoder, config.link.inbox_size, config.link.reconnect_interval_s,
                         signing_key) as link:
        doctor = Doctor(config, link)
        with contextlib.suppress(TimeoutError):
            async with asyncio.timeout(seconds):
                async with asyncio.TaskGroup() as tg:
                    tg.create_task(link.run(), name="receive-link")
                    tg.create_task(doctor.receive(), name="receive")
                    tg.create_task(doctor.heartbeat(), name="heartbeat")
                    tg.create_task(doctor.streams.run(), name="streams")
                    tg.create_task(doctor.ask(), name="ask")
        facts = doctor.facts()
    needed = {msg_id: getattr(config.streams, key) for msg_id, key in STREAMS}
    if doctor.found.identity.dialect.name == "px4":        # ESTIMATOR_STATUS for the EKF's
        needed = {codec.px4_stream_request(msg_id, hz)[0]: hz for msg_id, hz in needed.items()}
    return facts, evaluate(facts, config, needed, source)
