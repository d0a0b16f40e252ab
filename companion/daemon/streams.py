"""The telemetry the service asks the vehicle for, and the watch that it keeps coming.

The service's ``streams`` and ``geo-reference`` tasks and the rate part of its watchdog: each
stream by SET_MESSAGE_INTERVAL (acked, retried), else the REQUEST_DATA_STREAM fallback; asked
again when odometry stays away after asking, or arrives slower than asked (bounded:
companion/onboard/stream_rates.py); for a latitude/longitude goal, the EKF origin and HOME
asked for until known. Wiring only: what to ask is the config's, when to ask again the
StreamRateWatch's.
"""
from __future__ import annotations

import asyncio
import logging
from typing import Callable

from companion.config.service import StreamsConfig
from companion.mavlink import codec, dialect
from companion.mavlink.link import MavlinkLink
from companion.onboard.pipeline import Pipeline
from companion.onboard.stream_rates import StreamRateWatch

log = logging.getLogger(__name__)

WATCHDOG_INTERVAL_S = 0.2
STREAMS = ((dialect.MSG_ID_ATTITUDE, "attitude_rate_hz"),
           (dialect.MSG_ID_LOCAL_POSITION_NED, "local_position_rate_hz"),
           (dialect.MSG_ID_EXTENDED_SYS_STATE, "landed_state_rate_hz"),      # flight phases
           (dialect.MSG_ID_GLOBAL_POSITION_INT, "global_position_rate_hz"),
           (dialect.MSG_ID_GPS_RAW_INT, "gps_raw_rate_hz"),                # position fusion 'auto'
           (dialect.MSG_ID_EKF_STATUS_REPORT, "ekf_status_rate_hz"))
ODOMETRY_STREAMS = (dialect.MSG_ID_ATTITUDE, dialect.MSG_ID_LOCAL_POSITION_NED)
GEO_REFERENCE_RETRY_S = 2.0      # a lat/lon goal: ask for GPS_GLOBAL_ORIGIN and HOME this often


