"""A multicopter's evasion: stop, side-step or back off, its nose held on what comes (issue 33).

The velocity choice (velocity_choice.py) flies a multicopter where its camera looks: a heading
beyond half the view is turned to in place before the vehicle moves off (union.turn_speed_factor,
arc._fly_copter). Against a mover met head-on that is the wrong reflex. Seen at 36 m and closing
at 9.4 m/s (a 4.4 m/s mover, the copter at 5 m/s), it arrives in 3.8 s; a 90 deg turn in place
takes 3 s at 30 deg/s, and the vehicle brakes straight meanwhile, in the mover's lane
(docs/copter-headon-failures.md: every head-on failure of copter.yaml). A multicopter does not
need its nose to move sideways: its velocity setpoint can point anywhere, and the autopilot
reaches it within its acceleration limit, as a vector.

Here the candidates are that: every heading of the 5 deg grid at cruise and half cruise, flown
with the velocity setpoint set at once (``free_course``) and the nose held where it is (so the
camera stays on the mover ahead), plus stopping (braking straight). Each is rolled out as the
vehicle flies it (``fly_strafe``: the velocity moves toward the setpoint at max_accel as a vector
for the horizon, then brakes to rest) and measured as every other candidate is (arc.clearance:
movers at their predicted positions, their radius grown by their velocity's uncertainty). The
forward camera does not look where a side-step or a back-off goes, so its path must also keep d
from space never seen (seen_space.py), always, not only where the stopping distance exceeds d.
With a mover near, that path is flown for the loop's latency and then braked (speed_limit.py's
rule: re-decided every period, the vehicle must still be able to stop short of what it has not
seen), not held over the whole horizon, which refused a 5 m/s side-step that side cameras had
seen room for (issue 46); a static world's brake aside keeps the whole horizon.

How the velocity choice uses them (velocity_choice.choose_velocity, only with a mover among the
obstacles and only for a multicopter; static worlds and the unicycle are flown as before):
after every nose-led option (cruise down to a quarter, slow, stop) has failed, the first
evasion in the order of the union law's cost whose margin is >= EVADE_SPARE_M (1 m), else the
one with the most margin >= 0 (a thin margin nearer the goal is eaten by a mover's drift
before it passes); none: the evasion with the most margin enters the last resort's
comparison ("hold"), where a slower option wins ties of
0.5 m. A stop (speed 0) is itself a candidate, so a stop that keeps d is preferred to any
evasion whose clearance is in doubt (margin < 0 with the mover's uncertainty), and a side-step
is only taken over a stop when it keeps more clearance.
"""
from __future__ import annotations

import math

import numpy as np

from companion.core.avoidance import speed_limit
from companion.core.avoidance.arc import STEP_S, Motion, Rollout, accel_limited_step, clearance
from companion.core.avoidance.seen_space import SeenSpace

EVADE_SPEED_FRACTIONS = (1.0, 0.5)
GENTLE_FRACTION = 0.25     # with avoidance.speed_limit: braking away from a threat (speed_limit.py)


def fly_strafe(start_ne_m: np.ndarray, motion: Motion, headings_rad: np.ndarray,
               speeds_mps: np.ndarray, horizon_s: float) -> Rollout:
    """Roll J velocity setpoints (headings (J,), speeds (J,)) forward ``horizon_s``, then brake to
    rest, as truth.step_copter flies a setpoint that does not follow the nose: each step the
    velocity moves toward the setpoint by at most max_accel * STEP_S, as a vector. positions
    (J, N, 2), speeds (J, N); the same time steps as arc.fly_out."""
    headings = np.asarray(headings_rad, dtype=float)
    commanded = np.asarray(speeds_mps, dtype=float)
    j = len(headings)
    max_dv = motion.max_accel_mps2 * STEP_S
    top = max(float(commanded.max(initial=0.0)), motion.speed_mps)
    cruise_steps = int(math.ceil(horizon_s / STEP_S))
    steps = cruise_steps + int(math.ceil(top / max(max_dv, 1e-9)))
    target_n, target_e = commanded * np.cos(headings), commanded * np.sin(headings)
    vel_n = np.full(j, motion.speed_mps * math.cos(motion.course_rad))
    vel_e = np.full(j, motion.speed_mps * math.sin(motion.course_rad))
    north, east = np.full(j, float(start_ne_m[0])), np.full(j, float(start_ne_m[1]))
    positions = np.empty((j, steps, 2))
    speeds = np.empty((j, steps))
    for k in range(steps):
        if k < cruise_steps:
            dv_n, dv_e = target_n - vel_n, target_e - vel_e
        else:
            dv_n, dv_e = -vel_n, -vel_e
        north, east, vel_n, vel_e = accel_limited_step(north, east, vel_n, vel_e, dv_n, dv_e,
                                                       max_dv, positions, speeds, k)
    return Rollout(STEP_S * np.arange(1, steps + 1), positions, speeds)


def evasion_margins(position: np.ndarray, motion: Motion, headings: np.ndarray,
                    speeds: np.ndarray, horizon_s: float, obstacles: np.ndarray,
                    radii: np.ndarray, velocities: np.ndarray | None,
                    growth_mps: np.ndarray | None, seen: SeenSpace | None,
                    safety_distance_m: float, seen_horizon_s: float | None = None) -> np.ndarray:
    """(J,) each evasion's worst margin (m): from the obstacles (clearance, movers grown by their
    uncertainty) and, with a seen space, from space never seen (d less the grid's cell, as
    velocity_choice._seen_margin, and less what the vehicle lacks of it already here).

    ``seen_horizon_s``: the space-never-seen check rolls each setpoint out this long (the loop's
    latency), then brakes: what must hold is that the vehicle, re-deciding every period, can
    still stop d short of space never seen (speed_limit.py's rule). None: over ``horizon_s``,
    as the obstacles (stricter: a 5 m/s side-step held copter-3cam.yaml's 6 s reaches beyond a
    side camera's range, and was refused for it while the mover closed)."""
    rolled = fly_strafe(position, motion, headings, speeds, horizon_s)
    margin = clearance(rolled, obstacles, radii, velocities, growth_mps, position)
    if seen is None:
        return margin
    unseen = speed_limit.unseen_margins(
        seen, position,
        lambda fly_s: rolled.positions if fly_s == horizon_s
        else fly_strafe(position, motion, headings, speeds, fly_s).positions,
        horizon_s if seen_horizon_s is None else seen_horizon_s, safety_distance_m - seen.cell_m)
    return np.minimum(margin, unseen)


def evasion_candidates(headings: np.ndarray, cruise_mps: float,
                       gentle: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """(K,) headings and speeds: a stop first, then every heading at each EVADE_SPEED_FRACTIONS
    of cruise; ``gentle`` (avoidance.speed_limit): and at GENTLE_FRACTION of it, a brake with a
    sideways component more than a side-step."""
    fractions = EVADE_SPEED_FRACTIONS + ((GENTLE_FRACTION,) if gentle else ())
    grid_h = np.concatenate([np.zeros(1)] + [headings for _ in fractions])
    grid_v = np.concatenate([np.zeros(1)] + [np.full(len(headings), f * cruise_mps)
                                             for f in fractions])
    return grid_h, grid_v
