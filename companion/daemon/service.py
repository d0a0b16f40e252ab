"""``companion run`` wiring: link, tlog, pipeline and timers in one asyncio task tree.

No maths here. The :class:`~companion.onboard.pipeline.Pipeline` decides everything from the inbound
stream; this module only adds what a live daemon needs on top: sockets (the link), wall-clock
timers (our heartbeat, the vehicle-heartbeat watchdog, stream requests, tlog flushing) and
sending. Tasks, one job each:

  receive    the link's transport (TCP reconnects)
  estimate   inbox -> tlog -> codec -> pipeline -> send
  heartbeat  our HEARTBEAT (and SYS_STATUS) at link.heartbeat_rate_hz, the state from
             companion/onboard/health.py, a STATUSTEXT when it changes
  watchdog   logs vehicle-heartbeat loss; asks for streams again when odometry stays away or
             arrives slower than asked (bounded); reports suppressed STATUSTEXTs
  streams    SET_MESSAGE_INTERVAL (acked, retried), else REQUEST_DATA_STREAM; the EKF origin
             for a lat/lon goal (companion/daemon/streams.py)
  tlog       flush twice a second
  parameters write the parameter overlay after accepted PARAM_SETs (param_overlay.OverlaySaver)
  param-list PARAM_REQUEST_LIST answered at link.param_rate_hz, one list at a time (param_list.py)
  depth      perception.depth.source (``--depth``): frames read and perceived off the loop,
             their observations into the pipeline (companion/daemon/depth_feed.py)
  stop       SIGINT/SIGTERM -> one stop setpoint if commanding -> ShutdownRequested

(over 400 lines: the tasks' wiring, one short method each, reads best in one place.)

With ``lockstep`` (``companion run --lockstep``, against ``sitl-stub --lockstep``) the stamps given
to the pipeline and the tlog, and our heartbeat schedule, come from the vehicle's clock
(companion/daemon/lockstep.py); the watchdog's log lines stay on the wall clock.
"""
from __future__ import annotations

import asyncio
import logging
import math
import signal
import time
from dataclasses import asdict
from pathlib import Path

import yaml

from companion.mavlink import codec, mission_codec, param_codec
from companion.mavlink.link import MavlinkLink, open_link
from companion.mavlink.tlog import TlogWriter
from companion.config.secrets import read_signing_key
from companion.config.service import CompanionConfig, config_to_dict
from companion.daemon.depth_feed import DepthFeed
from companion.daemon.param_list import send_param_list
from companion.daemon.param_overlay import Overlay, OverlaySaver
from companion.errors import ShutdownRequested
from companion.daemon.lockstep import VehicleLinkClock, lockstep_config
from companion.daemon.streams import WATCHDOG_INTERVAL_S, StreamRequests
from companion.onboard import health
from companion.onboard.parameters import ParamChange, ParamValue
from companion.onboard.pipeline import Arrived, NavigatorStarted, Pipeline, StreamsWanted, snapshot
from companion.daemon.json_report import write_json
from companion.daemon.replay import sidecar_config_path
from companion.onboard.safety.notices import NoticeLimiter
from companion.view import feed

log = logging.getLogger(__name__)

TLOG_FLUSH_INTERVAL_S = 0.5
TIMESYNC_FAST_S, TIMESYNC_FAST_COUNT, TIMESYNC_SLOW_S = 1.0, 16, 10.0
# The report keeps the latest hour of track at 10 Hz (about 4 MB); the daemon flies for longer.
REPORT_TRACK_ROWS = 36_000
PLACEHOLDER_SYSTEM_ID = 1        # our system id until the vehicle's is known (if not configured)


