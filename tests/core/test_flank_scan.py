"""The flank scan (core/avoidance/flank_scan.py): a fixed 90 degree camera looks beyond its edges."""
import dataclasses
import math

import numpy as np

from companion.config.scenario import load_scenario
from companion.config.world import Goal, Obstacle, StartPose
from companion.core.avoidance.flank_scan import FlankScan, FlankScanParams
from companion.sim.simulation import run_once


def _crossing_behind(flank_scan_deg):
    """paper.yaml's unicycle flying north from (0, 0) to (200, 0), and one 4.9 m/s mover crossing
    from the right front (moving east, a little toward the vehicle) that passes 6 m behind it at
    t = 10 s: from a straight course it stays 47 to 90 degrees off the nose inside the camera's
    range, just outside the 90 degree view."""
    base = load_scenario("config/scenarios/paper.yaml")
    vel = np.array([-0.8, 4.8])
    rel_vel = vel - np.array([5.0, 0.0])
    behind = -np.array([rel_vel[1], -rel_vel[0]]) / np.hypot(*rel_vel)   # normal, north < 0
    if behind[0] > 0:
        behind = -behind
    at_cpa = np.array([50.0, 0.0]) + 6.0 * behind
    start = at_cpa - 10.0 * vel
    mover = Obstacle(id=1, north_m=float(start[0]), east_m=float(start[1]), radius_m=1.5,
                     vel_north_mps=float(vel[0]), vel_east_mps=float(vel[1]))
    world = dataclasses.replace(base.world, start=StartPose(0.0, 0.0, 0.0),
                                goal=Goal(200.0, 0.0, base.world.goal.radius_m), obstacles=(mover,))
    avoidance = dataclasses.replace(base.avoidance, flank_scan_deg=flank_scan_deg)
    return dataclasses.replace(base, world=world, avoidance=avoidance)


def test_a_mover_just_outside_the_view_is_seen_only_with_the_scan():
    for seed in range(3):
        off = run_once(_crossing_behind(None), seed).summary
        on = run_once(_crossing_behind(20.0), seed).summary
        assert off["landmarks"]["obstacles_seen"] == 0     # never in view: passed at 6 m
        assert off["min_clearance_m"] < 8.0
        assert on["landmarks"]["obstacles_seen"] == 1
        assert on["reached_goal"] and on["min_clearance_m"] >= 9.5      # 11-12 m


def test_each_flank_is_looked_at_in_turn():
    fov = math.radians(90.0)
    scan = FlankScan(FlankScanParams(fov, math.radians(20.0), period_s=4.0, dwell_frames=3))
    yaw, looks = 0.0, []
    for k in range(100):                        # 20 s at 5 Hz, flying the looks at 30 deg/s
        t = 0.2 * k
        scan.mark(t, yaw)
        heading = scan.look(t, 0.0)
        target = 0.0 if heading is None else heading
        yaw += max(-math.radians(6.0), min(math.radians(6.0), target - yaw))
        looks.append(0 if heading is None else int(math.copysign(1, heading)))
    sides = [s for i, s in enumerate(looks) if s and (i == 0 or looks[i - 1] != s)]
    assert set(sides) == {1, -1}
    assert all(a != b for a, b in zip(sides, sides[1:]))       # they alternate
    assert len(sides) >= 5                                     # about one a period each
    assert looks.count(0) > 0.3 * len(looks)                   # and fly the course in between
