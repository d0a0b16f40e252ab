"""Where the vehicle is going: the configured goal, the autopilot's mission, a "fly to here".

The goal in metres (``goal_ne``) and its radius, a latitude/longitude goal made metres once the
EKF origin (or HOME) is known, the mission's current waypoint (mission_follow.py), a ground
station's "fly to here" (fly_to.py: it holds the goal until the next one), and the arrival.
The navigator's goal follows every change.
"""
from __future__ import annotations

import dataclasses
import logging

import numpy as np

from companion.config.service import GoalConfig
from companion.mavlink import codec, mission_codec
from companion.onboard import fly_to
from companion.onboard.goal import goal_north_east
from companion.onboard.mission_follow import MissionFollower
from companion.onboard.outputs import Arrived

log = logging.getLogger(__name__)


class Goals:
    """The goal, the mission and the arrival.

    ``pipeline``: the pipeline this part serves (its config, navigator, vehicle and commanding
    state are read at each event, not copied here).
    """

    def __init__(self, pipeline, goal: GoalConfig | None) -> None:
        self._pipeline = pipeline
        self.goal = goal
        self.goal_ne: tuple[float, float] | None = (
            (goal.north_m, goal.east_m) if goal is not None and not goal.is_geographic
            and not goal.mission else None)
        self.goal_radius_m = goal.radius_m if goal is not None else 1.0
        self.mission = MissionFollower(pipeline.config.link.component_id, goal.radius_m,
                                       recheck_s=goal.mission_recheck_s) \
            if goal is not None and goal.mission else None
        self._goal_reference: str | None = None
        self.geo_reference: codec.GeoReference | None = None   # the EKF origin (or HOME)
        self._fly_to_active = False
        self.arrival_t_s: float | None = None

    @property
    def needs_geo_reference(self) -> bool:
        """A latitude/longitude goal (or mission waypoint) still waits for the EKF origin or HOME."""
        if self._pipeline.config.fly_to.enabled and (self.geo_reference is None
                                                     or self.geo_reference.kind != "origin"):
            return True                   # a "fly to here" needs it too
        if self.mission is not None:
            return self.mission.needs_geo_reference
        return self.goal is not None and self.goal.is_geographic and self._goal_reference != "origin"

    def on_goal_request(self, request: mission_codec.GoalRequest, out: list) -> None:
        """A ground station's "fly to here" (companion/onboard/fly_to.py): the new goal, or refused."""
        p = self._pipeline
        config = p.config
        if not config.fly_to.enabled or p.vehicle is None \
                or request.component_id == config.link.component_id:
            p.count("goal_request_ignored")
            return
        position = tuple(p.navigator.slam.pose[:2]) if p.navigator is not None else None
        verdict = fly_to.judge(request, p.vehicle,
                               p.identity.steering,
                               self.geo_reference, position, config.fly_to)
        if verdict.reason == "not addressed to the vehicle":
            p.count("goal_request_ignored")
            return
        if not verdict.accepted:
            p.count("goal_refused")
            log.warning("%s from %d/%d refused: %s", request.kind, request.system_id,
                        request.component_id, verdict.reason)
            out.append(codec.Notice(codec.SEVERITY_WARNING,
                                    f"companion: goal refused: {verdict.reason}"))
            return
        self._fly_to_active = True
        self.set_goal(verdict.north_m, verdict.east_m, config.fly_to.radius_m)
        self.arrival_t_s = None
        log.info("%s from %d/%d: new goal north %.1f m, east %.1f m", request.kind,
                 request.system_id, request.component_id, verdict.north_m, verdict.east_m)
        out.append(codec.Notice(codec.SEVERITY_INFO, f"companion: new goal N {verdict.north_m:.0f}"
                                                     f" E {verdict.east_m:.0f} m"))

    def set_goal(self, north_m: float, east_m: float, radius_m: float) -> None:
        self.goal_ne, self.goal_radius_m = (north_m, east_m), radius_m
        nav = self._pipeline.navigator
        if nav is not None:
            nav.goal = np.array(self.goal_ne)
            nav.params = dataclasses.replace(nav.params, goal_radius_m=radius_m)

    def on_mission_event(self, t_link_s: float, event, out: list) -> None:
        """The autopilot's mission protocol (a mission goal only)."""
        if self.mission is not None:
            out.extend(self.mission.on_event(t_link_s, event))
            self.sync_mission_goal()

    def mission_tick(self, t_link_s: float) -> list:
        """Mission download timeouts and retries (the service calls this on its timer)."""
        if self.mission is None:
            return []
        out = self.mission.tick(t_link_s)
        self.sync_mission_goal()
        return out

    def sync_mission_goal(self) -> None:
        """The mission's current waypoint is the navigator's goal."""
        goal = self.mission.goal()
        if self._fly_to_active or goal is None \
                or (self.goal_ne, self.goal_radius_m) == (goal[:2], goal[2]):
            return                # a "fly to here" holds the goal until the next one
        log.info("goal: waypoint at north %.1f m, east %.1f m (radius %.1f m)", *goal)
        self.set_goal(*goal)

    def on_geo_reference(self, ref: codec.GeoReference) -> None:
        if self.geo_reference is None or ref.kind == "origin":
            self.geo_reference = ref
        if self.mission is not None:
            self.mission.on_geo_reference(ref)
            self.sync_mission_goal()
            return
        goal_waits = self.goal is not None and self.goal.is_geographic \
            and self._goal_reference != "origin" and not self._fly_to_active
        if not goal_waits or (ref.kind == "home" and self._goal_reference):
            return                        # the EKF origin wins over HOME; one HOME is enough
        try:
            self.goal_ne = goal_north_east(self.goal.lat_deg, self.goal.lon_deg, ref.lat_deg,
                                           ref.lon_deg, ref.north_m, ref.east_m)
        except ValueError as exc:
            self._pipeline.count("goal_too_far")
            log.error("%s", exc)
            return
        self._goal_reference = ref.kind
        log.info("goal %.7f, %.7f -> north %.1f m, east %.1f m (from the %s)", self.goal.lat_deg,
                 self.goal.lon_deg, *self.goal_ne, "EKF origin" if ref.kind == "origin" else "HOME")
        nav = self._pipeline.navigator
        if nav is not None:
            nav.goal = np.array(self.goal_ne)

    def on_arrived(self, t_link_s: float, t_s: float, out: list) -> None:
        """The decision says arrived: the mission's next waypoint, or the goal reached."""
        if self.mission is not None and not self._fly_to_active:
            self._on_waypoint_arrived(t_link_s, t_s, out)
        elif self.arrival_t_s is None:
            self.arrival_t_s = t_s
            log.info("arrived at the goal at %.1f s", t_s)
            out.append(Arrived(t_s))
            out.append(codec.Notice(codec.SEVERITY_NOTICE, "companion: goal reached"))

    def _on_waypoint_arrived(self, t_link_s: float, t_s: float, out: list) -> None:
        """Only while commanding (GUIDED, armed, airborne): a waypoint the pilot flew through in
        another mode was not flown by us."""
        p = self._pipeline
        if self.mission.complete or not (p.commanding_allowed(t_link_s)
                                         and p.phase.decide(t_s).may_command):
            return
        out.extend(self.mission.on_arrived(t_s))
        self.sync_mission_goal()
        if self.mission.complete:
            self.arrival_t_s = t_s
            out.append(Arrived(t_s))
