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
- Setpoints only while the last vehicle heartbeat says armed and GUIDED and is fresh, and the
  flight phase (companion/onboard/flight_phase.py) is airborne; they hold an altitude (vz term).
- A goal given as latitude/longitude waits for the EKF origin (or HOME) to become metres.
- Stale camera or an unhealthy filter: the configured safe action (hold: velocity 0, current yaw).
- PARAM_* from a ground station (companion/onboard/parameters.py): answered at once; a live set changes
  the config at the next message boundary with no camera frame in assembly, never mid-decision.
"""
from __future__ import annotations

import dataclasses
import logging
import math
from array import array
from collections import deque
from dataclasses import asdict, dataclass, field

import numpy as np

from companion.onboard import odometry_intake
from companion.core.sample_interval import setpoint_interval_s
from companion.mavlink import codec
from companion.config.checks import PLAUSIBLE_SPEED_MPS
from companion.config.service import CompanionConfig, GoalConfig
from companion.core.perception.blobs import BlobParams, sector_observations
from companion.core.geometry import wrap_angle
from companion.core.avoidance.guidance import shape_setpoint
from companion.core.navigation.navigator import Navigator
from companion.onboard.safety.clock import ClockLimits, EpochCamera, VehicleClock
from companion.onboard.safety.gate import SetpointGate, SetpointLimits
from companion.onboard.safety.liveness import Liveness
from companion.onboard.flight_phase import FlightPhase, VerticalHold
from companion.onboard.heights import ServiceHeights
from companion.onboard.goal import goal_north_east
from companion.onboard.map_output import MapPublisher
from companion.mavlink import mission_codec
from companion.onboard.mission_follow import MissionFollower
from companion.onboard import fly_to
from companion.onboard.health import HealthInputs
from companion.onboard.parameters import ParamChange, ParamRequest, ParamServer, ParamValue
from companion.core.estimation.position_reset import PositionResetWatch, UnaidedDrift
from companion.onboard.safety.timesync import TimeSync

log = logging.getLogger(__name__)

# Beyond these, a finite value is still nonsense (no multicopter, no stereo camera): refused
# (PLAUSIBLE_SPEED_MPS, the config's bound on a multicopter's speed, too).
PLAUSIBLE_RANGE_M = 1000.0
PLAUSIBLE_YAW_RATE_RAD_S = 20.0  # ArduCopter's fastest yaw is well under 10 rad/s
ATTITUDE_HISTORY = 32
TIME_EPS_S = 1e-6


@dataclass(frozen=True)
class StreamsWanted:
    """Ask the vehicle for its telemetry streams (again)."""
    reason: str


@dataclass(frozen=True)
class NavigatorStarted:
    t_s: float


@dataclass(frozen=True)
class Arrived:
    t_s: float


PHASE_CHANGES_KEPT = 1000          # flight phase changes kept for the report
MISSION_EVENTS = (mission_codec.MissionCount, mission_codec.MissionItem, mission_codec.MissionAck,
                  mission_codec.MissionCurrent, mission_codec.MissionItemReached,
                  mission_codec.MissionRequestSeen)

Output = codec.VelocitySetpoint | codec.PoseEstimate | codec.Notice | codec.MoverReport \
    | codec.SectorMap | mission_codec.MissionRequest | StreamsWanted \
    | NavigatorStarted | Arrived | ParamValue | ParamChange


@dataclass(frozen=True)
class UrgencyRecord:
    t_s: float
    state: str                      # 'urgent' or 'cleared'
    obstacle_id: int | None
    landmark_index: int | None
    time_to_go_s: float | None


@dataclass
class _FrameAssembly:
    """One camera frame's observations, gathered from the messages that carry its time."""
    system_id: int
    component_id: int
    stamp_s: float                  # as the messages carry it (Unix time from an epoch camera)
    t_s: float                      # in vehicle time
    t_link_s: float
    observations: list = field(default_factory=list)

    def continued_by(self, event) -> bool:
        """Another message of this frame: an obstacle report from the same camera, same time."""
        return (isinstance(event, codec.ObstacleFrame) and event.t_s == self.stamp_s
                and (event.system_id, event.component_id) == (self.system_id, self.component_id))


