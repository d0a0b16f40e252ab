"""Stop and look around before flying on, after a start that finds the vehicle in the air.

Why (issue 31, kill -9 and restart on ArduCopter): a companion restarted by systemd mid-flight
starts with an empty map. ArduCopter meanwhile flew GUID_TIMEOUT (3 s) on the dead process's last
velocity setpoint, then braked to a stop (ModeGuided: the velocity target zeroed, the yaw kept),
so the vehicle stands about 20 m past where the old process died, and an obstacle it was steering
round can be off the nose, outside a 90 deg camera. Flying on at once, the new process sees it
only inside the safety distance. An operator beside the vehicle would first stop and look round.

So: when the first vehicle heartbeat already says armed (the service joined a flight; it never saw
the vehicle disarmed), the first commanded decisions are a hold (velocity 0) while the nose turns
a full circle in steps of ``step_rad`` (ArduCopter turns to a yaw target by the shortest way, so
each step stays below 180 deg), dwelling ``dwell_s`` at each step so that the camera's frames
confirm what they see (the landmark lifecycle needs several sightings). Then guidance flies on
from the full map. A vehicle still moving when commanding starts is first braked: the yaw steps
begin once its speed is below ``stopped_speed_mps``. ``timeout_s`` bounds the whole look (a yaw
that never settles: a wind, a yaw limit) so that the flight goes on regardless.

Then, if the nearest mapped obstacle is within ``clear_m`` (the safety distance plus a margin),
it first steps back from it, slowly (``back_off_speed_mps``) and nose first, until it is that far:
guidance starting at rest 2.5 m outside the safety distance flies the collision cone's tangent
from the start, and ArduCopter's lag in turning its velocity cuts inside it (measured on SITL,
README "Kill -9 and restart": 8.7-10.0 m without the step back).

A flight the service saw from the ground (disarmed first) never looks round: its map was built
as it flew. Pure: no I/O; time (the vehicle's) is an argument.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from companion.core.geometry import wrap_angle

WAITING = "waiting"      # not yet commanding: the decision is still to be taken
LOOKING = "looking"
DONE = "done"


@dataclass(frozen=True)
class LookAroundParams:
    enabled: bool = True
    step_rad: float = math.radians(60.0)
    yaw_tolerance_rad: float = math.radians(10.0)
    dwell_s: float = 0.5
    stopped_speed_mps: float = 0.5
    timeout_s: float = 40.0
    clear_m: float = 15.0                  # step back until the nearest obstacle is this far
    back_off_speed_mps: float = 1.0


@dataclass(frozen=True)
class LookStep:
    """One commanded decision of the look: the yaw to hold (autopilot frame) and why."""
    yaw_rad: float
    step: int               # 0: braking, 1..steps: the step being turned to, steps + 1: back off
    steps: int
    vel_north_mps: float = 0.0
    vel_east_mps: float = 0.0


class LookAround:
    """The look's state machine; ``next_yaw`` is asked at every commanded decision."""

    def __init__(self, params: LookAroundParams) -> None:
        self.params = params
        self.state = WAITING
        self.saw_disarmed = False
        self.joined_armed: bool | None = None     # the first vehicle heartbeat's armed flag
        self.started_t_s: float | None = None
        self.ended_t_s: float | None = None
        self.end_reason: str | None = None
        self._steps = max(1, math.ceil(2.0 * math.pi / params.step_rad - 1e-9))
        self._start_yaw_rad: float | None = None
        self._step = 0
        self._reached_t_s: float | None = None
        self.backed_off_m: float | None = None    # nearest obstacle when the step back began

    def on_heartbeat(self, armed: bool) -> None:
        if self.joined_armed is None:
            self.joined_armed = armed
        if not armed:
            self.saw_disarmed = True

    @property
    def active(self) -> bool:
        return self.state == LOOKING

    def next_yaw(self, t_s: float, yaw_rad: float, speed_mps: float,
                 nearest_ne_m: tuple[float, float] | None = None) -> LookStep | None:
        """A commanded decision at ``t_s`` with the autopilot's yaw and ground speed, and the
        nearest mapped obstacle's offset from the vehicle (north, east, autopilot frame; None:
        nothing mapped): the hold's yaw (or the step back) while the look goes on, None once it
        is over (or was never wanted)."""
        if self.state == DONE:
            return None
        if self.state == WAITING:
            if not self.params.enabled or self.saw_disarmed or not self.joined_armed:
                self._end(t_s, "not needed")
                return None
            self.state, self.started_t_s = LOOKING, t_s
        if t_s - self.started_t_s > self.params.timeout_s:
            self._end(t_s, "timeout")
            return None
        if self._step > self._steps:
            return self._back_off(t_s, nearest_ne_m)
        if self._start_yaw_rad is None:
            if speed_mps > self.params.stopped_speed_mps:
                return LookStep(wrap_angle(yaw_rad), 0, self._steps)      # brake first
            self._start_yaw_rad, self._step = yaw_rad, 1
        target = self._target(self._step)
        if abs(wrap_angle(yaw_rad - target)) <= self.params.yaw_tolerance_rad:
            if self._reached_t_s is None:
                self._reached_t_s = t_s
            if t_s - self._reached_t_s >= self.params.dwell_s:
                self._step, self._reached_t_s = self._step + 1, None
                if self._step > self._steps:
                    return self._back_off(t_s, nearest_ne_m)
                target = self._target(self._step)
        else:
            self._reached_t_s = None
        return LookStep(target, self._step, self._steps)

    def _back_off(self, t_s: float, nearest_ne_m) -> LookStep | None:
        """After the circle: away from the nearest obstacle, nose first, until clear_m."""
        distance_m = math.hypot(*nearest_ne_m) if nearest_ne_m is not None else math.inf
        if distance_m >= self.params.clear_m:
            self._end(t_s, "full circle" if self.backed_off_m is None else "full circle, backed off")
            return None
        away = math.atan2(-nearest_ne_m[1], -nearest_ne_m[0])
        if self.backed_off_m is None:
            self.backed_off_m = distance_m          # where it began: for the report
        speed = self.params.back_off_speed_mps
        return LookStep(away, self._steps + 1, self._steps, speed * math.cos(away),
                        speed * math.sin(away))

    def _target(self, step: int) -> float:
        return wrap_angle(self._start_yaw_rad + step * 2.0 * math.pi / self._steps)

    def _end(self, t_s: float, reason: str) -> None:
        self.state, self.ended_t_s, self.end_reason = DONE, t_s, reason
