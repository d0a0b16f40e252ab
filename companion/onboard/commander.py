"""Commanding: each decision made a setpoint, or the safe action, and the one way out.

A decision (``decide``) runs the navigator's guidance and urgency, then turns the command into
a setpoint in the autopilot's frame (turn-limited: core/avoidance/guidance.py shape_setpoint),
or takes the configured safe action (hold: velocity 0, current yaw) when the estimator diverged,
the camera is stale or the gate refuses the setpoint. Every setpoint leaves through ``send``:
commanding allowed, airborne (flight_phase.py), the vertical term added (heights.py), passed by
the gate (safety/gate.py). The flight phase is said as soon as its inputs change.
"""
from __future__ import annotations

import dataclasses
import logging
import math

import numpy as np

from companion.core.avoidance.guidance import shape_setpoint
from companion.core.geometry import wrap_angle
from companion.core.sample_interval import setpoint_interval_s
from companion.mavlink import codec
from companion.onboard.outputs import UrgencyRecord

log = logging.getLogger(__name__)

PHASE_CHANGES_KEPT = 1000          # flight phase changes kept for the report


class Commander:
    """The decision's state: the last decision and setpoint, the safe action, the phases said.

    ``pipeline``: the pipeline this part serves (its config, navigator, gate, flight phase,
    vertical hold, heights and vehicle are read at each decision, not copied here: a live
    parameter set replaces the config).
    """

    def __init__(self, pipeline) -> None:
        self._pipeline = pipeline
        self.last_decision_t_s: float | None = None
        self.safe_reason: str | None = None
        self._safe_logged_commanding = False
        self._last_shaped = None        # the last setpoint's velocity direction and nose (SLAM)
        self._last_shaped_t_s: float | None = None      # ... and its time
        self.last_command = None        # (t_s, GuidanceCommand) of the latest decision: the view
        self.urgency: list[UrgencyRecord] = []
        self.setpoints = 0
        self.stopped = False            # stop_setpoint() sent: no setpoint after it
        self._phase_said: str | None = None
        self.phase_changes: list[tuple[float, str, str]] = []   # (vehicle s, phase, source)

    def reset(self) -> None:
        """The estimate restarted: no last decision, no turn limit from the last setpoint."""
        self._last_shaped = self._last_shaped_t_s = None
        self.last_decision_t_s = None

    def decide(self, t_link_s: float, t_s: float, out: list) -> None:
        p = self._pipeline
        self.last_decision_t_s = t_s
        nav = p.navigator
        if not nav.slam.is_healthy():
            self.safe(t_link_s, t_s, "estimator diverged", out)
            # restart from the next good sample rather than hold for good
            log.error("estimator diverged at %.1f s: restarting from the next sample", t_s)
            p.count("estimator_restarts")
            p.reset_estimate()
            return
        self.sync_heights()
        command, change = nav.decide(t_s)
        self.last_command = (t_s, command)
        if change is not None:
            self._on_urgency(change, out)
        out.extend(p.estimator_notices.after_decision(nav, command))
        if command.mode == "arrived":
            p.goals.on_arrived(t_link_s, t_s, out)
        if p.liveness.camera_stale(t_s):
            self.safe(t_link_s, t_s, "obstacle data stale", out)
            return
        if self._look_around(t_link_s, t_s, out):
            return
        setpoint = self.setpoint(t_s, command)
        verdict = p.gate.check(setpoint)
        if not verdict.passed:
            self.safe(t_link_s, t_s, f"setpoint refused ({verdict.reason})", out)
            return
        if self.safe_reason is not None:
            log.log(logging.WARNING if self._safe_logged_commanding else logging.INFO,
                    "safe action ended (%s): guidance resumed", self.safe_reason)
            if self._safe_logged_commanding:
                out.append(codec.Notice(codec.SEVERITY_INFO, "companion: guidance resumed"))
            self.safe_reason, self._safe_logged_commanding = None, False
        self.send(t_link_s, setpoint, out)

    def _look_around(self, t_link_s: float, t_s: float, out: list) -> bool:
        """After a start in the air: a hold turning the nose round, then a step back from the
        nearest mapped obstacle (onboard/look_around.py) instead of guidance's setpoint; False
        once the look is over or was never wanted."""
        p = self._pipeline
        look = p.look_around
        if look.state == "done" or not (p.commanding_allowed(t_link_s)
                                        and p.phase.decide(t_s).may_command):
            return False
        was_active = look.active
        step = look.next_yaw(t_s, p.ap_yaw_rad, p.ap_speed_mps, self._nearest_ne_m())
        if step is None:
            if was_active:
                log.info("look-around over at %.1f s (%s): guidance flies on with %d landmarks",
                         t_s, look.end_reason, p.navigator.slam.landmark_count)
                out.append(codec.Notice(codec.SEVERITY_INFO,
                                        f"companion: look-around done ({look.end_reason})"))
            return False
        if not was_active:
            log.warning("started with the vehicle armed in the air at %.1f s: holding and "
                        "looking round before flying on", t_s)
            out.append(codec.Notice(codec.SEVERITY_WARNING,
                                    "companion: joined in flight, holding to look around"))
        self.send(t_link_s, codec.VelocitySetpoint(
            *p.vehicle, t_s, step.vel_north_mps, step.vel_east_mps, step.yaw_rad,
            "hold: look around" if step.step <= step.steps else "look around: back off"), out)
        return True

    def _nearest_ne_m(self) -> tuple[float, float] | None:
        """The nearest mapped obstacle's offset from the vehicle, turned into the autopilot's
        frame (its yaw drifts from the SLAM yaw, as in setpoint); None: nothing mapped."""
        p = self._pipeline
        slam = p.navigator.slam
        if slam.landmark_count == 0:
            return None
        pose = slam.pose
        rel = slam.landmarks() - pose[:2]
        north, east = rel[int(np.argmin(np.hypot(rel[:, 0], rel[:, 1])))]
        offset = p.ap_yaw_rad - float(pose[2])
        c, s = math.cos(offset), math.sin(offset)
        return (c * north - s * east, s * north + c * east)

    def setpoint(self, t_s: float, command) -> codec.VelocitySetpoint | None:
        """Turn-limit the velocity's direction and the nose (core/avoidance/guidance.py shape_setpoint),
        rotate them into the autopilot's frame, clamp the speed: the chosen speed (slowing,
        stopping, accelerating back) along the chosen direction; the yaw toward a watched mover
        if the command looks at one."""
        p = self._pipeline
        commanding = p.config.commanding
        slam_yaw = float(p.navigator.slam.pose[2])
        # turn-limited over the interval the setpoints come at (a GCS may have slowed the streams)
        interval_s = setpoint_interval_s(t_s, self._last_shaped_t_s, commanding.setpoint_period_s,
                                         commanding.max_attitude_age_s)
        shaped = shape_setpoint(slam_yaw, self._last_shaped, command,
                                commanding.max_turn_rate_rad_s, interval_s,
                                commanding.max_speed_mps, commanding.yaw_lead_s)
        self._last_shaped, self._last_shaped_t_s = shaped, t_s
        p.navigator.on_setpoint(shaped)
        # The autopilot's yaw drifts from the SLAM yaw; fly the SLAM heading in its frame.
        offset = p.ap_yaw_rad - slam_yaw
        heading_ap = wrap_angle(shaped.course_rad + offset)
        vn, ve = shaped.speed_mps * math.cos(heading_ap), shaped.speed_mps * math.sin(heading_ap)
        return codec.VelocitySetpoint(*p.vehicle, t_s, vn, ve,
                                      wrap_angle(shaped.yaw_rad + offset), command.mode)

    def safe(self, t_link_s: float, t_s: float, reason: str, out: list) -> None:
        """The configured safe action, said once per reason (ERROR and a STATUSTEXT while
        commanding; before that, on the ground or the camera not up yet, an INFO line)."""
        p = self._pipeline
        commanding = p.commanding_allowed(t_link_s) and p.phase.decide(t_s).may_command
        if (reason, commanding) != (self.safe_reason, self._safe_logged_commanding):
            action = p.config.failsafe.safe_action
            if commanding:
                log.error("%s: safe action %s", reason, action)
                out.append(codec.Notice(codec.SEVERITY_ERROR, f"companion: {reason}, {action}"))
            else:
                log.info("%s (not commanding): safe action %s when commanding", reason, action)
            self.safe_reason, self._safe_logged_commanding = reason, commanding
        p.count(f"safe_action: {reason}")
        if p.config.failsafe.safe_action == "hold":
            yaw = p.ap_yaw_rad if p.ap_yaw_rad is not None else 0.0
            self.send(t_link_s, codec.VelocitySetpoint(*p.vehicle, t_s, 0.0, 0.0, yaw,
                                                       f"hold: {reason}"), out)

    def stop_setpoint(self, t_link_s: float) -> list:
        """Zero velocity at the current yaw, through the gate, if commanding (on shutdown).
        It is the last setpoint: nothing is sent after it."""
        p = self._pipeline
        out: list = []
        if p.vehicle is not None and p.clock.latest_t_s is not None:
            yaw = p.ap_yaw_rad
            if yaw is None:
                yaw = p.attitude.latest_yaw_rad()
            self.send(t_link_s, codec.VelocitySetpoint(
                *p.vehicle, p.clock.latest_t_s, 0.0, 0.0,
                wrap_angle(0.0 if yaw is None else yaw), "stop"), out)
            if p.identity.dialect.name == "px4" and p.offboard.hand_to_hold():
                # ours to hand back: Hold now, not the offboard-loss failsafe after COM_OF_LOSS_T
                log.info("shutdown: OFFBOARD was ours: asking for Hold (AUTO.LOITER)")
                out.append(codec.ModeRequest(*p.vehicle, codec.PX4_AUTO_LOITER, "stop: hold"))
        self.stopped = True
        return out

    def send(self, t_link_s: float, setpoint: codec.VelocitySetpoint, out: list) -> None:
        """The one place a setpoint leaves: commanding allowed, airborne (flight phase), the
        vertical hold added, and passed by the gate."""
        p = self._pipeline
        if not p.commanding_allowed(t_link_s):
            p.vertical.reset()
            if p.identity.dialect.name == "px4" and not self.stopped:
                self._offboard_stream(t_link_s, setpoint.t_s, out)
            return
        if self.stopped:
            p.count("setpoint_after_stop")
            return
        decision = p.phase.decide(setpoint.t_s)
        if decision.phase != self._phase_said:
            self._say_phase(setpoint.t_s, decision)
        if not decision.may_command:
            p.vertical.reset()
            p.count(f"no_setpoint_{decision.phase.replace(' ', '_')}")
            return
        if setpoint.reason != "stop":     # the shutdown stop: vz = 0, ArduCopter holds there
            vel_down = p.heights.vel_down_mps(       # 3D: the decision's climb (heights.py)
                p.navigator, p.phase.up_m, p.vertical.vel_down_mps(p.phase.up_m),
                safe_hold=setpoint.reason.startswith("hold: "))
            setpoint = dataclasses.replace(setpoint, vel_down_mps=vel_down)
        verdict = p.gate.check(setpoint)
        if not verdict.passed:
            p.count(f"setpoint_refused: {verdict.reason}")
            return
        self.setpoints += 1
        out.append(setpoint)

    def _offboard_stream(self, t_link_s: float, t_s: float, out: list) -> None:
        """PX4, armed but not in OFFBOARD: while airborne, a hold (velocity 0, vz 0, the
        vehicle's yaw) in place of the decision's setpoint, which PX4 does not fly outside
        OFFBOARD but counts as the offboard signal its switch needs; with px4.offboard
        'companion', the request for OFFBOARD when due (onboard/autopilot_dialect.py)."""
        p = self._pipeline
        if p.vehicle is None or not p.armed or not p.liveness.heartbeat_fresh(t_link_s):
            return
        decision = p.phase.decide(t_s)
        if decision.phase != self._phase_said:
            self._say_phase(t_s, decision)
        step = p.offboard.step(t_s, decision.may_command)
        if not step.stream:
            return
        yaw = p.ap_yaw_rad if p.ap_yaw_rad is not None else p.attitude.latest_yaw_rad()
        hold = codec.VelocitySetpoint(*p.vehicle, t_s, 0.0, 0.0,
                                      wrap_angle(0.0 if yaw is None else yaw),
                                      "hold: offboard stream")
        if not p.gate.check(hold).passed:
            p.count("offboard_stream_refused")
            return
        p.count("offboard_stream")
        out.append(hold)
        if step.request:
            log.info("%s at %.1f s", step.reason, t_s)
            out.append(codec.ModeRequest(*p.vehicle, codec.PX4_OFFBOARD, "offboard engage"))
            out.append(codec.Notice(codec.SEVERITY_INFO, "companion: asking for OFFBOARD"))

    def sync_heights(self) -> None:
        """avoidance.vertical: the navigator's altitude and cruise altitude (onboard/heights.py)."""
        p = self._pipeline
        up_m = p.phase.up_m
        p.heights.sync(p.navigator, up_m, p.heights.cruise_up_m(p.vertical.target_up_m, up_m))

    def note_phase(self) -> None:
        """The phase as soon as its inputs change, goal or not: a mission uploaded later must
        not hide when the vehicle became airborne (issue 32)."""
        p = self._pipeline
        t_s = p.clock.latest_t_s
        if t_s is None:
            return
        decision = p.phase.decide(t_s)
        if decision.phase != self._phase_said:
            self._say_phase(t_s, decision)

    def _say_phase(self, t_s: float, decision) -> None:
        self._phase_said = decision.phase
        if len(self.phase_changes) < PHASE_CHANGES_KEPT:
            self.phase_changes.append((t_s, decision.phase, decision.source))
        log.info("flight phase %s (%s) at %.1f s: %s", decision.phase, decision.source, t_s,
                 "commanding" if decision.may_command else "no setpoints")

    def _on_urgency(self, change, out: list) -> None:
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
