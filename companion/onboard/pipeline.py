"""The companion's decisions as a pure function of the ordered inbound message stream.

Both the live service and ``companion replay`` push decoded events through :class:`Pipeline`,
each with the timestamp its link (or the tlog) attached; the pipeline returns what to send. It
owns no socket and reads no clock, so a recorded stream replays to the same estimates and the
same setpoints.

Clocks. The estimator and every guidance decision run on the vehicle's time since boot
(``time_boot_ms``), carried by the messages. The link timestamp (``t_link_s``: the loop clock
live, the tlog's record time in replay) is used for one thing only: whether the vehicle's
heartbeat is fresh enough to command it.

Rules (docs/messages.md repeats them):
- The vehicle is the first heartbeat from an autopilot (or the pinned ids). Obstacle reports are
  accepted from the vehicle's system, autopilot or camera component; everything else is ignored.
- Odometry: one sample per LOCAL_POSITION_NED (its use: odometry_intake), paired with the ATTITUDE
  of the same time_boot_ms (the position waits for it until the next position arrives), else
  with the latest earlier ATTITUDE, its yaw carried forward by its yaw rate over the gap (at
  most ``max_attitude_age_s``, else the sample is skipped).
- A decision (guidance, urgency, maybe a setpoint) follows each odometry sample once a setpoint
  period of message time has passed, and each obstacle report the filter absorbed.
- Setpoints only while the fresh heartbeat says armed and GUIDED (OFFBOARD on PX4) and the flight
  phase (onboard/flight_phase.py) is airborne; they hold an altitude. PX4, airborne outside
  OFFBOARD: a hold stream, the signal its switch to OFFBOARD needs (onboard/autopilot_dialect.py).
- A goal given as latitude/longitude waits for the EKF origin (or HOME) to become metres.
- Stale camera or an unhealthy filter: the configured safe action (hold: velocity 0, current yaw).
- PARAM_* from a ground station (companion/onboard/parameters.py): reads and sets answered at once,
  the list one at a time at link.param_rate_hz (param_tick); a live set changes the config at
  the next message boundary with no camera frame in assembly, never mid-decision.

The pipeline is a composition of parts, one job each; this module's own: the order of the
stream (handle), the clock's verdict on the autopilot's messages, each odometry sample into the
estimator, a queued live parameter set applied at the safe point.

  identity.py          the vehicle, its heartbeat, whether it may be commanded
  attitude_pairing.py  each position's yaw from the ATTITUDE of its time
  camera_frames.py     obstacle reports in vehicle time, gathered into frames
  depth_intake.py      a service's own depth frames: capture time, tilt and pose, into the map
  goals.py             the goal, the mission, a "fly to here", the arrival
  commander.py         decisions, setpoints, the safe action, the flight phase said
  outputs.py           the events for the service; the track, the map, our pose and movers
                       out; ``snapshot``, the results as plain data
  param_requests.py    PARAM_* answered, a live set queued for the next safe point

The parts read the config through the pipeline when they use it (a live parameter set
replaces it), never a copy taken at construction. (over 400 lines: the stream's order is one
function's with its few hooks into the parts; split, the order would be spread over files.)
"""
from __future__ import annotations

import logging
import math

import numpy as np

from companion.config.checks import PLAUSIBLE_SPEED_MPS
from companion.config.service import CompanionConfig, GoalConfig
from companion.core.estimation.position_reset import PositionResetWatch, UnaidedDrift
from companion.core.geometry import wrap_angle
from companion.core.navigation.navigator import Navigator
from companion.mavlink import codec, mission_codec
from companion.onboard import odometry_intake
from companion.onboard.autopilot_dialect import OffboardEntry
from companion.onboard.attitude_pairing import TIME_EPS_S, AttitudePairing, plausible_attitude
from companion.onboard.camera_frames import CameraFrames
from companion.onboard.depth_intake import DepthIntake
from companion.onboard.commander import Commander
from companion.onboard.flight_phase import FlightPhase, VerticalHold
from companion.onboard.goals import Goals
from companion.onboard.health import HealthInputs
from companion.onboard.heights import ServiceHeights
from companion.onboard.identity import VehicleIdentity
from companion.onboard.look_around import LookAround
from companion.onboard.outputs import (Arrived, EstimateOutputs, NavigatorStarted,  # noqa: F401
                                       Output, StreamsWanted, snapshot)
