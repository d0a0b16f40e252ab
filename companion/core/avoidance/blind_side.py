"""Movers at speed: what a camera rig can see of a mover meeting the vehicle, and how fast the
vehicle may cruise so that a mover it sees can still be dodged (issue 46 item 4; the maths and
the measurements: docs/movers-speed.md).

A mover that meets the vehicle, both flying straight, holds a constant bearing (relative to the
vehicle's course) until they meet: it is seen only if that bearing lies in the rig's view. With
the vehicle at speed v along x and the mover at speed u along course theta (from the vehicle's
course), the mover is seen along -(u - v), so

    tan(beta) = u sin(theta) / (v - u cos(theta))                           (``meeting_bearing_rad``)

Over every course theta the bearing reaches asin(u / v) when u < v, and any bearing at all when
u >= v (``widest_meeting_bearing_rad``). A rig that sees +-H off the course therefore sees every
mover of speed u that can meet the vehicle only if v > u and asin(u / v) <= H, i.e.

    v >= u / sin(H)   (H < 90 deg),   v > u   (H >= 90 deg)               (``seeing_speed_mps``)

With one 90 deg camera (H = 45 deg) and 7 m/s movers that is 9.9 m/s: at 5 m/s a 7 m/s crosser
within 10-15 deg of square is never in view (the 7 collisions of crossing-7), and slowing down
widens the blind bearings instead of closing them. Only coverage closes them: forward and both
side cameras (H = 135 deg) see every meeting of a mover slower than the vehicle, and of faster
ones all but those from behind.

Seeing is not enough: the mover must be seen early enough to dodge it. Seen at the camera's range
R, closing at c = |u - v| (head-on, the worst: u + v), it meets the vehicle R / c later. From
no sideways speed, a vehicle of acceleration a needs the loop's latency t plus sqrt(2 d / a)
to move d aside (accelerating all the way: the bound is a lower one on the time, so the speed
cap it gives is an upper one). So a mover met head-on at up to u is dodged by d from first
sight only if

    u + v <= R / (t + sqrt(2 d / a))                                        (``dodge_speed_cap_mps``)

With R = 40 m, d = 10 m, a = 2.5 m/s^2 and t = 1.0 s (copter.yaml: the perception delay, five
frames at 5 Hz; speed_limit.latency_s): u + v <= 10.4 m/s: 3.4 m/s against 7 m/s movers, 5.4 m/s
against 5 m/s ones. ``avoidance.mover_max_speed_mps`` caps the velocity choice's cruise so.

Pure maths; speeds m/s, angles rad (bearings right positive), distances m, times s.
"""
from __future__ import annotations

import math


def meeting_bearing_rad(vehicle_speed_mps: float, mover_speed_mps: float,
                        mover_course_rad: float) -> float:
    """The constant bearing, off the vehicle's course, at which a mover on course
    ``mover_course_rad`` (relative to the vehicle's) is seen while it comes to meet the vehicle,
    both flying straight. A mover crossing from the right to the left has a course < 0
    (it comes from the right: bearing > 0)."""
    rel_n = mover_speed_mps * math.cos(mover_course_rad) - vehicle_speed_mps
    rel_e = mover_speed_mps * math.sin(mover_course_rad)
    return math.atan2(-rel_e, -rel_n)


def widest_meeting_bearing_rad(vehicle_speed_mps: float, mover_speed_mps: float) -> float:
    """The widest bearing off the course from which a mover of this speed can meet the vehicle:
    asin(u / v) for a slower mover, pi (anywhere, behind included) for one as fast or faster."""
    if mover_speed_mps >= vehicle_speed_mps:
        return math.pi
    return math.asin(mover_speed_mps / vehicle_speed_mps)


def seeing_speed_mps(mover_speed_mps: float, half_view_rad: float) -> float:
    """The slowest vehicle speed at which every mover of up to ``mover_speed_mps`` that can meet
    it comes from within +-``half_view_rad`` of the course; math.inf for a view that leaves
    the rear blind to movers as fast as the vehicle (half view < pi: every such view)."""
    if half_view_rad >= math.pi:
        return 0.0
    if half_view_rad >= 0.5 * math.pi:
        return math.nextafter(mover_speed_mps, math.inf)
    return mover_speed_mps / math.sin(half_view_rad)


def dodge_time_s(safety_distance_m: float, max_accel_mps2: float, latency_s: float) -> float:
    """How long a vehicle with no sideways speed needs to move ``safety_distance_m`` aside:
    the latency, then accelerating sideways all the way (a lower bound on the time)."""
    return latency_s + math.sqrt(2.0 * safety_distance_m / max_accel_mps2)


def dodge_speed_cap_mps(range_m: float, safety_distance_m: float, max_accel_mps2: float,
                        latency_s: float, mover_speed_mps: float) -> float:
    """The fastest cruise from which a mover of ``mover_speed_mps`` met head-on, first seen at
    the camera's range, can be dodged by d: R / dodge_time - u, at least 0."""
    closing = range_m / dodge_time_s(safety_distance_m, max_accel_mps2, latency_s)
    return max(closing - mover_speed_mps, 0.0)