class Service:
    """The live daemon around one Pipeline."""

    def __init__(self, config: CompanionConfig, link: MavlinkLink, tlog: TlogWriter | None,
                 report_path: str | Path | None, clock: VehicleLinkClock | None = None,
                 keep_track: bool = False, overlay: Overlay | None = None) -> None:
        self.config = config
        self.overlay = overlay
        self.health: health.Health | None = None
        self.saver = OverlaySaver(overlay) if overlay is not None else None
        self.clock = clock
        self.link = link
        self.tlog = tlog
        self.report_path = report_path
        self.pipeline = Pipeline(config, config.goal,
                                 record_track=report_path is not None or keep_track,
                                 track_limit=REPORT_TRACK_ROWS)
        self.streams = StreamRequests(config.streams, link, self.pipeline)
        self.stop = asyncio.Event()
        self.notices = NoticeLimiter(config.safety.statustext_repeat_s,
                                     config.safety.statustext_per_s)
        # The limiter runs on vehicle time in every mode: off lock-step too the vehicle may run
        # faster than the wall clock (a stub at --speedup 20), and what a ground station sees
        # per second of flight must not depend on that. The lock-step clock is one already;
        # otherwise a clock of its own follows the vehicle's stamps (monotonic across reboots).
        self.notice_clock = clock if clock is not None else VehicleLinkClock(1.0)
        self.param_list_queued = asyncio.Event()     # a PARAM_REQUEST_LIST is being answered
        self._timesyncs_sent = 0
        self._last_timesync_s: float | None = None
        if tlog is not None:
            link.on_sent = tlog.write if clock is None else \
                (lambda _t_us, data: tlog.write(clock.now_us(), data))
        link.on_connect = self.streams.wanted.set
        self.depth: DepthFeed | None = None
        if config.perception.depth.source is not None:
            self.depth = DepthFeed(config.perception.depth.source, self.pipeline,
                                   clock is not None, self._dispatch,
                                   lambda: self._now_us() / 1e6)

    # ------------------------------------------------------------ tasks
    async def estimate(self) -> None:
        link = self.link
        # Stop taking messages once shutdown is asked: the stop setpoint follows the last message
        # handled (and recorded), as replay reproduces it. (inbox.get() does not yield while the
        # inbox holds messages, so the TaskGroup's cancellation alone could come late.)
        while not self.stop.is_set():
            received = await self._next_received()
            if self.stop.is_set():
                break
            if received is None:                # a camera frame complete on idle time
                for output in self.pipeline.frames.close_if_idle(link.now_us() / 1e6):
                    await self._dispatch(output)
                continue
            if self.clock is None:
                await self._handle(received)
                continue
            # Lock-step: what the messages already received make us send, up to our ODOMETRY
            # (the stub's sign to step), goes out together: one wake-up of the stub
            # (companion/daemon/lockstep.py); the messages after it wait for the next answer.
            with link.coalesced():
                while not await self._handle(received) and not link.inbox.empty() \
                        and not self.stop.is_set():
                    received = link.inbox.get_nowait()

    async def _next_received(self):
        """The next message; None if a camera frame waits and ``link.camera_frame_idle_s``
        passes first (on the wall clock; not in lock-step, whose clock is the stub's steps: there
        the next step's messages close the frame, as the tlog's stamps do in replay)."""
        link = self.link
        deadline_s = self.pipeline.frames.idle_deadline_s() if self.clock is None else None
        if deadline_s is None or not link.inbox.empty():
            return await link.inbox.get()
        try:
            return await asyncio.wait_for(link.inbox.get(),
                                          max(deadline_s - link.now_us() / 1e6, 0.0))
        except TimeoutError:
            return None

    async def _handle(self, received) -> bool:
        """One received message: stamp, record, through the pipeline, its outputs out. True if
        they include our ODOMETRY."""
        link, pipeline = self.link, self.pipeline
        event = codec.decode(received.msg)
        t_us = received.t_us if self.clock is None else self.clock.observe(event)
        if self.clock is None and self._is_vehicle(event):
            self.notice_clock.observe(event)
        if self.depth is not None:
            if isinstance(event, codec.Attitude):
                self.depth.attitude_seen.set()
            elif self.clock is not None and isinstance(event, codec.LocalPosition) \
                    and self._is_vehicle(event):
                # lock-step: the step's frames first (companion replay --depth does the same);
                # recorded after them, so that a stop while they are perceived leaves the
                # position neither handled nor in the tlog
                await self.depth.settle(event.t_s)
        if self.tlog is not None:
            self.tlog.write(t_us, codec.packet_bytes(received.msg))
        if self.clock is not None and self.clock.heartbeat_due():
            self._send_identity()
        self.streams.on_event(event)
        if isinstance(event, codec.TimeSyncReply) and self._is_vehicle(event):
            sample = pipeline.timesync.on_reply(event.tc1_ns, event.ts1_ns, time.time_ns())
            if sample is not None and pipeline.timesync.replies == 1:
                log.info("TIMESYNC: vehicle clock = ours %+.6f s (round trip %.1f ms)",
                         sample.offset_ns * 1e-9, sample.round_trip_ns * 1e-6)
        answered = False
        for output in pipeline.handle(t_us / 1e6, event):
            await self._dispatch(output)
            answered = answered or isinstance(output, codec.PoseEstimate)
        if pipeline.param_requests.pacer.sending:
            self.param_list_queued.set()
        return answered

    async def _dispatch(self, output) -> None:
        link = self.link
        if self.config.link.system_id is None and self.pipeline.vehicle is not None:
            link.encoder.system_id = self.pipeline.vehicle[0]
        if isinstance(output, codec.VelocitySetpoint):
            link.send(codec.set_position_target(output))
        elif isinstance(output, codec.PoseEstimate):
            link.send(codec.odometry(output))
        elif isinstance(output, codec.ModeRequest):
            log.info("asking the vehicle for mode %d (%s)", output.custom_mode, output.reason)
            link.send(codec.set_mode_command(output))
        elif isinstance(output, codec.Notice):
            self._send_notice(output)
        elif isinstance(output, codec.MoverReport):
            link.send(codec.mover_obstacle(output))
        elif isinstance(output, codec.SectorMap):
            link.send(codec.obstacle_distance_map(output))
        elif isinstance(output, mission_codec.MissionRequest):
            link.send(mission_codec.encode(output))
        elif isinstance(output, StreamsWanted):
            log.info("asking for telemetry streams: %s", output.reason)
            self.streams.want()
        elif isinstance(output, ParamValue):
            link.send(param_codec.param_value(output))
        elif isinstance(output, ParamChange) and self.saver is not None:
            self.saver.persist(output)
        elif isinstance(output, (NavigatorStarted, Arrived)) and self.report_path:
            await asyncio.to_thread(write_json, self.report_path, self.report(), None)

    def _send_identity(self) -> None:
        """HEARTBEAT and SYS_STATUS as companion/onboard/health.py judges the state; a STATUSTEXT when
        the judgement changes."""
        judged = health.assess(self.pipeline.health_inputs(self._now_us() / 1e6))
        self.link.send(codec.heartbeat(judged.system_status))
        if self.config.link.sys_status:
            self.link.send(codec.sys_status(judged.avoidance_enabled, judged.avoidance_healthy))
        before, self.health = self.health, judged
        if before is not None and (before.state, before.avoidance_healthy) != \
                (judged.state, judged.avoidance_healthy):
            log.info("health: %s (%s), avoidance %s", judged.state, judged.reason,
                     "healthy" if judged.avoidance_healthy else "unhealthy")
            severity = codec.SEVERITY_WARNING if judged.state == "critical" \
                or not judged.avoidance_healthy else codec.SEVERITY_INFO
            self._send_notice(codec.Notice(severity, judged.describe()))

    def _now_us(self) -> int:
        """The service's time: the link's wall clock, or the vehicle's in lock-step (the
        STATUSTEXT limiter runs on vehicle time in either mode: ``notice_clock``)."""
        return self.link.now_us() if self.clock is None else self.clock.now_us()

    def _is_vehicle(self, event) -> bool:
        vehicle = self.pipeline.vehicle
        return vehicle is None or (getattr(event, "system_id", None),
                                   getattr(event, "component_id", None)) == vehicle

    def _notice_s(self) -> float:
        return self.notice_clock.now_us() / 1e6

    def _send_notice(self, notice: codec.Notice) -> None:
        if self.notices.admit(notice.text, self._notice_s()):
            self.link.send(codec.statustext(notice))
        else:
            log.debug("STATUSTEXT suppressed: %s", notice.text)

    def _check_rates(self) -> None:
        """The watchdog's look at suppressed STATUSTEXTs and at the streams' rates."""
        text = self.notices.take_suppressed_report(self._notice_s())
        now_s = self.link.now_us() / 1e6
        if text is not None:
            log.warning("%s (STATUSTEXT limit)", text)
            self.link.send(codec.statustext(codec.Notice(codec.SEVERITY_INFO, text)))
        self.streams.check_rates(now_s)

    async def send_heartbeats(self) -> None:
        period_s = 1.0 / self.config.link.heartbeat_rate_hz
        while True:
            if self.clock is None or not self.clock.started:   # lock-step: see estimate()
                self._send_identity()
            await asyncio.sleep(period_s)

    async def watch(self) -> None:
        """Wall-clock watchdog: says when the vehicle goes silent (the pipeline already refuses
        to command on a stale heartbeat) and asks for streams again when odometry stays away."""
        timeout_s = self.config.link.heartbeat_timeout_s
        silent = False
        loop = asyncio.get_running_loop()
        seen, seen_wall_s = None, 0.0
        while True:
            await asyncio.sleep(WATCHDOG_INTERVAL_S)
            self._check_rates()
            self._maybe_timesync(loop.time())
            now_us = self._now_us()
            for output in self.pipeline.mission_tick(now_us / 1e6):
                await self._dispatch(output)
            last = self.pipeline.heartbeat_link_s
            if last is None:
                continue
            if last != seen:
                seen, seen_wall_s = last, loop.time()
            # lock-step: the link clock stops with the link, so the silence is timed on the wall
            age_s = self.link.now_us() / 1e6 - last if self.clock is None \
                else loop.time() - seen_wall_s
            if age_s > timeout_s and not silent:
                silent = True
                log.warning("no vehicle heartbeat for %.1f s: commanding stopped", age_s)
            elif age_s <= timeout_s and silent:
                silent = False
                log.info("vehicle heartbeat back")

    def _maybe_timesync(self, wall_s: float) -> None:
        """Once a camera stamps in Unix time (and off lock-step, where our clock is the wall's
        and so the camera's): a TIMESYNC request to the autopilot every TIMESYNC_FAST_S for the
        first TIMESYNC_FAST_COUNT, then every TIMESYNC_SLOW_S (safety/timesync.py)."""
        if not self.pipeline.wants_timesync or self.clock is not None \
                or self.pipeline.vehicle is None:
            return
        period = TIMESYNC_FAST_S if self._timesyncs_sent < TIMESYNC_FAST_COUNT else TIMESYNC_SLOW_S
        if self._last_timesync_s is not None and wall_s - self._last_timesync_s < period:
            return
        self._last_timesync_s = wall_s
        self._timesyncs_sent += 1
        self.link.send(codec.timesync_request(self.pipeline.timesync.request(time.time_ns())))

    async def flush_tlog(self) -> None:
        while True:
            await asyncio.sleep(TLOG_FLUSH_INTERVAL_S)
            self.tlog.flush()

    async def raise_on_stop(self) -> None:
        await self.stop.wait()
        # The vehicle would coast on its last velocity until GUID_TIMEOUT: tell it to stop.
        now_us = self._now_us()
        for output in self.pipeline.stop_setpoint(now_us / 1e6):
            if isinstance(output, codec.ModeRequest):     # PX4: Hold after our own OFFBOARD
                await self._dispatch(output)
                continue
            self.link.send(codec.set_position_target(output))
            log.info("shutdown: stop setpoint sent (velocity 0, yaw %.1f deg)",
                     math.degrees(output.yaw_rad))
        raise ShutdownRequested()

    # ------------------------------------------------------------ results
    def report(self) -> dict:
        data = snapshot(self.pipeline)
        data["link"] = asdict(self.link.statistics())
        data["statustext_suppressed"] = self.notices.suppressed
        data["stream_reasserts"] = self.streams.rates.reasserts
        data["stream_rates_hz"] = self.streams.rates.last_measured_hz
        data["phases"] = [list(change) for change in self.pipeline.phase_changes]
        data["setpoints_refused"] = dict(self.pipeline.gate.refused)
        data["config"] = config_to_dict(self.pipeline.config)
        if self.depth is not None:
            data.update(self.depth.snapshot())
        if self.overlay is not None:
            data["parameter_overlay"] = {"path": str(self.overlay.path),
                                         "values": dict(self.overlay.values),
                                         "error": self.overlay.error}
        return data