class StreamRequests:
    """Asks for the streams (``run``) whenever ``wanted`` is set, and watches their rates."""

    def __init__(self, streams: StreamsConfig, link: MavlinkLink, pipeline: Pipeline) -> None:
        self.config = streams
        self.link = link
        self.pipeline = pipeline
        self.wanted = asyncio.Event()
        self.vehicle_changed = asyncio.Event()   # set by want(): the geo reference asked at once
        self.acks: asyncio.Queue[codec.CommandAck] = asyncio.Queue(maxsize=16)
        self.odometry_seen = asyncio.Event()
        # The odometry streams' rates are watched (what the estimate and the setpoints run on);
        # the slow ones (landed state, GPS health) are asked for with them.
        self.rates = StreamRateWatch({msg_id: getattr(streams, key) for msg_id, key in STREAMS
                                      if msg_id in ODOMETRY_STREAMS},
                                     streams.rate_check_s, streams.min_rate_fraction,
                                     streams.max_reasserts)
        self._rates_said = False
        self.on_asked: Callable[[float], None] | None = None   # after each round of requests

    def want(self) -> None:
        """Ask for the streams again, and for the EKF origin at once if it is still wanted
        (vehicle found, heartbeat back, reboot)."""
        self.wanted.set()
        self.vehicle_changed.set()

    def on_event(self, event) -> None:
        """A received event: the vehicle's acks, odometry seen, the odometry streams counted."""
        vehicle = self.pipeline.vehicle
        if isinstance(event, codec.CommandAck) and codec.is_ack_for(event, "set_mode") \
                and vehicle == (event.system_id, event.component_id):
            log.log(logging.INFO if event.accepted else logging.WARNING,   # ours, or a GCS's
                    "DO_SET_MODE answered: %s (result %d)",
                    "accepted" if event.accepted else "refused", event.result)
        if isinstance(event, codec.CommandAck) and vehicle == (
                event.system_id, event.component_id) and not self.acks.full():
            self.acks.put_nowait(event)
        elif isinstance(event, codec.LocalPosition):
            self.odometry_seen.set()
        if isinstance(event, (codec.Attitude, codec.LocalPosition)) and vehicle == (
                event.system_id, event.component_id):
            self.rates.on_message(dialect.MSG_ID_ATTITUDE if isinstance(event, codec.Attitude)
                                  else dialect.MSG_ID_LOCAL_POSITION_NED)

    def check_rates(self, now_s: float) -> None:
        """The watchdog's look at the odometry streams' rates (link time ``now_s``)."""
        if self.pipeline.vehicle is None or not self.odometry_seen.is_set():
            return                        # run() is still asking
        gave_up = set(self.rates.gave_up)
        again = self.rates.check(now_s)
        if again:
            rates = self.rates.last_measured_hz
            got = ", ".join(f"{m} at {rates[m]:.1f} Hz (asked {self.rates.asked_hz[m]:g})"
                            for m in again)
            if not self._rates_said:
                # Once: what it got and why. A ground station or router on the same link
                # (MAVProxy, Mission Planner, QGC: 4 Hz by default) sets the vehicle's stream
                # rates with REQUEST_DATA_STREAM, and ArduPilot keeps one set per link.
                log.warning("streams %s: another client on this link (a ground station or "
                            "router) sets the vehicle's stream rates; asking again at most %d "
                            "times, flying at the rate that comes", got,
                            self.config.max_reasserts)
                self._rates_said = True
            else:
                log.debug("streams %s: asking again", got)
            self.wanted.set()
        for msg_id in sorted(self.rates.gave_up - gave_up):
            log.info("stream %d stays at %.1f Hz: not asked again; estimate and decisions run "
                     "at that rate", msg_id, self.rates.last_measured_hz.get(msg_id, 0.0))

    async def run(self) -> None:
        streams = self.config
        while True:
            await self.wanted.wait()
            self.wanted.clear()
            if self.pipeline.vehicle is None:
                continue                      # 'vehicle found' will ask again
            self.odometry_seen.clear()
            px4 = self.pipeline.identity.dialect.name == "px4"
            for msg_id, rate_key in STREAMS:
                rate_hz = getattr(streams, rate_key)
                if px4:        # ESTIMATOR_STATUS, and never below PX4's onboard rates
                    msg_id, rate_hz = codec.px4_stream_request(msg_id, rate_hz)
                await self._request_stream(msg_id, rate_hz)
            self.rates.restart(self.link.now_us() / 1e6)
            if self.on_asked is not None:
                self.on_asked(self.link.now_us() / 1e6)
            try:
                async with asyncio.timeout(streams.rerequest_after_s):
                    await self.odometry_seen.wait()
            except TimeoutError:
                log.warning("no odometry %.1f s after asking: asking again",
                            streams.rerequest_after_s)
                self.wanted.set()

    async def _request_stream(self, msg_id: int, rate_hz: float) -> None:
        streams = self.config
        sysid, compid = self.pipeline.vehicle
        while not self.acks.empty():
            self.acks.get_nowait()
        for _ in range(streams.attempts):
            self.link.send(codec.set_message_interval(sysid, compid, msg_id, rate_hz))
            ack = await self._wait_for_ack(streams.ack_timeout_s)
            if ack is not None and ack.accepted:
                log.info("message %d at %.1f Hz: accepted", msg_id, rate_hz)
                return
            if ack is not None:
                log.warning("SET_MESSAGE_INTERVAL %d refused (result %d)", msg_id, ack.result)
                break
        if msg_id not in codec.DATA_STREAMS_FOR:
            log.warning("message %d: not granted and in no data stream; going without it", msg_id)
            return
        log.warning("message %d: falling back to REQUEST_DATA_STREAM", msg_id)
        self.link.send(codec.request_data_stream(sysid, compid, msg_id, rate_hz))

    async def _wait_for_ack(self, timeout_s: float) -> codec.CommandAck | None:
        try:
            async with asyncio.timeout(timeout_s):
                while True:
                    ack = await self.acks.get()
                    if codec.is_set_message_interval_ack(ack):
                        return ack
        except TimeoutError:
            return None

    async def ask_geo_reference(self) -> None:
        """A latitude/longitude goal needs the EKF origin (or HOME): ask until it is known.
        ArduCopter sets its origin once the EKF has a position (30-40 s after boot in SITL)."""
        while True:
            if self.pipeline.vehicle is not None and self.pipeline.needs_geo_reference:
                sysid, compid = self.pipeline.vehicle
                for msg_id in (dialect.MSG_ID_GPS_GLOBAL_ORIGIN, dialect.MSG_ID_HOME_POSITION):
                    self.link.send(codec.request_message(sysid, compid, msg_id))
                await asyncio.sleep(GEO_REFERENCE_RETRY_S)
            else:
                # Ask as soon as the vehicle is found, not on the next poll: a lock-step flight
                # is ~100x, and 0.2 s of wall time is past the first obstacle.
                self.vehicle_changed.clear()
                try:
                    async with asyncio.timeout(WATCHDOG_INTERVAL_S):
                        await self.vehicle_changed.wait()
                except TimeoutError:
                    pass
