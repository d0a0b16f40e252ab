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
- Odometry: one sample per LOCAL_POSITION_NED, speed = hypot(vx, vy), paired with the ATTITUDE
  of the same time_boot_ms (the position waits for it until the next position arrives), else
  with the latest earlier ATTITUDE, its yaw carried forward by its yaw rate over the gap (at
  most ``max_attitude_age_s``, else the sample is skipped).
- A decision (guidance, urgency, maybe a setpoint) follows each odometry sample once a setpoint
  period of message time has passed, and each obstacle report the filter absorbed.
- Setpoints only while the last vehicle heartbeat says armed and GUIDED and is fresh.
- Stale camera or an unhealthy filter: the configured safe action (hold: velocity 0, current yaw).
"""
from __future__ import annotations

import logging
import math
from array import array
from collections import deque
from dataclasses import asdict, dataclass

import numpy as np

from companion.adapters import codec
from companion.config import CompanionConfig, GoalConfig
from companion.core.geometry import wrap_angle
from companion.core.guidance import limit_turn
from companion.core.navigator import Navigator

log = logging.getLogger(__name__)

# Beyond these, a finite value is still nonsense (no multicopter, no stereo camera): refused.
PLAUSIBLE_SPEED_MPS = 50.0
PLAUSIBLE_RANGE_M = 1000.0
REBOOT_BACKSTEP_S = 1.0          # time_boot_ms stepping back more than this: the vehicle rebooted
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


Output = codec.VelocitySetpoint | codec.PoseEstimate | codec.Notice | codec.MoverReport \
    | StreamsWanted \
    | NavigatorStarted | Arrived


@dataclass(frozen=True)
class UrgencyRecord:
    t_s: float
    state: str                      # 'urgent' or 'cleared'
    obstacle_id: int | None
    landmark_index: int | None
    time_to_go_s: float | None


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
        self._heartbeat_link_s: float | None = None
        self._link_lost = False
        self._allowed = False
        self._latest_t_s: float | None = None
        self._attitudes: deque[codec.Attitude] = deque(maxlen=ATTITUDE_HISTORY)
        self._held_position: codec.LocalPosition | None = None
        self._ap_yaw_rad: float | None = None       # autopilot yaw at the last odometry sample
        self._last_decision_t_s: float | None = None
        self._last_pose_out_t_s: float | None = None
        self._last_camera_t_s: float | None = None
        self._camera_alive_unstamped = False
        self._safe_reason: str | None = None
        self._safe_logged_commanding = False
        self.arrival_t_s: float | None = None
        self.started_t_s: float | None = None
        self.urgency: list[UrgencyRecord] = []
        # rows (t_s, north_m, east_m, yaw_rad, 9 cov) as compact float arrays (104 bytes each)
        self.track: deque[array] = deque(maxlen=track_limit)
        self.counters: dict[str, int] = {}
        self.setpoints = 0

    # ------------------------------------------------------------ entry point
    def handle(self, t_link_s: float, event: codec.Event | None) -> list[Output]:
        """One inbound event, stamped by the link; returns what to send or do, in order."""
        out: list[Output] = []
        self._check_heartbeat_age(t_link_s)
        if event is None:
            return out
        if isinstance(event, codec.Heartbeat):
            self._on_heartbeat(t_link_s, event, out)
        elif not self._from_vehicle_system(event):
            self._count("ignored_other_source")
        elif isinstance(event, codec.Attitude) and self._is_vehicle(event):
            if self._timed(event.t_s, out):
                self._attitudes.append(event)
                held = self._held_position
                if held is not None and event.t_s >= held.t_s - TIME_EPS_S:
                    self._held_position = None
                    self._on_position(t_link_s, held, out)
        elif isinstance(event, codec.LocalPosition) and self._is_vehicle(event):
            if self._timed(event.t_s, out):
                self._pair_position(t_link_s, event, out)
        elif isinstance(event, codec.ObstacleFrame):
            self._on_obstacles(t_link_s, event, out)
        return out

    @property
    def heartbeat_link_s(self) -> float | None:
        """Link time of the vehicle's last heartbeat."""
        return self._heartbeat_link_s

    def commanding_allowed(self, t_link_s: float) -> bool:
        """Armed, in GUIDED, and the vehicle's heartbeat is fresh: setpoints may be sent."""
        return (self.vehicle is not None and self.armed
                and self.custom_mode == self.config.link.guided_custom_mode
                and self._heartbeat_link_s is not None
                and t_link_s - self._heartbeat_link_s <= self.config.link.heartbeat_timeout_s)

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
        if self.vehicle is not None and (hb.system_id, hb.component_id) == self.vehicle:
            if self._link_lost:
                self._link_lost = False
                log.info("vehicle heartbeat back: resync")
                out.append(StreamsWanted("heartbeat back"))
            self._heartbeat_link_s = t_link_s
            self.armed, self.custom_mode = hb.armed, hb.custom_mode
            self._note_allowed(t_link_s)
        elif self.vehicle is not None and hb.system_id == self.vehicle[0] \
                and hb.component_id == link.camera_component_id:
            self._on_camera_alive()
        elif hb.is_autopilot and (self.vehicle is None or hb.system_id != self.vehicle[0]):
            if hb.system_id not in self.other_vehicles:
                self.other_vehicles.add(hb.system_id)
                log.info("ignoring another vehicle: system %d", hb.system_id)

    def _on_camera_alive(self) -> None:
        """The camera's heartbeat has no time of its own: stamp it with the vehicle's latest."""
        self._camera_alive_unstamped = self._latest_t_s is None
        if self._latest_t_s is not None:
            self._last_camera_t_s = self._latest_t_s

    def _check_heartbeat_age(self, t_link_s: float) -> None:
        if self._heartbeat_link_s is None or self._link_lost:
            return
        if t_link_s - self._heartbeat_link_s > self.config.link.heartbeat_timeout_s:
            self._link_lost = True
            log.warning("vehicle heartbeat lost for %.1f s: commanding stopped",
                        t_link_s - self._heartbeat_link_s)
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
    def _timed(self, t_s: float, out: list[Output]) -> bool:
        """Track the vehicle clock; a big step back means a reboot: start the estimate afresh."""
        if not math.isfinite(t_s):
            self._count("time_not_finite")
            return False
        if self._latest_t_s is not None and t_s < self._latest_t_s - REBOOT_BACKSTEP_S:
            log.warning("vehicle time went back %.1f s -> %.1f s: reboot, estimate reset",
                        self._latest_t_s, t_s)
            self.navigator = None
            self.reset_counter += 1
            self._attitudes.clear()
            self._held_position = None
            self._last_decision_t_s = self._last_pose_out_t_s = None
            self._last_camera_t_s = None
            self._latest_t_s = t_s
            out.append(StreamsWanted("vehicle reboot"))
            out.append(codec.Notice(codec.SEVERITY_WARNING, "companion: vehicle reboot, map reset"))
            return True
        self._latest_t_s = t_s if self._latest_t_s is None else max(self._latest_t_s, t_s)
        if self._camera_alive_unstamped:
            self._camera_alive_unstamped = False
            self._last_camera_t_s = t_s
        return True

    def _attitude_at(self, t_s: float) -> float | None:
        """Yaw at t_s from the latest ATTITUDE not after it, carried forward by its yaw rate."""
        for att in reversed(self._attitudes):
            if att.t_s <= t_s + TIME_EPS_S:
                gap = t_s - att.t_s
                if gap > self.config.commanding.max_attitude_age_s:
                    return None
                rate = att.yaw_rate_rad_s if math.isfinite(att.yaw_rate_rad_s) else 0.0
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
            if not (math.isfinite(lpn.north_m) and math.isfinite(lpn.east_m)):
                self._count("start_not_finite")
                return
            self.navigator = self._make_navigator(lpn.north_m, lpn.east_m, yaw)
            self.started_t_s = lpn.t_s
            log.info("estimator started at %.1f s: north %.1f m, east %.1f m, yaw %.1f deg",
                     lpn.t_s, lpn.north_m, lpn.east_m, math.degrees(yaw))
            out.append(NavigatorStarted(lpn.t_s))
        nav = self.navigator
        before = nav.t_s
        reports = nav.on_odometry(lpn.t_s, speed, yaw)
        if nav.t_s == before and before is not None:
            self._count("odometry_not_newer")
            return
        self._ap_yaw_rad = yaw
        if self.record_track:
            pose, cov = nav.slam.pose, nav.slam.pose_cov
            self.track.append(array("d", (lpn.t_s, *pose.tolist(), *cov.ravel().tolist())))
        due = (self._last_decision_t_s is None or lpn.t_s - self._last_decision_t_s
               >= self.config.commanding.setpoint_period_s - TIME_EPS_S)
        if (reports or due) and self.goal is not None:
            self._decide(t_link_s, lpn.t_s, out)
        # After the decision: a lock-step stub takes our ODOMETRY as the sign that everything we
        # do for this sample has been sent (companion/lockstep.py).
        self._maybe_publish_pose(lpn.t_s, out)

    def _make_navigator(self, north_m: float, east_m: float, yaw_rad: float) -> Navigator:
        est = self.config.estimator
        goal = self.goal or GoalConfig(north_m, east_m)
        pose_cov = np.diag([est.initial_position_sigma_m ** 2, est.initial_position_sigma_m ** 2,
                            math.radians(est.initial_yaw_sigma_deg) ** 2])
        return Navigator(np.array([north_m, east_m, wrap_angle(yaw_rad)]), pose_cov,
                         est.slam_noise(), est.gates(), self.config.guidance_params(goal.radius_m),
                         np.array([goal.north_m, goal.east_m]),
                         self.config.avoidance.strategy, self.config.avoidance.union_params())

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
                                      tuple(map(tuple, cov.tolist())), self.reset_counter))
        # Tracked movers, for the ground station to see (docs/messages.md).
        for mover in self.navigator.movers.states(self.navigator.clock_s):
            if np.all(np.isfinite(mover.position_ne_m)):
                out.append(codec.MoverReport(t_s, mover.obstacle_id, mover.track_id,
                                             float(mover.position_ne_m[0]),
                                             float(mover.position_ne_m[1])))

    # ------------------------------------------------------------ obstacles
    def _on_obstacles(self, t_link_s: float, frame: codec.ObstacleFrame, out: list[Output]) -> None:
        if frame.component_id not in (self.vehicle[1], self.config.link.camera_component_id):
            self._count("ignored_other_source")
            return
        if not math.isfinite(frame.t_s) or (self._latest_t_s is not None
                                            and frame.t_s < self._latest_t_s - REBOOT_BACKSTEP_S):
            # From before the vehicle's clock (a reboot not yet seen in its own messages, or a
            # glitch): it would be matched against the wrong pose. Reboots are detected on the
            # autopilot's messages only.
            self._count("obstacle_too_old")
            return
        self._last_camera_t_s = frame.t_s
        if frame.rejected:
            self._count("obstacle_rejected")
            log.debug("obstacle report refused: %s", frame.rejected)
            return
        if self.navigator is None:
            self._count("obstacle_before_estimator")
            return
        observations = [o for o in frame.observations if o.range_m <= PLAUSIBLE_RANGE_M]
        if len(observations) < len(frame.observations):
            self._count("observation_implausible_range")
            if not observations:
                return
        reports = self.navigator.on_observations(frame.t_s, observations)
        for report in reports:
            if report.action == "added":
                log.info("new landmark %s (obstacle id %s)", report.landmark_index,
                         report.obstacle_id)
        if reports and self.goal is not None:
            self._decide(t_link_s, self.navigator.t_s, out)

    # ------------------------------------------------------------ guidance and commanding
    def _camera_stale(self, t_s: float) -> bool:
        failsafe = self.config.failsafe
        if self._last_camera_t_s is None:
            return failsafe.require_camera
        return t_s - self._last_camera_t_s > failsafe.obstacle_timeout_s

    def _decide(self, t_link_s: float, t_s: float, out: list[Output]) -> None:
        self._last_decision_t_s = t_s
        nav = self.navigator
        if not nav.slam.is_healthy():
            self._safe(t_link_s, t_s, "estimator diverged", out)
            return
        command, change = nav.decide(t_s)
        if change is not None:
            self._on_urgency(change, out)
        if command.mode == "arrived" and self.arrival_t_s is None:
            self.arrival_t_s = t_s
            log.info("arrived at the goal at %.1f s", t_s)
            out.append(Arrived(t_s))
            out.append(codec.Notice(codec.SEVERITY_NOTICE, "companion: goal reached"))
        if self._camera_stale(t_s):
            self._safe(t_link_s, t_s, "obstacle data stale", out)
            return
        setpoint = self._setpoint(t_s, command.speed_mps, command.heading_rad, command.mode)
        if setpoint is None:
            self._safe(t_link_s, t_s, "non-finite setpoint", out)
            return
        if self._safe_reason is not None:
            log.log(logging.WARNING if self._safe_logged_commanding else logging.INFO,
                    "safe action ended (%s): guidance resumed", self._safe_reason)
            if self._safe_logged_commanding:
                out.append(codec.Notice(codec.SEVERITY_INFO, "companion: guidance resumed"))
            self._safe_reason, self._safe_logged_commanding = None, False
        self._send(t_link_s, setpoint, out)

    def _setpoint(self, t_s: float, speed_mps: float, heading_rad: float,
                  mode: str) -> codec.VelocitySetpoint | None:
        """Turn-limit the heading, rotate it into the autopilot's frame, clamp the speed."""
        commanding = self.config.commanding
        slam_yaw = float(self.navigator.slam.pose[2])
        ap_yaw = self._ap_yaw_rad
        change = limit_turn(slam_yaw, heading_rad, commanding.max_turn_rate_rad_s,
                            commanding.setpoint_period_s)
        # The autopilot's yaw drifts from the SLAM yaw; fly the SLAM heading in its frame.
        heading_ap = wrap_angle(slam_yaw + change + (ap_yaw - slam_yaw))
        speed = min(max(speed_mps, 0.0), commanding.max_speed_mps)
        vn, ve = speed * math.cos(heading_ap), speed * math.sin(heading_ap)
        if not all(math.isfinite(v) for v in (vn, ve, heading_ap, t_s)):
            return None
        return codec.VelocitySetpoint(*self.vehicle, t_s, vn, ve, heading_ap, mode)

    def _safe(self, t_link_s: float, t_s: float, reason: str, out: list[Output]) -> None:
        # ERROR (and a STATUSTEXT) once per reason while commanding; before that (on the ground,
        # camera not up yet) it is only worth an INFO line.
        commanding = self.commanding_allowed(t_link_s)
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

    def _send(self, t_link_s: float, setpoint: codec.VelocitySetpoint, out: list[Output]) -> None:
        if self.commanding_allowed(t_link_s):
            self.setpoints += 1
            out.append(setpoint)

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
        "started_t_s": pipeline.started_t_s,
        "arrived": pipeline.arrival_t_s is not None,
        "arrival_t_s": pipeline.arrival_t_s,
        "reset_counter": pipeline.reset_counter,
        "setpoints": pipeline.setpoints,
        "track": track,
        "landmarks": landmarks,
        "urgency_events": [asdict(r) for r in pipeline.urgency],
        "counters": dict(pipeline.counters),
        "rejected_by_estimator": dict(nav.rejected) if nav is not None else {},
    }