class Pipeline:
    """Vehicle tracking, odometry pairing, estimation, guidance and commanding rules."""

    def __init__(self, config: CompanionConfig, goal: GoalConfig | None,
                 record_track: bool = False, track_limit: int | None = None) -> None:
        """``goal`` None: estimate only (a foreign tlog without a mission): no decisions.

        ``track_limit``: keep only the latest rows of the track (the live daemon flies for
        hours; a replay of a finite file keeps it all).
        """
        self.config = config
        self.goal = goal
        self.record_track = record_track
        link = config.link
        self.vehicle: tuple[int, int] | None = (
            (link.vehicle_system_id, link.vehicle_component_id or codec.MAV_COMP_ID_AUTOPILOT1)
            if link.vehicle_system_id is not None and link.vehicle_component_id is not None
            else None)
        self.other_vehicles: set[int] = set()
        self.navigator: Navigator | None = None
        self.reset_counter = 0
        self.armed = False
        self.custom_mode: int | None = None
        safety = config.safety
        self.clock = VehicleClock(ClockLimits(safety.clock_behind_tolerance_s,
                                              safety.clock_ahead_window_s,
                                              safety.clock_evidence_messages))
        self.epoch_camera = EpochCamera()
        # TIMESYNC with the autopilot, asked for by the service once a camera stamps in Unix time
        self.timesync = TimeSync()
        self.wants_timesync = False
        self.liveness = Liveness(link.heartbeat_timeout_s, config.failsafe.obstacle_timeout_s,
                                 config.failsafe.require_camera)
        self.gate = SetpointGate(SetpointLimits(
            config.commanding.max_speed_mps, safety.max_vertical_speed_mps,
            safety.max_yaw_rate_rad_s, safety.max_position_m))
        self._link_lost = False
        self._allowed = False
        self._attitudes: deque[codec.Attitude] = deque(maxlen=ATTITUDE_HISTORY)
        self._held_position: codec.LocalPosition | None = None
        self._yaw_rate_rad_s = 0.0                  # of the ATTITUDE the last yaw came from
        self.position_health = odometry_intake.PositionHealth(config.estimator)
        self.position_watch = PositionResetWatch(config.estimator.position_reset_params())
        self.unaided_drift = UnaidedDrift(config.estimator.unaided_velocity_sigma_mps)
        self.position_resets: list[dict] = []       # {t_s, offset_m}: estimate restarted from a fix
        self.estimator_notices = odometry_intake.EstimatorNotices()
        self._ap_yaw_rad: float | None = None       # autopilot yaw at the last odometry sample
        self._last_decision_t_s: float | None = None
        self._last_pose_out_t_s: float | None = None
        self._safe_reason: str | None = None
        self._safe_logged_commanding = False
        self.arrival_t_s: float | None = None
        self.started_t_s: float | None = None
        self.urgency: list[UrgencyRecord] = []
        # rows (t_s, north_m, east_m, yaw_rad, 9 cov) as compact float arrays (104 bytes each)
        self.track: deque[array] = deque(maxlen=track_limit)
        self.counters: dict[str, int] = {}
        self.setpoints = 0
        self.stopped = False            # stop_setpoint() sent: no setpoint after it
        self.phase = FlightPhase(config.flight.params())
        self.vertical = VerticalHold(config.flight.params())
        self.heights = ServiceHeights(config)          # avoidance.vertical (onboard/heights.py)
        self._phase_said: str | None = None
        self.phase_changes: list[tuple[float, str, str]] = []   # (vehicle s, phase, source)
        self.goal_ne: tuple[float, float] | None = (
            (goal.north_m, goal.east_m) if goal is not None and not goal.is_geographic
            and not goal.mission else None)
        self.goal_radius_m = goal.radius_m if goal is not None else 1.0
        self.mission = MissionFollower(config.link.component_id, goal.radius_m,
                                       recheck_s=goal.mission_recheck_s) \
            if goal is not None and goal.mission else None
        self._goal_reference: str | None = None
        self.last_command = None        # (t_s, GuidanceCommand) of the latest decision: the view
        self.map_out = MapPublisher(config.map_out)
        self.geo_reference: codec.GeoReference | None = None   # the EKF origin (or HOME)
        self._fly_to_active = False
        self._last_shaped = None        # the last setpoint's velocity direction and nose (SLAM)
        self._last_shaped_t_s: float | None = None      # ... and its time
        # The camera frame being assembled: one OBSTACLE_DISTANCE_3D per obstacle, all with the
        # frame's time, are one chance for the landmark lifecycle, not one each.
        self._frame: _FrameAssembly | None = None
        # The parameter protocol (companion/onboard/parameters.py): a live set waits here for a safe point.
        self.params = ParamServer(config, require_signed=link.signing_key_file is not None)
        self._pending_config: CompanionConfig | None = None

    # ------------------------------------------------------------ entry point
    def handle(self, t_link_s: float, event: codec.Event | None) -> list[Output]:
        """One inbound event, stamped by the link; returns what to send or do, in order."""
        out: list[Output] = []
        self._check_heartbeat_age(t_link_s)
        if event is None:
            return out
        if isinstance(event, ParamRequest):       # not flight data: a camera frame stays whole
            self._on_param(t_link_s, event, out)
            return out
        if self._frame is not None and not self._frame.continued_by(event):
            self._flush_frame(out)
        if self._pending_config is not None and self._frame is None:
            self._apply_config()                  # the safe point: no decision under way
        if isinstance(event, codec.Heartbeat):
            self._on_heartbeat(t_link_s, event, out)
        elif isinstance(event, mission_codec.GoalRequest):
            self._on_goal_request(event, out)
        elif not self._from_vehicle_system(event):
            self._count("ignored_other_source")
        elif isinstance(event, codec.Attitude) and self._is_vehicle(event):
            if self._timed(t_link_s, event, out) and self._plausible_attitude(event):
                self._attitudes.append(event)
                held = self._held_position
                if held is not None and event.t_s >= held.t_s - TIME_EPS_S:
                    self._held_position = None
                    self._on_position(t_link_s, held, out)
        elif isinstance(event, codec.LocalPosition) and self._is_vehicle(event):
            if self._timed(t_link_s, event, out):
                self._pair_position(t_link_s, event, out)
        elif isinstance(event, codec.ObstacleFrame):
            self._on_obstacles(t_link_s, event, out)
        elif isinstance(event, (codec.GpsFix, codec.EkfStatus)) and self._is_vehicle(event):
            self.position_health.note(event, self.clock.latest_t_s)
        elif isinstance(event, MISSION_EVENTS) and self._is_vehicle(event):
            if self.mission is not None:
                out.extend(self.mission.on_event(t_link_s, event))
                self._sync_mission_goal()
        elif self._is_vehicle(event):
            self._on_flight_data(event)
        return out

    # ------------------------------------------------------------ parameters
    def _on_param(self, t_link_s: float, request: ParamRequest, out: list[Output]) -> None:
        """A ground station's PARAM_* (companion/onboard/parameters.py); a live set is queued for the
        next safe point (handle(): between messages, no camera frame in assembly)."""
        our_system = self.config.link.system_id or (self.vehicle[0] if self.vehicle else 1)
        outcome = self.params.handle(request, our_system, self.config.link.component_id,
                                     self.clock.latest_t_s if self.clock.latest_t_s is not None
                                     else t_link_s)
        out.extend(outcome.replies)
        for notice in outcome.notices:
            warn = notice.severity == "warning"
            if warn:
                self._count("param_refused")
                log.warning("PARAM_%s from %d/%d: %s", request.kind.upper(), request.system_id,
                            request.component_id, self.params.last_refusal)
            out.append(codec.Notice(codec.SEVERITY_WARNING if warn else codec.SEVERITY_INFO,
                                    notice.text))
        change = outcome.change
        if change is not None:
            log.info("parameter %s (%s) %r -> %r from %d/%d: %s", change.name, change.key,
                     change.old, change.new, *change.source,
                     "live at the next safe point" if change.live else "at the next start")
            if change.config is not None:
                self._pending_config = change.config
            out.append(change)

    def _apply_config(self) -> None:
        """The running config after a live parameter set; the navigator's guidance follows."""
        self.config, self._pending_config = self._pending_config, None
        if self.navigator is not None:
            self.navigator.params = self.config.guidance_params(self.navigator.params.goal_radius_m)
        self._count("param_applied")

    def health_inputs(self, t_link_s: float) -> HealthInputs:
        """What companion/onboard/health.py judges the HEARTBEAT and SYS_STATUS from."""
        t_s = self.clock.latest_t_s
        commanding = self.commanding_allowed(t_link_s) and t_s is not None \
            and self.phase.decide(t_s).may_command
        nav = self.navigator
        return HealthInputs(
            vehicle_found=self.vehicle is not None, link_lost=self._link_lost,
            commanding=commanding, safe_reason=self._safe_reason,
            deciding=nav is not None and self.goal_ne is not None,
            camera_live=t_s is not None and not self.liveness.camera_stale(t_s),
            estimator_state=nav.health.state if nav is not None and nav.health is not None
            else None)

    def _on_flight_data(self, event) -> None:
        """Flight phase inputs and the goal's geographic reference."""
        if isinstance(event, codec.LandedState) and self.clock.latest_t_s is not None:
            self.phase.on_landed_state(self.clock.latest_t_s, event.landed_state)
            self._note_phase()
        elif isinstance(event, codec.GlobalPosition) and math.isfinite(event.t_s):
            self.phase.on_relative_alt(event.t_s, event.relative_alt_m, event.vel_down_mps)
            self._note_phase()
        elif isinstance(event, codec.GeoReference):
            self._on_geo_reference(event)

    @property
    def needs_geo_reference(self) -> bool:
        """A latitude/longitude goal (or mission waypoint) still waits for the EKF origin or HOME."""
        if self.config.fly_to.enabled and (self.geo_reference is None
                                           or self.geo_reference.kind != "origin"):
            return True                   # a "fly to here" needs it too
        if self.mission is not None:
            return self.mission.needs_geo_reference
        return self.goal is not None and self.goal.is_geographic and self._goal_reference != "origin"

    def _on_goal_request(self, request: mission_codec.GoalRequest, out: list[Output]) -> None:
        """A ground station's "fly to here" (companion/onboard/fly_to.py): the new goal, or refused."""
        if not self.config.fly_to.enabled or self.vehicle is None \
                or request.component_id == self.config.link.component_id:
            self._count("goal_request_ignored")
            return
        position = tuple(self.navigator.slam.pose[:2]) if self.navigator is not None else None
        verdict = fly_to.judge(request, self.vehicle,
                               self.custom_mode == self.config.link.guided_custom_mode,
                               self.geo_reference, position, self.config.fly_to)
        if verdict.reason == "not addressed to the vehicle":
            self._count("goal_request_ignored")
            return
        if not verdict.accepted:
            self._count("goal_refused")
            log.warning("%s from %d/%d refused: %s", request.kind, request.system_id,
                        request.component_id, verdict.reason)
            out.append(codec.Notice(codec.SEVERITY_WARNING,
                                    f"companion: goal refused: {verdict.reason}"))
            return
        self._fly_to_active = True
        self._set_goal(verdict.north_m, verdict.east_m, self.config.fly_to.radius_m)
        self.arrival_t_s = None
        log.info("%s from %d/%d: new goal north %.1f m, east %.1f m", request.kind,
                 request.system_id, request.component_id, verdict.north_m, verdict.east_m)
        out.append(codec.Notice(codec.SEVERITY_INFO, f"companion: new goal N {verdict.north_m:.0f}"
                                                     f" E {verdict.east_m:.0f} m"))

    def _set_goal(self, north_m: float, east_m: float, radius_m: float) -> None:
        self.goal_ne, self.goal_radius_m = (north_m, east_m), radius_m
        if self.navigator is not None:
            self.navigator.goal = np.array(self.goal_ne)
            self.navigator.params = dataclasses.replace(self.navigator.params,
                                                        goal_radius_m=radius_m)

    def mission_tick(self, t_link_s: float) -> list[Output]:
        """Mission download timeouts and retries (the service calls this on its timer)."""
        if self.mission is None:
            return []
        out = self.mission.tick(t_link_s)
        self._sync_mission_goal()
        return out

    def _sync_mission_goal(self) -> None:
        """The mission's current waypoint is the navigator's goal."""
        goal = self.mission.goal()
        if self._fly_to_active or goal is None \
                or (self.goal_ne, self.goal_radius_m) == (goal[:2], goal[2]):
            return                # a "fly to here" holds the goal until the next one
        log.info("goal: waypoint at north %.1f m, east %.1f m (radius %.1f m)", *goal)
        self._set_goal(*goal)

    def _on_geo_reference(self, ref: codec.GeoReference) -> None:
        if self.geo_reference is None or ref.kind == "origin":
            self.geo_reference = ref
        if self.mission is not None:
            self.mission.on_geo_reference(ref)
            self._sync_mission_goal()
            return
        goal_waits = self.goal is not None and self.goal.is_geographic \
            and self._goal_reference != "origin" and not self._fly_to_active
        if not goal_waits or (ref.kind == "home" and self._goal_reference):
            return                        # the EKF origin wins over HOME; one HOME is enough
        try:
            self.goal_ne = goal_north_east(self.goal.lat_deg, self.goal.lon_deg, ref.lat_deg,
                                           ref.lon_deg, ref.north_m, ref.east_m)
        except ValueError as exc:
            self._count("goal_too_far")
            log.error("%s", exc)
            return
        self._goal_reference = ref.kind
        log.info("goal %.7f, %.7f -> north %.1f m, east %.1f m (from the %s)", self.goal.lat_deg,
                 self.goal.lon_deg, *self.goal_ne, "EKF origin" if ref.kind == "origin" else "HOME")
        if self.navigator is not None:
            self.navigator.goal = np.array(self.goal_ne)

    @property
    def safe_reason(self) -> str | None:
        """Why the safe action is on now (None: guidance as planned)."""
        return self._safe_reason

    @property
    def heartbeat_link_s(self) -> float | None:
        """Link time of the vehicle's last heartbeat."""
        return self.liveness.heartbeat_link_s

    @property
    def latest_t_s(self) -> float | None:
        """The vehicle's latest believed time since boot."""
        return self.clock.latest_t_s

    def commanding_allowed(self, t_link_s: float) -> bool:
        """Armed, in GUIDED, and the vehicle's heartbeat is fresh: setpoints may be sent."""
        return (self.vehicle is not None and self.armed
                and self.custom_mode == self.config.link.guided_custom_mode
                and self.liveness.heartbeat_fresh(t_link_s))

    def stop_setpoint(self, t_link_s: float) -> list[Output]:
        """Zero velocity at the current yaw, through the gate, if commanding (on shutdown).
        It is the last setpoint: nothing is sent after it."""
        out: list[Output] = []
        if self.vehicle is not None and self.clock.latest_t_s is not None:
            yaw = self._ap_yaw_rad
            if yaw is None and self._attitudes:
                yaw = self._attitudes[-1].yaw_rad
            self._send(t_link_s, codec.VelocitySetpoint(
                *self.vehicle, self.clock.latest_t_s, 0.0, 0.0,
                wrap_angle(0.0 if yaw is None else yaw), "stop"), out)
        self.stopped = True
        return out

    # ------------------------------------------------------------ identities
    def _from_vehicle_system(self, event) -> bool:
        return self.vehicle is not None and event.system_id == self.vehicle[0]

    def _is_vehicle(self, event) -> bool:
        return (event.system_id, event.component_id) == self.vehicle

    def _on_heartbeat(self, t_link_s: float, hb: codec.Heartbeat, out: list[Output]) -> None:
        link = self.config.link
        wanted_component = link.vehicle_component_id or codec.MAV_COMP_ID_AUTOPILOT1
        if self.vehicle is None and hb.is_autopilot and hb.component_id == wanted_component \
                and link.vehicle_system_id in (None, hb.system_id):
            self.vehicle = (hb.system_id, hb.component_id)
            log.info("vehicle found: system %d component %d", *self.vehicle)
            out.append(StreamsWanted("vehicle found"))
            if self.mission is not None:
                out.extend(self.mission.on_vehicle(t_link_s, self.vehicle))
        if self.vehicle is not None and (hb.system_id, hb.component_id) == self.vehicle:
            if self._link_lost:
                self._link_lost = False
                log.info("vehicle heartbeat back: resync")
                out.append(StreamsWanted("heartbeat back"))
            self.liveness.on_vehicle_heartbeat(t_link_s)
            self.clock.on_vehicle_heartbeat()
            self.armed, self.custom_mode = hb.armed, hb.custom_mode
            self.phase.on_armed(hb.armed)
            self._note_phase()
            self._note_allowed(t_link_s)
        elif self.vehicle is not None and hb.system_id == self.vehicle[0] \
                and hb.component_id == link.camera_component_id:
            pass        # the camera's heartbeat is no obstacle data (safety/liveness.py)
        elif hb.is_autopilot and (self.vehicle is None or hb.system_id != self.vehicle[0]):
            if hb.system_id not in self.other_vehicles:
                self.other_vehicles.add(hb.system_id)
                log.info("ignoring another vehicle: system %d", hb.system_id)

    def _check_heartbeat_age(self, t_link_s: float) -> None:
        last = self.liveness.heartbeat_link_s
        if last is None or self._link_lost:
            return
        if not self.liveness.heartbeat_fresh(t_link_s):
            self._link_lost = True
            log.warning("vehicle heartbeat lost for %.1f s: commanding stopped",
                        t_link_s - last)
            self._note_allowed(t_link_s)

    def _note_allowed(self, t_link_s: float) -> None:
        allowed = self.commanding_allowed(t_link_s)
        if allowed != self._allowed:
            self._allowed = allowed
            if allowed:
                log.info("vehicle armed in GUIDED: commanding")
            else:
                log.info("commanding stopped (armed %s, mode %s, link %s)", self.armed,
                         self.custom_mode, "lost" if self._link_lost else "up")

    # ------------------------------------------------------------ clock and odometry
    def _timed(self, t_link_s: float, event, out: list[Output]) -> bool:
        """Judge an autopilot message's time (safety/clock.py). Refused stamps are counted; those
        on a candidate clock are kept, and handled once that clock is adopted (reboot, jump)."""
        before = self.clock.latest_t_s
        verdict = self.clock.on_autopilot(event.t_s, (t_link_s, event))
        if verdict.reason == "ok":
            return True
        if not verdict.accepted:
            self._count(f"time_{verdict.reason}")
            return False
        evidence = verdict.held
        if verdict.reason == "reboot":
            log.warning("vehicle time went back %.1f s -> %.1f s on %d messages and a heartbeat: "
                        "reboot, estimate reset", before, event.t_s, len(evidence) + 1)
            self._reset_estimate()
            self.liveness.forget_camera()
            self.epoch_camera.forget()
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

    def _reset_estimate(self) -> None:
        self.navigator = None
        self._last_shaped = self._last_shaped_t_s = None
        self.reset_counter += 1
        self._attitudes.clear()
        self._held_position = None
        self._last_decision_t_s = self._last_pose_out_t_s = None

    def _reset_position(self, lpn: codec.LocalPosition, offset_m: float, reason: str,
                        out: list[Output]) -> None:
        """The autopilot's fixes stay refused (a GPS back after a long outage): the estimate
        restarts from its position at the next sample, the map dropped (README, "GPS outage and
        return": the landmarks mapped before and during the outage drifted by different amounts,
        no single shift puts them all right; the camera maps what is in view again)."""
        log.warning("position reset at %.1f s: %s, %.1f m off; estimate restarted from the "
                    "autopilot's position, map dropped", lpn.t_s, reason, offset_m)
        self._count("position_reset")
        self.position_resets.append({"t_s": lpn.t_s, "offset_m": offset_m})
        self._reset_estimate()
        out.append(codec.Notice(codec.SEVERITY_WARNING,
                                f"companion: position reset ({offset_m:.0f} m), map dropped"))

    def _plausible_attitude(self, att: codec.Attitude) -> bool:
        if not (math.isfinite(att.yaw_rad) and abs(att.yaw_rad) <= 2.0 * math.pi
                and math.isfinite(att.yaw_rate_rad_s)
                and abs(att.yaw_rate_rad_s) <= PLAUSIBLE_YAW_RATE_RAD_S):
            self._count("attitude_implausible")
            return False
        return True

    def _attitude_at(self, t_s: float) -> float | None:
        """Yaw at t_s from the latest ATTITUDE not after it, carried forward by its yaw rate."""
        for att in reversed(self._attitudes):
            if att.t_s <= t_s + TIME_EPS_S:
                gap = t_s - att.t_s
                if gap > self.config.commanding.max_attitude_age_s:
                    return None
                rate = att.yaw_rate_rad_s
                self._yaw_rate_rad_s = rate
                return wrap_angle(att.yaw_rad + rate * max(gap, 0.0))
        return None

    def _pair_position(self, t_link_s: float, lpn: codec.LocalPosition, out: list[Output]) -> None:
        """Use the ATTITUDE of the same time_boot_ms: if it has not come yet, hold the position
        until it does, or until the next position (then the older attitude, carried forward)."""
        held, self._held_position = self._held_position, None
        if held is not None:
            self._on_position(t_link_s, held, out)
        latest = self._attitudes[-1] if self._attitudes else None
        if latest is not None and latest.t_s >= lpn.t_s - TIME_EPS_S:
            self._on_position(t_link_s, lpn, out)
        else:
            self._held_position = lpn

    def _on_position(self, t_link_s: float, lpn: codec.LocalPosition, out: list[Output]) -> None:
        self.phase.on_local_position(lpn.t_s, lpn.down_m, lpn.vel_down_mps)
        self._note_phase()
        yaw = self._attitude_at(lpn.t_s)
        if yaw is None:
            self._count("odometry_without_attitude")
            return
        speed = math.hypot(lpn.vel_north_mps, lpn.vel_east_mps)
        if math.isfinite(speed) and speed > max(PLAUSIBLE_SPEED_MPS,
                                                5.0 * self.config.commanding.max_speed_mps):
            # finite but absurd (3e38 m/s): it would blow the covariance up to inf and NaN
            self._count("odometry_implausible_speed")
            return
        if self.navigator is None:
            if not (math.isfinite(lpn.north_m) and math.isfinite(lpn.east_m)
                    and math.isfinite(yaw)):
                self._count("start_not_finite")
                return
            limit_m = self.config.safety.max_position_m
            if abs(lpn.north_m) > limit_m or abs(lpn.east_m) > limit_m:
                self._count("start_implausible")
                return
            self.navigator = self._make_navigator(lpn.north_m, lpn.east_m, yaw)
            self.started_t_s = lpn.t_s
            log.info("estimator started at %.1f s: north %.1f m, east %.1f m, yaw %.1f deg",
                     lpn.t_s, lpn.north_m, lpn.east_m, math.degrees(yaw))
            out.append(NavigatorStarted(lpn.t_s))
        nav = self.navigator
        before = nav.t_s
        reports, verdict = odometry_intake.absorb(nav, self.config.estimator, self.position_health,
                                                  lpn, yaw, self._yaw_rate_rad_s,
                                                  self.position_watch, self.unaided_drift)
        if verdict is not None and verdict.reset:
            self._reset_position(lpn, verdict.offset_m, verdict.reason, out)
            return
        if nav.t_s == before and before is not None:
            self._count("odometry_not_newer")
            return
        self._ap_yaw_rad = yaw
        if self.record_track:
            pose, cov = nav.slam.pose, nav.slam.pose_cov
            self.track.append(array("d", (lpn.t_s, *pose.tolist(), *cov.ravel().tolist())))
        due = (self._last_decision_t_s is None or lpn.t_s - self._last_decision_t_s
               >= self.config.commanding.setpoint_period_s - TIME_EPS_S)
        if (reports or due) and self.goal_ne is not None:
            self._decide(t_link_s, lpn.t_s, out)
        # After the decision: a lock-step stub takes our ODOMETRY as the sign that everything we
        # do for this sample has been sent (companion/daemon/lockstep.py). A diverged estimator is
        # restarted by the decision (navigator None until the next good sample): nothing to say.
        if self.navigator is not None:
            scan = self.map_out.scan(lpn.t_s, self.navigator.slam.pose,
                                     self.navigator.slam.landmarks())
            if scan is not None:
                out.append(scan)
            self._maybe_publish_pose(lpn.t_s, out)

    def _make_navigator(self, north_m: float, east_m: float, yaw_rad: float) -> Navigator:
        est = self.config.estimator
        goal_ne = self.goal_ne or (north_m, east_m)    # no goal yet: replaced once known
        radius_m = self.goal_radius_m                   # no goal: no guidance
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

    def _maybe_publish_pose(self, t_s: float, out: list[Output]) -> None:
        if self._last_pose_out_t_s is not None and t_s - self._last_pose_out_t_s \
                < 1.0 / self.config.commanding.odometry_rate_hz - TIME_EPS_S:
            return
        slam = self.navigator.slam
        pose, cov = slam.pose, slam.pose_cov
        if not (np.all(np.isfinite(pose)) and np.all(np.isfinite(cov))):
            return
        self._last_pose_out_t_s = t_s
        north_m, east_m, yaw_rad = pose.tolist()
        out.append(codec.PoseEstimate(t_s, north_m, east_m, yaw_rad,
                                      tuple(map(tuple, cov.tolist())), self.reset_counter,
                                      odometry_intake.quality(self.navigator)))
        # Tracked movers, for the ground station to see (docs/messages.md).
        for mover in self.navigator.movers.states(self.navigator.clock_s):
            if np.all(np.isfinite(mover.position_ne_m)):
                out.append(codec.MoverReport(t_s, mover.obstacle_id, mover.track_id,
                                             float(mover.position_ne_m[0]),
                                             float(mover.position_ne_m[1])))

    # ------------------------------------------------------------ obstacles
    def _on_obstacles(self, t_link_s: float, frame: codec.ObstacleFrame, out: list[Output]) -> None:
        stamp_s = frame.t_s
        if frame.component_id not in (self.vehicle[1], self.config.link.camera_component_id):
            self._count("ignored_other_source")
            return
        frame = self._in_vehicle_time(frame, out)
        if frame is None:
            return
        verdict = self.clock.check_frame(frame.t_s, (t_link_s, frame))
        if not verdict.accepted:
            # Before the vehicle's clock (a reboot not yet seen in its own messages, or a
            # glitch) or ahead of it: it would be matched against the wrong pose.
            self._count("obstacle_time_ahead" if verdict.reason == "ahead" else "obstacle_too_old")
            return
        if frame.rejected:
            self._count("obstacle_rejected")
            log.debug("obstacle report refused: %s", frame.rejected)
            return
        self.liveness.on_camera_frame(frame.t_s, self.clock.latest_t_s)
        if self.navigator is None:
            if frame.observations:
                self._count("obstacle_before_estimator")
            return
        observations = [o for o in frame.observations if o.range_m <= PLAUSIBLE_RANGE_M]
        if len(observations) < len(frame.observations):
            self._count("observation_implausible_range")
            if not observations:
                return
        if frame.sectors is not None:        # a depth camera: its blobs, not a landmark per bin
            observations = sector_observations(frame.sectors, BlobParams(
                range_sigma_k_per_m=self.navigator.options.range_sigma_k_per_m))
        # Held until a message that is not part of this frame arrives (handle() flushes it): an
        # empty frame too, a chance in which the landmarks in view were not seen.
        if self._frame is None:
            self._frame = _FrameAssembly(frame.system_id, frame.component_id, stamp_s, frame.t_s,
                                         t_link_s)
        self._frame.observations.extend(observations)

    def _flush_frame(self, out: list[Output]) -> None:
        """The assembled camera frame to the estimator, and a decision on what it changed."""
        frame, self._frame = self._frame, None
        if self.navigator is None:
            return
        self._sync_heights()
        reports = self.navigator.on_observations(frame.t_s, self.heights.frame(frame.observations))
        for report in reports:
            if report.action == "added":
                log.info("new landmark %s (obstacle id %s)", report.landmark_index,
                         report.obstacle_id)
        if reports and self.goal_ne is not None:
            self._decide(frame.t_link_s, self.navigator.t_s, out)

    def _in_vehicle_time(self, frame: codec.ObstacleFrame,
                         out: list[Output]) -> codec.ObstacleFrame | None:
        """A frame stamped in Unix time (OBSTACLE_DISTANCE allows it), moved to vehicle time by
        the offset of the first such frame; refused while the vehicle's clock is unknown."""
        if not self.epoch_camera.is_epoch(frame.t_s):
            return frame
        self.wants_timesync = True
        synced = self.timesync.vehicle_time_s(frame.t_s)
        if synced is not None:      # TIMESYNC's offset: no transport delay of one frame in it
            return dataclasses.replace(frame, t_s=synced)
        first = self.epoch_camera.offset_s is None
        t_s = self.epoch_camera.to_vehicle_time(frame.t_s, self.clock.latest_t_s)
        if t_s is None:
            self._count("obstacle_epoch_before_clock")
            return None
        if first:
            log.warning("camera stamps obstacle reports in Unix time: mapped to vehicle time by "
                        "the offset seen now (%.3f s)", self.epoch_camera.offset_s)
            out.append(codec.Notice(
                codec.SEVERITY_WARNING, "companion: camera in Unix time, offset mapped"))
        return dataclasses.replace(frame, t_s=t_s)

    # ------------------------------------------------------------ guidance and commanding
    def _decide(self, t_link_s: float, t_s: float, out: list[Output]) -> None:
        self._last_decision_t_s = t_s
        nav = self.navigator
        if not nav.slam.is_healthy():
            self._safe(t_link_s, t_s, "estimator diverged", out)
            # restart from the next good sample rather than hold for good
            log.error("estimator diverged at %.1f s: restarting from the next sample", t_s)
            self._count("estimator_restarts")
            self._reset_estimate()
            return
        self._sync_heights()
        command, change = nav.decide(t_s)
        self.last_command = (t_s, command)
        if change is not None:
            self._on_urgency(change, out)
        out.extend(self.estimator_notices.after_decision(nav, command))
        if command.mode == "arrived" and self.mission is not None and not self._fly_to_active:
            self._on_waypoint_arrived(t_link_s, t_s, out)
        elif command.mode == "arrived" and self.arrival_t_s is None:
            self.arrival_t_s = t_s
            log.info("arrived at the goal at %.1f s", t_s)
            out.append(Arrived(t_s))
            out.append(codec.Notice(codec.SEVERITY_NOTICE, "companion: goal reached"))
        if self.liveness.camera_stale(t_s):
            self._safe(t_link_s, t_s, "obstacle data stale", out)
            return
        setpoint = self._setpoint(t_s, command)
        verdict = self.gate.check(setpoint)
        if not verdict.passed:
            self._safe(t_link_s, t_s, f"setpoint refused ({verdict.reason})", out)
            return
        if self._safe_reason is not None:
            log.log(logging.WARNING if self._safe_logged_commanding else logging.INFO,
                    "safe action ended (%s): guidance resumed", self._safe_reason)
            if self._safe_logged_commanding:
                out.append(codec.Notice(codec.SEVERITY_INFO, "companion: guidance resumed"))
            self._safe_reason, self._safe_logged_commanding = None, False
        self._send(t_link_s, setpoint, out)

    def _on_waypoint_arrived(self, t_link_s: float, t_s: float, out: list[Output]) -> None:
        """Only while commanding (GUIDED, armed, airborne): a waypoint the pilot flew through in
        another mode was not flown by us."""
        if self.mission.complete or not (self.commanding_allowed(t_link_s)
                                         and self.phase.decide(t_s).may_command):
            return
        out.extend(self.mission.on_arrived(t_s))
        self._sync_mission_goal()
        if self.mission.complete:
            self.arrival_t_s = t_s
            out.append(Arrived(t_s))

    def _setpoint(self, t_s: float, command) -> codec.VelocitySetpoint | None:
        """Turn-limit the velocity's direction and the nose (core/avoidance/guidance.py shape_setpoint),
        rotate them into the autopilot's frame, clamp the speed: the chosen speed (slowing,
        stopping, accelerating back) along the chosen direction; the yaw toward a watched mover
        if the command looks at one."""
        commanding = self.config.commanding
        slam_yaw = float(self.navigator.slam.pose[2])
        # turn-limited over the interval the setpoints come at (a GCS may have slowed the streams)
        interval_s = setpoint_interval_s(t_s, self._last_shaped_t_s, commanding.setpoint_period_s,
                                         commanding.max_attitude_age_s)
        shaped = shape_setpoint(slam_yaw, self._last_shaped, command,
                                commanding.max_turn_rate_rad_s, interval_s,
                                commanding.max_speed_mps)
        self._last_shaped, self._last_shaped_t_s = shaped, t_s
        # The autopilot's yaw drifts from the SLAM yaw; fly the SLAM heading in its frame.
        offset = self._ap_yaw_rad - slam_yaw
        heading_ap = wrap_angle(shaped.course_rad + offset)
        vn, ve = shaped.speed_mps * math.cos(heading_ap), shaped.speed_mps * math.sin(heading_ap)
        return codec.VelocitySetpoint(*self.vehicle, t_s, vn, ve,
                                      wrap_angle(shaped.yaw_rad + offset), command.mode)

    def _safe(self, t_link_s: float, t_s: float, reason: str, out: list[Output]) -> None:
        # ERROR (and a STATUSTEXT) once per reason while commanding; before that (on the ground,
        # camera not up yet) it is only worth an INFO line.
        commanding = self.commanding_allowed(t_link_s) and self.phase.decide(t_s).may_command
        if (reason, commanding) != (self._safe_reason, self._safe_logged_commanding):
            action = self.config.failsafe.safe_action
            if commanding:
                log.error("%s: safe action %s", reason, action)
                out.append(codec.Notice(codec.SEVERITY_ERROR, f"companion: {reason}, {action}"))
            else:
                log.info("%s (not commanding): safe action %s when commanding", reason, action)
            self._safe_reason, self._safe_logged_commanding = reason, commanding
        self._count(f"safe_action: {reason}")
        if self.config.failsafe.safe_action == "hold":
            yaw = self._ap_yaw_rad if self._ap_yaw_rad is not None else 0.0
            self._send(t_link_s, codec.VelocitySetpoint(*self.vehicle, t_s, 0.0, 0.0, yaw,
                                                        f"hold: {reason}"), out)

    def _note_phase(self) -> None:
        """The phase as soon as its inputs change, goal or not: a mission uploaded later must
        not hide when the vehicle became airborne (issue 32)."""
        t_s = self.clock.latest_t_s
        if t_s is None:
            return
        decision = self.phase.decide(t_s)
        if decision.phase != self._phase_said:
            self._say_phase(t_s, decision)

    def _say_phase(self, t_s: float, decision) -> None:
        self._phase_said = decision.phase
        if len(self.phase_changes) < PHASE_CHANGES_KEPT:
            self.phase_changes.append((t_s, decision.phase, decision.source))
        log.info("flight phase %s (%s) at %.1f s: %s", decision.phase, decision.source, t_s,
                 "commanding" if decision.may_command else "no setpoints")

    def _send(self, t_link_s: float, setpoint: codec.VelocitySetpoint, out: list[Output]) -> None:
        """The one place a setpoint leaves: commanding allowed, airborne (flight phase), the
        vertical hold added, and passed by the gate."""
        if not self.commanding_allowed(t_link_s):
            self.vertical.reset()
            return
        if self.stopped:
            self._count("setpoint_after_stop")
            return
        decision = self.phase.decide(setpoint.t_s)
        if decision.phase != self._phase_said:
            self._say_phase(setpoint.t_s, decision)
        if not decision.may_command:
            self.vertical.reset()
            self._count(f"no_setpoint_{decision.phase.replace(' ', '_')}")
            return
        if setpoint.reason != "stop":     # the shutdown stop: vz = 0, ArduCopter holds there
            vel_down = self.heights.vel_down_mps(       # 3D: the decision's climb (heights.py)
                self.navigator, self.phase.up_m, self.vertical.vel_down_mps(self.phase.up_m),
                safe_hold=setpoint.reason.startswith("hold: "))
            setpoint = dataclasses.replace(setpoint, vel_down_mps=vel_down)
        verdict = self.gate.check(setpoint)
        if not verdict.passed:
            self._count(f"setpoint_refused: {verdict.reason}")
            return
        self.setpoints += 1
        out.append(setpoint)

    def _sync_heights(self) -> None:
        """avoidance.vertical: the navigator's altitude and cruise altitude (onboard/heights.py)."""
        up_m = self.phase.up_m
        self.heights.sync(self.navigator, up_m,
                          self.heights.cruise_up_m(self.vertical.target_up_m, up_m))

    def _on_urgency(self, change, out: list[Output]) -> None:
        if change.landmark_index is None:
            record = UrgencyRecord(change.t_s, "cleared", None, None, None)
            text = "companion: obstacle cleared"
            severity = codec.SEVERITY_INFO
        else:
            record = UrgencyRecord(change.t_s, "urgent", change.obstacle_id,
                                   change.landmark_index, change.time_to_go_s)
            name = change.obstacle_id if change.obstacle_id is not None else \
                f"L{change.landmark_index}"
            ttg = change.time_to_go_s if change.time_to_go_s is not None else math.nan
            text = f"companion: obstacle {name} urgent, t_go {ttg:.1f} s"
            severity = codec.SEVERITY_WARNING
        log.info("%s at %.1f s", text, change.t_s)
        self.urgency.append(record)
        out.append(codec.Notice(severity, text))

    def _count(self, kind: str) -> None:
        self.counters[kind] = self.counters.get(kind, 0) + 1