async def run_service(config: CompanionConfig, url: str, tlog_path: str | Path | None = None,
                      report_path: str | Path | None = None, lockstep: bool = False,
                      view_feed: tuple[str, int] | None = None,
                      overlay: Overlay | None = None,
                      tlog_max_bytes: int | None = None) -> None:
    """Run the daemon until SIGINT/SIGTERM. ``config.goal`` must be set. ``view_feed``:
    (host, port) to send the live view's state to (companion/view/feed.py). ``overlay``: where
    parameters set from a ground station are kept (companion/daemon/param_overlay.py; None: not kept).
    ``tlog_max_bytes``: rotate the tlog at this size (TlogWriter), None: one file, unbounded."""
    loop = asyncio.get_running_loop()
    clock = None
    if lockstep:
        config = lockstep_config(config)
        clock = VehicleLinkClock(1.0 / config.link.heartbeat_rate_hz)
    # The key stays in this frame, the encoder and the parser: never in the config, a log line,
    # the tlog's sidecar or the report (they name the key file only).
    signing_key = read_signing_key(config.link)
    tlog = None
    if tlog_path is not None:
        tlog = TlogWriter(tlog_path, max_bytes=tlog_max_bytes)
        sidecar_config_path(tlog_path).write_text(yaml.safe_dump(config_to_dict(config)))
    encoder = codec.Encoder(config.link.system_id or PLACEHOLDER_SYSTEM_ID,
                            config.link.component_id, signing_key)
    service = None
    try:
        async with open_link(url, encoder, config.link.inbox_size,
                             config.link.reconnect_interval_s, signing_key) as link:
            service = Service(config, link, tlog, report_path, clock, view_feed is not None,
                              overlay)
            for sig in (signal.SIGINT, signal.SIGTERM):
                loop.add_signal_handler(sig, service.stop.set)
            log.info("companion up on %s%s: goal %s", url,
                     f" (local {link.local_address[0]}:{link.local_address[1]})"
                     if link.local_address else "", config.goal.describe())
            log.info("effective config: %s", config_to_dict(config))
            if overlay is not None and overlay.error is not None:
                service._send_notice(codec.Notice(codec.SEVERITY_ERROR,
                                                  "companion: parameter overlay ignored"))
            if signing_key is not None:
                log.info("MAVLink 2 signing on (key from %s): unsigned traffic refused",
                         config.link.signing_key_file)
            try:
                async with asyncio.TaskGroup() as tg:
                    tg.create_task(link.run(), name="receive")
                    tg.create_task(service.estimate(), name="estimate")
                    tg.create_task(service.send_heartbeats(), name="heartbeat")
                    tg.create_task(service.watch(), name="watchdog")
                    tg.create_task(service.streams.run(), name="streams")
                    if config.goal.is_geographic or config.goal.mission or config.fly_to.enabled:
                        tg.create_task(service.streams.ask_geo_reference(),
                                       name="geo-reference")
                    if tlog is not None:
                        tg.create_task(service.flush_tlog(), name="tlog")
                    if overlay is not None:
                        tg.create_task(service.saver.run(), name="parameters")
                    tg.create_task(send_param_list(service.pipeline, service.param_list_queued,
                                                   lambda: service._now_us() / 1e6,
                                                   service._dispatch), name="param-list")
                    if service.depth is not None:
                        tg.create_task(service.depth.run(), name="depth")
                    if view_feed is not None:
                        tg.create_task(feed.publish(service.pipeline, view_feed), name="view-feed")
                    tg.create_task(service.raise_on_stop(), name="stop")
            except* ShutdownRequested:
                log.info("clean shutdown: %s", link.statistics())
    finally:
        for sig in (signal.SIGINT, signal.SIGTERM):
            loop.remove_signal_handler(sig)
        if tlog is not None:
            tlog.close()
        if service is not None and service.depth is not None:
            service.depth.close()
        if service is not None and service.saver is not None:
            service.saver.write_if_dirty()
        if service is not None and report_path is not None:
            write_json(report_path, service.report(), indent=None)