from companion.onboard.param_requests import ParamRequests
from companion.onboard.parameters import ParamRequest
from companion.onboard.safety.clock import ClockLimits, VehicleClock
from companion.onboard.safety.gate import SetpointGate, SetpointLimits
from companion.onboard.safety.liveness import Liveness
from companion.onboard.safety.timesync import TimeSync

log = logging.getLogger(__name__)

MISSION_EVENTS = (mission_codec.MissionCount, mission_codec.MissionItem, mission_codec.MissionAck,
                  mission_codec.MissionCurrent, mission_codec.MissionItemReached,
                  mission_codec.MissionRequestSeen)


class Pipeline:
    """Vehicle tracking, odometry pairing, estimation, guidance and commanding rules."""

    def __init__(self, config: CompanionConfig, goal: GoalConfig | None,
                 record_track: bool = False, track_limit: int | None = None) -> None:
        """``goal`` None: estimate only (a foreign tlog without a mission): no decisions.

        ``track_limit``: keep only the latest rows of the track (the live daemon flies for
        hours; a replay of a finite file keeps it all).
        """
        self.config = config
        link, safety = config.link, config.safety
        self.navigator: Navigator | None = None
        self.reset_counter = 0
        self.counters: dict[str, int] = {}
        self.clock = VehicleClock(ClockLimits(safety.clock_behind_tolerance_s,
                                              safety.clock_ahead_window_s,
                                              safety.clock_evidence_messages))
        # TIMESYNC with the autopilot, asked for by the service once a camera stamps in Unix time
        self.timesync = TimeSync()
        self.liveness = Liveness(link.heartbeat_timeout_s, config.failsafe.obstacle_timeout_s,
                                 config.failsafe.require_camera)
        self.gate = SetpointGate(SetpointLimits(
            config.commanding.max_speed_mps, safety.max_vertical_speed_mps,
            safety.max_yaw_rate_rad_s, safety.max_position_m))
        self.position_health = odometry_intake.PositionHealth(config.estimator)
        self.position_watch = PositionResetWatch(config.estimator.position_reset_params())
        self.unaided_drift = UnaidedDrift(config.estimator.unaided_velocity_sigma_mps)
        self.position_resets: list[dict] = []       # {t_s, offset_m}: estimate restarted from a fix
        self.estimator_notices = odometry_intake.EstimatorNotices()
        self.ap_yaw_rad: float | None = None        # autopilot yaw at the last odometry sample
        self.ap_speed_mps = 0.0                     # ground speed at the last odometry sample
        # a start that finds the vehicle armed: hold and look round first (onboard/look_around.py)
        self.look_around = LookAround(config.restart.params(config.safety_distance_m))
        self.started_t_s: float | None = None
        self.phase = FlightPhase(config.flight.params())
        self.offboard = OffboardEntry(config.px4.params())    # PX4 only (autopilot_dialect.py)
        self.vertical = VerticalHold(config.flight.params())
        self.heights = ServiceHeights(config)          # avoidance.vertical (onboard/heights.py)
        # the parts
        self.identity = VehicleIdentity(self)
        self.attitude = AttitudePairing()
        self.frames = CameraFrames(self)
        self.depth = DepthIntake(self)      # fed only with perception.depth.source set
        self.goals = Goals(self, goal)
        self.commander = Commander(self)
        self.outputs = EstimateOutputs(config.map_out, record_track, track_limit)
        self.param_requests = ParamRequests(self, config)   # a live set waits for a safe point

    # ------------------------------------------------------------ entry point
    def handle(self, t_link_s: float, event: codec.Event | None) -> list[Output]:
        """One inbound event, stamped by the link; returns what to send or do, in order."""
        out: list[Output] = []
        self.identity.check_heartbeat_age(t_link_s)
        if event is None:
            return out
        if isinstance(event, ParamRequest):       # not flight data: a camera frame stays whole
            self.param_requests.on_request(t_link_s, event, out)
            return out
        frames, identity = self.frames, self.identity
        if frames.idle_due(t_link_s):
            frames.close_idle(out)                # (the service's timer may have come late)
        elif frames.assembly is not None and not frames.assembly.continued_by(event):
            frames.flush(out)
        if self.param_requests.pending is not None and frames.assembly is None:
            self._apply_config()                  # the safe point: no decision under way
        if isinstance(event, codec.Heartbeat):
            identity.on_heartbeat(t_link_s, event, out)
        elif isinstance(event, mission_codec.GoalRequest):
            self.goals.on_goal_request(event, out)
        elif not identity.from_vehicle_system(event):
            self.count("ignored_other_source")
        elif isinstance(event, codec.Attitude) and identity.is_vehicle(event):
            if self._timed(t_link_s, event, out) and self._plausible_attitude(event):
                if self.depth_source:
                    self.depth.on_attitude(event.t_s, event.roll_rad, event.pitch_rad,
                                           event.yaw_rate_rad_s)
                held = self.attitude.add(event)
                if held is not None:
                    self._on_position(t_link_s, held, out)
        elif isinstance(event, codec.LocalPosition) and identity.is_vehicle(event):
            if self._timed(t_link_s, event, out):
                self._pair_position(t_link_s, event, out)
        elif isinstance(event, codec.ObstacleFrame):
            frames.on_obstacles(t_link_s, event, out)
        elif isinstance(event, (codec.GpsFix, codec.EkfStatus)) and identity.is_vehicle(event):
            self.position_health.note(event, self.clock.latest_t_s)
        elif isinstance(event, MISSION_EVENTS) and identity.is_vehicle(event):
            self.goals.on_mission_event(t_link_s, event, out)
        elif identity.is_vehicle(event):
            self._on_flight_data(event)
        return out

    # ------------------------------------------------------------ the parts' state, by name
    vehicle = property(lambda self: self.identity.vehicle)
    other_vehicles = property(lambda self: self.identity.other_vehicles)
    armed = property(lambda self: self.identity.armed)
    custom_mode = property(lambda self: self.identity.custom_mode)
    goal = property(lambda self: self.goals.goal)
    goal_ne = property(lambda self: self.goals.goal_ne)
    mission = property(lambda self: self.goals.mission)
    arrival_t_s = property(lambda self: self.goals.arrival_t_s)
    needs_geo_reference = property(lambda self: self.goals.needs_geo_reference,
                                   doc="A latitude/longitude goal waits for the EKF origin.")
    last_command = property(lambda self: self.commander.last_command)
    urgency = property(lambda self: self.commander.urgency)
    setpoints = property(lambda self: self.commander.setpoints)
    phase_changes = property(lambda self: self.commander.phase_changes)
    wants_timesync = property(lambda self: self.frames.wants_timesync)
    record_track = property(lambda self: self.outputs.record_track)
    track = property(lambda self: self.outputs.track)
    params = property(lambda self: self.param_requests.server)

    @property
    def depth_source(self) -> bool:
        """The service reads depth frames itself (perception.depth.source)."""
        return self.config.perception.depth.source is not None

    @property
    def safe_reason(self) -> str | None:
        """Why the safe action is on now (None: guidance as planned)."""
        return self.commander.safe_reason

    @property
    def heartbeat_link_s(self) -> float | None:
        """Link time of the vehicle's last heartbeat."""
        return self.liveness.heartbeat_link_s

    @property
    def latest_t_s(self) -> float | None:
        """The vehicle's latest believed time since boot."""
        return self.clock.latest_t_s

    def commanding_allowed(self, t_link_s: float) -> bool:
        """Armed, in the steering mode (GUIDED, OFFBOARD on PX4), and the vehicle's heartbeat is
        fresh: setpoints may be sent."""
        return self.identity.commanding_allowed(t_link_s)

    def stop_setpoint(self, t_link_s: float) -> list[Output]:
        """Zero velocity at the current yaw, through the gate, if commanding (on shutdown).
        It is the last setpoint: nothing is sent after it."""
        return self.commander.stop_setpoint(t_link_s)

    def mission_tick(self, t_link_s: float) -> list[Output]:
        """Mission download timeouts and retries (the service calls this on its timer)."""
        return self.goals.mission_tick(t_link_s)

    def param_tick(self, t_link_s: float) -> list[Output]:
        """The parameter list's values due now (the service calls this on its timer)."""
        return list(self.param_requests.tick(t_link_s))

    def count(self, kind: str) -> None:
        self.counters[kind] = self.counters.get(kind, 0) + 1

    # ------------------------------------------------------------ parameters
    def _apply_config(self) -> None:
        """The running config after a live parameter set; the navigator's guidance follows."""
        self.config, self.param_requests.pending = self.param_requests.pending, None
        if self.navigator is not None:
            self.navigator.params = self.config.guidance_params(self.navigator.params.goal_radius_m)
        self.count("param_applied")

    def health_inputs(self, t_link_s: float) -> HealthInputs:
        """What companion/onboard/health.py judges the HEARTBEAT and SYS_STATUS from."""
        t_s = self.clock.latest_t_s
        commanding = self.commanding_allowed(t_link_s) and t_s is not None \
            and self.phase.decide(t_s).may_command
        nav = self.navigator
        return HealthInputs(
            vehicle_found=self.vehicle is not None, link_lost=self.identity.link_lost,
            commanding=commanding, safe_reason=self.safe_reason,
            deciding=nav is not None and self.goal_ne is not None,
            camera_live=t_s is not None and not self.liveness.camera_stale(t_s),
            estimator_state=nav.health.state if nav is not None and nav.health is not None
            else None)

    def _on_flight_data(self, event) -> None:
        """Flight phase inputs and the goal's geographic reference."""
        if isinstance(event, codec.LandedState) and self.clock.latest_t_s is not None:
            self.phase.on_landed_state(self.clock.latest_t_s, event.landed_state)
            self.commander.note_phase()
        elif isinstance(event, codec.GlobalPosition) and math.isfinite(event.t_s):
            self.phase.on_relative_alt(event.t_s, event.relative_alt_m, event.vel_down_mps)
            self.commander.note_phase()
        elif isinstance(event, codec.GeoReference):
            self.goals.on_geo_reference(event)

    # ------------------------------------------------------------ clock and odometry
    def _timed(self, t_link_s: float, event, out: list[Output]) -> bool:
        """Judge an autopilot message's time (safety/clock.py). Refused stamps are counted; those
        on a candidate clock are kept, and handled once that clock is adopted (reboot, jump)."""
        before = self.clock.latest_t_s
        verdict = self.clock.on_autopilot(event.t_s, (t_link_s, event))
        if verdict.reason == "ok":
            return True
        if not verdict.accepted:
            self.count(f"time_{verdict.reason}")
            return False
        evidence = verdict.held
        if verdict.reason == "reboot":
            log.warning("vehicle time went back %.1f s -> %.1f s on %d messages and a heartbeat: "
                        "reboot, estimate reset", before, event.t_s, len(evidence) + 1)
            self.reset_estimate()
            self.liveness.forget_camera()
            self.frames.epoch_camera.forget()
            self.timesync.forget()
            out.append(StreamsWanted("vehicle reboot"))
            out.append(codec.Notice(codec.SEVERITY_WARNING, "companion: vehicle reboot, map reset"))
        else:
            log.warning("vehicle time jumped ahead %.1f s -> %.1f s on %d messages: accepted",
                        before, event.t_s, len(evidence) + 1)
        for t_link_held, held in evidence:
            out.extend(self.handle(t_link_held, held))
        self.clock.settle(event.t_s)
        return True

    def reset_estimate(self) -> None:
        """The estimate restarts from the next good sample (reboot, divergence, position reset)."""
        self.navigator = None
        self.commander.reset()
        self.reset_counter += 1
        self.attitude.clear()
        self.depth.reset()
        self.outputs.reset()

    def _reset_position(self, lpn: codec.LocalPosition, offset_m: float, reason: str,
                        out: list[Output]) -> None:
        """The autopilot's fixes stay refused (a GPS back after a long outage): the estimate
        restarts from its position at the next sample, the map dropped (README, "GPS outage and
        return": the landmarks mapped before and during the outage drifted by different amounts,
        no single shift puts them all right; the camera maps what is in view again)."""
        log.warning("position reset at %.1f s: %s, %.1f m off; estimate restarted from the "
                    "autopilot's position, map dropped", lpn.t_s, reason, offset_m)
        self.count("position_reset")
        self.position_resets.append({"t_s": lpn.t_s, "offset_m": offset_m})
        self.reset_estimate()
        out.append(codec.Notice(codec.SEVERITY_WARNING,
                                f"companion: position reset ({offset_m:.0f} m), map dropped"))

    def _plausible_attitude(self, att: codec.Attitude) -> bool:
        if not plausible_attitude(att):
            self.count("attitude_implausible")
            return False
        return True

    def _pair_position(self, t_link_s: float, lpn: codec.LocalPosition, out: list[Output]) -> None:
        """Use the ATTITUDE of the same time_boot_ms: if it has not come yet, hold the position
        until it does, or until the next position (then the older attitude, carried forward).
        The held position goes first, and may restart the estimate (the attitudes dropped):
        only then is ``lpn``'s cover looked at."""
        held = self.attitude.take_held()
        if held is not None:
            self._on_position(t_link_s, held, out)
        if self.attitude.covers(lpn.t_s):
            self._on_position(t_link_s, lpn, out)
        else:
            self.attitude.hold(lpn)

    def _on_position(self, t_link_s: float, lpn: codec.LocalPosition, out: list[Output]) -> None:
        self.phase.on_local_position(lpn.t_s, lpn.down_m, lpn.vel_down_mps)
        self.commander.note_phase()
        yaw = self.attitude.yaw_at(lpn.t_s, self.config.commanding.max_attitude_age_s)
        if yaw is None:
            self.count("odometry_without_attitude")
            return
        speed = math.hypot(lpn.vel_north_mps, lpn.vel_east_mps)
        if math.isfinite(speed) and speed > max(PLAUSIBLE_SPEED_MPS,
                                                5.0 * self.config.commanding.max_speed_mps):
            # finite but absurd (3e38 m/s): it would blow the covariance up to inf and NaN
            self.count("odometry_implausible_speed")
            return
        if self.navigator is None:
            if not (math.isfinite(lpn.north_m) and math.isfinite(lpn.east_m)
                    and math.isfinite(yaw)):
                self.count("start_not_finite")
                return
            limit_m = self.config.safety.max_position_m
            if abs(lpn.north_m) > limit_m or abs(lpn.east_m) > limit_m:
                self.count("start_implausible")
                return
            self.navigator = self._make_navigator(lpn.north_m, lpn.east_m, yaw)
            self.started_t_s = lpn.t_s
            log.info("estimator started at %.1f s: north %.1f m, east %.1f m, yaw %.1f deg",
                     lpn.t_s, lpn.north_m, lpn.east_m, math.degrees(yaw))
            out.append(NavigatorStarted(lpn.t_s))
        nav = self.navigator
        before = nav.t_s
        reports, verdict = odometry_intake.absorb(nav, self.config.estimator, self.position_health,
                                                  lpn, yaw, self.attitude.yaw_rate_rad_s,
                                                  self.position_watch, self.unaided_drift)
        if verdict is not None and verdict.reset:
            self._reset_position(lpn, verdict.offset_m, verdict.reason, out)
            return
        if nav.t_s == before and before is not None:
            self.count("odometry_not_newer")
            return
        self.ap_yaw_rad, self.ap_speed_mps = yaw, speed
        self.outputs.record(lpn.t_s, nav)
        if self.depth_source:
            self.depth.on_estimate(lpn.t_s, nav, self.phase.up_at(lpn.t_s))
        last = self.commander.last_decision_t_s
        due = (last is None or lpn.t_s - last
               >= self.config.commanding.setpoint_period_s - TIME_EPS_S)
        if (reports or due) and self.goal_ne is not None:
            self.commander.decide(t_link_s, lpn.t_s, out)
        # After the decision: a lock-step stub takes our ODOMETRY as the sign that everything we
        # do for this sample has been sent (companion/daemon/lockstep.py). A diverged estimator is
        # restarted by the decision (navigator None until the next good sample): nothing to say.
        if self.navigator is not None:
            self.outputs.publish(lpn.t_s, self.navigator, self.config.commanding.odometry_rate_hz,
                                 self.reset_counter, out)

    def _make_navigator(self, north_m: float, east_m: float, yaw_rad: float) -> Navigator:
        est = self.config.estimator
        goal_ne = self.goal_ne or (north_m, east_m)    # no goal yet: replaced once known
        radius_m = self.goals.goal_radius_m             # no goal: no guidance
        pose_cov = np.diag([est.initial_position_sigma_m ** 2, est.initial_position_sigma_m ** 2,
                            math.radians(est.initial_yaw_sigma_deg) ** 2])
        return Navigator(np.array([north_m, east_m, wrap_angle(yaw_rad)]), pose_cov,
                         est.slam_noise(), est.gates(), self.config.guidance_params(radius_m),
                         np.array(goal_ne),
                         self.config.avoidance.strategy, self.config.union_params(),
                         est.mover_params(), est.options(), limits=self.config.vehicle_limits(),
                         look_at=self.config.look_at_params(),
                         goal_look=self.config.goal_look_params(),
                         extent=self.heights.extent, vertical=self.heights.vertical_params(None))
