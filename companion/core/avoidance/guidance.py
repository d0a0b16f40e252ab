"""Guidance: goal seeking, the paper's collision-cone avoidance, and Khatib's potential field.

Everything here works on the estimate (pose and mapped obstacles), never on the truth.
Headings are yaw in LOCAL_NED (clockwise from north), radians.

Deflection, the paper's open point (ALGORITHM-NOTES.md): read literally, the paper deflects by the
unsigned look angle to the obstacle. We take the geometric reading instead: the new heading is the
current velocity's heading plus ``eta`` times the signed angle from V to the chosen tangent p_i, so
the vehicle leaves the cone on the near side with margin (eta > 1). The Monte Carlo results in the
README show the effect.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Callable

import numpy as np

from companion.core.avoidance.cone import ConeVerdict, check_cone, signed_angle
from companion.core.geometry import wrap_angle

if TYPE_CHECKING:
    from companion.core.avoidance.arc import Motion
    from companion.core.avoidance.seen_space import SeenSpace


@dataclass(frozen=True)
class GuidanceParams:
    """Settings of the guidance law (SI units, radians)."""
    cruise_speed_mps: float
    safety_distance_m: float
    horizon_s: float
    eta: float
    goal_radius_m: float
    mission_time_s: float | None = None
    inflation_sigmas: float = 0.0        # d += k * sigma of the relative position (0: paper)
    approach_decel_mps2: float = 1.0     # speed = min(cruise, sqrt(2 a dist)) near the goal
    apf_attraction_gain: float = 1.0     # Khatib's k, 1/s
    apf_repulsion_gain: float = 3.0e5    # Khatib's eta, m^3/s: holds ~d on the paper world
    apf_influence_m: float = 20.0        # Khatib's rho_0


@dataclass(frozen=True)
class Threat:
    """One obstacle's verdict, with the safety radius actually used for it."""
    index: int
    verdict: ConeVerdict
    safety_radius_m: float
    urgent: bool


@dataclass(frozen=True)
class GuidanceCommand:
    """What to fly: a speed and an absolute heading, plus why.

    mode: 'goal' (nothing urgent), 'avoid' (deflected by the cone), 'escape' (inside a safety
    circle), 'arrived', or 'apf'; the velocity choice also says 'slow' (only a quarter speed or
    less keeps d), 'stop' (only stopping does) and 'hold' (nothing does: the most clearance).
    heading_rad is the velocity's direction; the nose points there too unless yaw_rad says.
    """
    speed_mps: float
    heading_rad: float
    mode: str
    urgent_index: int | None = None
    time_to_go_s: float | None = None
    threats: tuple[Threat, ...] = ()
    side: int = 0          # union guidance: +1 passing with the goal on the left, -1 right, 0 none
    yaw_rad: float | None = None   # a multicopter's nose apart from its velocity: toward a tracked
                                   # mover it cannot see (core/avoidance/look_at.py); None: along heading_rad
    free_course: bool = False      # a multicopter's evasion (core/avoidance/evade.py): the velocity
                                   # setpoint goes to heading_rad at once, not turned at the turn
                                   # rate (the autopilot's acceleration limit shapes the flight);
                                   # the nose holds yaw_rad


@dataclass(frozen=True)
class GuidanceInputs:
    """What one decision of the union law (union.guide_union) or the velocity choice
    (velocity_choice.guide_flyable) is made on, all from the estimate.

    ``pose`` (3,) and ``goal`` (2,); ``obstacles`` (n, 2), their relative-position covariances
    ``rel_covs`` (n, 2, 2) or None (no inflation) and ``velocities`` (n, 2) or None (all static);
    ``previous_heading_rad``: the last choice (hysteresis), None before the first; ``side``: the
    committed side (+1, -1, 0 none). The velocity choice's only: ``motion`` (the vehicle's limits
    and velocity now, arc.py); ``growth_mps`` (n,): how fast each obstacle's radius grows with
    time there (a mover's velocity uncertainty); ``clear_reach_m``: the commitment's reach
    (commitment.py); ``seen``: the space the camera has looked at (seen_space.py); ``spread_m``
    (n,): how far each obstacle may be from its estimate now (a coasting track's position sigma,
    a young mover's extrapolation), added to its safety distance (at most union.MAX_SPREAD_M);
    ``look``: the flank scan's heading for a chosen one (flank_scan.py), or None; ``kept_path_ne_m``
    (k, 2): the path the follower followed last (path_search.plan_path's ``kept_ne_m``), or None."""
    pose: np.ndarray
    goal: np.ndarray
    obstacles: np.ndarray
    rel_covs: np.ndarray | None = None
    previous_heading_rad: float | None = None
    side: int = 0
    velocities: np.ndarray | None = None
    motion: Motion | None = None
    growth_mps: np.ndarray | None = None
    clear_reach_m: float | None = None
    seen: SeenSpace | None = None
    spread_m: np.ndarray | None = None
    look: Callable[[float], float | None] | None = None
    kept_path_ne_m: np.ndarray | None = None