def snapshot(pipeline: Pipeline) -> dict:
    """The pipeline's results as plain data: track, map, urgency events, arrival, counters."""
    nav = pipeline.navigator
    landmarks = []
    if nav is not None:
        for oid, mean, cov in zip(nav.slam.landmark_ids(), nav.slam.landmarks(),
                                  nav.slam.landmark_covs()):
            landmarks.append({"id": oid if oid is None or oid >= 0 else None,  # < 0: internal
                              "north_m": float(mean[0]), "east_m": float(mean[1]),
                              "cov_m2": cov.tolist()})
    columns = ("t_s", "north_m", "east_m", "yaw_rad")
    track = {name: [row[i] for row in pipeline.track] for i, name in enumerate(columns)}
    track["pose_cov"] = [list(row[4:]) for row in pipeline.track]
    return {
        "vehicle": list(pipeline.vehicle) if pipeline.vehicle else None,
        "other_vehicles": sorted(pipeline.other_vehicles),
        "goal": asdict(pipeline.goal) if pipeline.goal is not None else None,
        "goal_ne_m": list(pipeline.goal_ne) if pipeline.goal_ne is not None else None,
        "started_t_s": pipeline.started_t_s,
        "arrived": pipeline.arrival_t_s is not None,
        "arrival_t_s": pipeline.arrival_t_s,
        "reset_counter": pipeline.reset_counter,
        "position_resets": list(pipeline.position_resets),
        "setpoints": pipeline.setpoints,
        "track": track,
        "landmarks": landmarks,
        "urgency_events": [asdict(r) for r in pipeline.urgency],
        "counters": dict(pipeline.counters),
        "rejected_by_estimator": dict(nav.rejected) if nav is not None else {},
        "mission": pipeline.mission.summary() if pipeline.mission is not None else None,
        "parameters": pipeline.params.summary(),
        **odometry_intake.snapshot(nav),
        **pipeline.heights.snapshot(nav),
    }