def inflated_radius(d: float, rel_cov: np.ndarray | None, sigmas: float) -> float:
    """d plus ``sigmas`` standard deviations of the relative position along its worst axis."""
    if rel_cov is None or sigmas <= 0.0:
        return d
    worst_var = float(np.linalg.eigvalsh(0.5 * (rel_cov + rel_cov.T))[-1])
    return d + sigmas * math.sqrt(max(worst_var, 0.0))


def is_urgent(verdict: ConeVerdict, horizon_s: float, t_s: float,
              mission_time_s: float | None) -> bool:
    """Conditions (1) and (2) of the paper: in the cone, 0 < t_go < T, and t + t_go < t_f."""
    if verdict.kind == "inside":
        return True
    if not verdict.in_cone:
        return False
    ttg = verdict.time_to_go_s
    if not 0.0 < ttg < horizon_s:
        return False
    return mission_time_s is None or t_s + ttg < mission_time_s


def assess(position: np.ndarray, velocity: np.ndarray, obstacles: np.ndarray,
           rel_covs: np.ndarray | None, params: GuidanceParams, t_s: float,
           obstacle_vels: np.ndarray | None = None) -> list[Threat]:
    """Run the cone on every obstacle. obstacles (n,2); rel_covs (n,2,2) or None."""
    threats = []
    for i, obstacle in enumerate(obstacles):
        d = inflated_radius(params.safety_distance_m,
                            None if rel_covs is None else rel_covs[i], params.inflation_sigmas)
        rel_vel = velocity if obstacle_vels is None else velocity - obstacle_vels[i]
        verdict = check_cone(obstacle - position, rel_vel, d)
        urgent = is_urgent(verdict, params.horizon_s, t_s, params.mission_time_s)
        threats.append(Threat(i, verdict, d, urgent))
    return threats


def most_urgent(threats: list[Threat]) -> Threat | None:
    """The urgent threat with the smallest time to go (ties: the lower index)."""
    urgent = [t for t in threats if t.urgent]
    return min(urgent, key=lambda t: (t.verdict.time_to_go_s, t.index)) if urgent else None


def approach_speed(params: GuidanceParams, goal_distance_m: float) -> float:
    return min(params.cruise_speed_mps,
               math.sqrt(2.0 * params.approach_decel_mps2 * max(goal_distance_m, 0.0)))


def escape_heading(rel_pos: np.ndarray, to_goal: np.ndarray) -> float:
    """Inside a safety circle: 45 degrees between straight away and the tangent on the goal's side."""
    away = -rel_pos / max(np.linalg.norm(rel_pos), 1e-9)
    right = np.array([-away[1], away[0]])
    side = right if float(right @ to_goal) >= 0.0 else -right
    direction = away + side
    return math.atan2(direction[1], direction[0])


def toward_goal(pose: np.ndarray, goal: np.ndarray) -> tuple[float, float]:
    """Distance (m) and heading (rad, LOCAL_NED yaw) from the pose to the goal."""
    to_goal = goal - pose[:2]
    return float(np.hypot(*to_goal)), math.atan2(to_goal[1], to_goal[0])


def guide_cone(pose: np.ndarray, goal: np.ndarray, obstacles: np.ndarray,
               rel_covs: np.ndarray | None, params: GuidanceParams, t_s: float,
               obstacle_vels: np.ndarray | None = None) -> GuidanceCommand:
    """The paper's law: fly at the goal unless an obstacle is urgent, then deflect from it."""
    position = pose[:2]
    goal_distance, goal_heading = toward_goal(pose, goal)
    if goal_distance <= params.goal_radius_m:
        return GuidanceCommand(0.0, pose[2], "arrived")
    speed = approach_speed(params, goal_distance)
    velocity = speed * np.array([math.cos(pose[2]), math.sin(pose[2])])
    threats = assess(position, velocity, obstacles, rel_covs, params, t_s, obstacle_vels)
    threat = most_urgent(threats)
    if threat is None:
        return GuidanceCommand(speed, goal_heading, "goal", threats=tuple(threats))
    if threat.verdict.kind == "inside":
        heading = escape_heading(obstacles[threat.index] - position,
                                 np.array([math.cos(goal_heading), math.sin(goal_heading)]))
        return GuidanceCommand(speed, heading, "escape", threat.index, 0.0, tuple(threats))
    deflection = params.eta * signed_angle(velocity, np.asarray(threat.verdict.aim))
    heading = wrap_angle(pose[2] + deflection)
    return GuidanceCommand(speed, heading, "avoid", threat.index, threat.verdict.time_to_go_s,
                           tuple(threats))


def guide_apf(pose: np.ndarray, goal: np.ndarray, obstacles: np.ndarray,
              params: GuidanceParams) -> GuidanceCommand:
    """Khatib's artificial potential field: fly along F = -grad U, at a speed |F| / k capped.

    U_G = k |p - p_G|^2 / 2; U_O = eta (1/rho - 1/rho_0)^2 / 2 for rho <= rho_0, rho the distance to
    the obstacle centre. The speed |F|/k makes the field a position controller: where the forces
    cancel (a local minimum), the vehicle stops. That trap is the method's known weakness, kept.
    """
    position = pose[:2]
    goal_distance, _ = toward_goal(pose, goal)
    if goal_distance <= params.goal_radius_m:
        return GuidanceCommand(0.0, pose[2], "arrived")
    force = params.apf_attraction_gain * (goal - position)
    for obstacle in obstacles:
        away = position - obstacle
        rho = float(np.hypot(*away))
        if 1e-6 < rho <= params.apf_influence_m:
            magnitude = (params.apf_repulsion_gain * (1.0 / rho - 1.0 / params.apf_influence_m)
                         / (rho * rho))
            force = force + magnitude * away / rho
    norm = float(np.hypot(*force))
    speed = min(approach_speed(params, goal_distance), norm / params.apf_attraction_gain)
    heading = math.atan2(force[1], force[0]) if norm > 1e-9 else pose[2]
    return GuidanceCommand(speed, heading, "apf")


def limit_turn(current_heading_rad: float, desired_heading_rad: float,
               max_turn_rate_rad_s: float, dt_s: float) -> float:
    """The heading change toward the desired heading that the turn-rate limit allows in dt."""
    max_change = max_turn_rate_rad_s * dt_s
    change = wrap_angle(desired_heading_rad - current_heading_rad)
    return max(-max_change, min(max_change, change))


@dataclass(frozen=True)
class ShapedSetpoint:
    """One setpoint's horizontal part, in the estimate's frame: the velocity's direction and
    speed, and the nose's yaw (the same as the direction unless the command looks elsewhere);
    ``apart``: the nose is (still) away from the velocity's direction after a look."""
    course_rad: float
    speed_mps: float
    yaw_rad: float
    apart: bool = False


def shape_setpoint(yaw_now_rad: float, last: ShapedSetpoint | None, command: GuidanceCommand,
                   max_turn_rate_rad_s: float, dt_s: float, max_speed_mps: float,
                   yaw_lead_s: float | None = None) -> ShapedSetpoint:
    """The command as one setpoint after ``last`` (the previous one, None at first): each of
    velocity direction and nose turns at most ``max_turn_rate_rad_s * dt_s`` toward its target,
    the speed within [0, max_speed_mps].

    The velocity turns from the nose (where the camera looks) while the two fly together, as the
    velocity choice's arc assumes (core/avoidance/arc.py: the course turns at the turn rate). While they
    are apart (the command looks at a threat, or the nose is still coming back from a look), it
    turns from the last commanded direction instead: a nose pointed elsewhere must not drag the
    velocity after it. Without looks this is the plain turn limit from the nose.
    ``yaw_lead_s`` (None: off): the nose's turn goes on from the last setpoint's yaw, kept within
    ``max_turn_rate_rad_s * yaw_lead_s`` of the nose now, rather than from the nose now. An
    autopilot whose yaw lags its target (ArduCopter: about 0.3 s) then turns at the full rate;
    turned from the nose now, each setpoint asks only one step ahead of a lagging nose and the
    turn slows to the step over the lag (9 deg/s on ArduCopter 4.6 SITL for 30 deg/s asked).
    """
    max_change = max_turn_rate_rad_s * dt_s
    if yaw_lead_s is not None and last is not None:
        lead = max_turn_rate_rad_s * yaw_lead_s
        yaw_now_rad = wrap_angle(yaw_now_rad + max(-lead, min(lead, wrap_angle(
            last.yaw_rad - yaw_now_rad))))
    apart = last is not None and (
        command.yaw_rad is not None
        or (last.apart and abs(wrap_angle(yaw_now_rad - last.course_rad)) > max_change + 1e-9))
    reference = last.course_rad if apart else yaw_now_rad
    course = wrap_angle(reference + limit_turn(reference, command.heading_rad,
                                               max_turn_rate_rad_s, dt_s))
    if command.free_course:
        # an evasion: the setpoint is the command (evade.py); once it ends, the velocity is led
        # by the nose again at once (not apart: a course turning ahead of a lagging nose flies
        # where the camera does not look; traffic seed 58 met a crosser from that side)
        course, apart = wrap_angle(command.heading_rad), False
    target = course if command.yaw_rad is None else command.yaw_rad
    yaw = wrap_angle(yaw_now_rad + limit_turn(yaw_now_rad, target, max_turn_rate_rad_s, dt_s))
    if yaw_lead_s is not None and last is not None:
        # the lead's clamp must not make the yaw (nor the course it leads) jump between
        # setpoints: each stays within one step of the last one's
        yaw = wrap_angle(last.yaw_rad + limit_turn(last.yaw_rad, yaw, max_turn_rate_rad_s, dt_s))
        if not command.free_course:
            course = wrap_angle(last.course_rad + limit_turn(last.course_rad, course,
                                                             max_turn_rate_rad_s, dt_s))
    speed = command.speed_mps if not math.isfinite(command.speed_mps) \
        else min(max(command.speed_mps, 0.0), max_speed_mps)
    return ShapedSetpoint(course, speed, yaw, apart)     # a NaN speed stays NaN: the gate refuses it
