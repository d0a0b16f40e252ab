"""Seeded random worlds with heights (issue 27): ``lowwalls`` and ``mixed``.

Walls and buildings here are made of posts (circles of the centres camera, as the gate world's
walls are), each post carrying the wall's or building's height: the default scenario base
(paper.yaml, a camera reporting centres) flies them, and the vertical avoidance needs the centres
form (the depth sectors carry no z yet).

These kinds turn ``avoidance.vertical`` on unless the base says otherwise (``vertical: false``,
or ``companion simulate --vertical off``): a world of heights is what it is for; the same worlds
flown with the 2D law are the comparison.
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np

from companion.config.scenario import Scenario
from companion.config.world import Goal, Obstacle, StartPose, World
from companion.core.avoidance.arc import stopping_distance_m
from companion.sim.simulation import perception_delay_s

POST_SPACING_M = 4.0
POST_RADIUS_M = 1.0
LOWWALL_LEG_M = (180.0, 300.0)
LOWWALL_HEIGHT_M = (2.0, 6.0)
LOWWALL_LENGTH_M = (50.0, 80.0)       # across the 50 m corridor: flying round costs 25 to 50 m aside
LOWWALL_SPACING_M = 50.0              # between walls, along the leg
TOWER_HEIGHT_M = 40.0
TOWER_RADIUS_M = (1.5, 3.0)
MIXED_LEG_M = (150.0, 300.0)
MIXED_CORRIDOR_HALF_WIDTH_M = 25.0
MIXED_POST_HEIGHT_M = (1.0, 40.0)
MIXED_BUILDING_HEIGHT_M = (3.0, 25.0)
TRIES = 2000


def _keep_out_m(base: Scenario) -> float:
    """As the other kinds': d beyond the reaction and braking distance (worlds.start_stopping_m,
    written out here: worlds.py imports this module to register its kinds)."""
    stopping = stopping_distance_m(base.vehicle.speed_mps,
                                   perception_delay_s(base.estimator_config(), base),
                                   base.vehicle.max_accel_mps2)
    return base.safety_distance_m + max(15.0, stopping)


def _finish(base: Scenario, name: str, leg: float, obstacles: list[Obstacle]) -> Scenario:
    world = World(start=StartPose(0.0, 0.0, 0.0, base.world.start.alt_m),
                  goal=Goal(float(leg), 0.0, base.world.goal.radius_m),
                  obstacles=tuple(obstacles), origin=base.world.origin)
    max_time = max(base.mission.max_time_s, 3.0 * leg / base.vehicle.speed_mps)
    mission = dataclasses.replace(base.mission, max_time_s=max_time)
    vertical = True if base.avoidance.vertical is None else base.avoidance.vertical
    avoidance = dataclasses.replace(base.avoidance, mission_time_s=max_time, vertical=vertical)
    return dataclasses.replace(base, name=name, world=world, mission=mission, avoidance=avoidance)


def _row(a: np.ndarray, b: np.ndarray) -> list[np.ndarray]:
    n = max(1, int(round(float(np.hypot(*(b - a))) / POST_SPACING_M)))
    return [a + (b - a) * k / n for k in range(n + 1)]


def lowwalls_world(base: Scenario, seed: int) -> Scenario:
    """Two or three walls 2 to 6 m high of posts (one height each) across the corridor, 50 to
    80 m long, at least LOWWALL_SPACING_M apart along a 180 to 300 m leg, and one to four 40 m
    towers between them, each two safety circles (plus 4 m) clear of every wall post and of one
    another: the way round a tower is open, the way round a wall long."""
    rng = np.random.default_rng([seed, 0x10A11])
    leg = float(rng.uniform(*LOWWALL_LEG_M))
    d = base.safety_distance_m
    keep_out = _keep_out_m(base)
    first, last = keep_out + 10.0, leg - keep_out - 10.0
    walls: list[float] = []
    want_walls = int(rng.integers(2, 4))
    for _ in range(TRIES):
        if len(walls) == want_walls:
            break
        north = float(rng.uniform(first, last))
        if all(abs(north - w) >= LOWWALL_SPACING_M for w in walls):
            walls.append(north)
    obstacles: list[Obstacle] = []
    ids = iter(range(1, 60000))
    for north in sorted(walls):
        length = float(rng.uniform(*LOWWALL_LENGTH_M))
        centre = float(rng.uniform(-10.0, 10.0))
        tilt = float(rng.uniform(-0.2, 0.2))           # not quite square to the leg
        half = 0.5 * length * np.array([math.sin(tilt), math.cos(tilt)])
        height = float(rng.uniform(*LOWWALL_HEIGHT_M))
        for c in _row(np.array([north, centre]) - half, np.array([north, centre]) + half):
            obstacles.append(Obstacle(next(ids), float(c[0]), float(c[1]), POST_RADIUS_M,
                                      height_m=height))
    towers = 0
    want = int(rng.integers(1, 5))
    for _ in range(TRIES):
        if towers == want:
            break
        c = np.array([rng.uniform(first, last), rng.uniform(-25.0, 25.0)])
        radius = float(rng.uniform(*TOWER_RADIUS_M))
        if any(math.hypot(c[0] - o.north_m, c[1] - o.east_m) - radius - o.radius_m < 2.0 * d + 4.0
               for o in obstacles):
            continue
        obstacles.append(Obstacle(next(ids), float(c[0]), float(c[1]), radius,
                                  height_m=TOWER_HEIGHT_M))
        towers += 1
    return _finish(base, f"lowwalls-{seed}", leg, obstacles)


def mixed_world(base: Scenario, seed: int) -> Scenario:
    """Posts of random heights (1 to 40 m, 1 to 3 m radius, 5 to 12 of them) and one to three
    buildings (a block of 2x2 to 3x3 posts 4 m apart, one height of 3 to 25 m) in a 50 m corridor
    on a 150 to 300 m leg; posts 12 m apart (the dense worlds'), a building two safety circles
    (plus 4 m) clear of anything else."""
    rng = np.random.default_rng([seed, 0x313ED])
    leg = float(rng.uniform(*MIXED_LEG_M))
    d = base.safety_distance_m
    keep_out = _keep_out_m(base)
    ends = np.array([[0.0, 0.0], [leg, 0.0]])
    items: list[tuple[np.ndarray, float]] = []     # (centre, footprint radius) of posts and blocks
    obstacles: list[Obstacle] = []
    ids = iter(range(1, 60000))
    for kind, count in (("building", int(rng.integers(1, 4))), ("post", int(rng.integers(5, 13)))):
        placed = 0
        for _ in range(TRIES):
            if placed == count:
                break
            c = np.array([rng.uniform(0.0, leg), rng.uniform(-1.0, 1.0) * MIXED_CORRIDOR_HALF_WIDTH_M])
            if kind == "building":
                cells = (int(rng.integers(2, 4)), int(rng.integers(2, 4)))
                footprint = 0.5 * POST_SPACING_M * math.hypot(cells[0] - 1, cells[1] - 1) + POST_RADIUS_M
                gap = 2.0 * d + 4.0
            else:
                radius = float(rng.uniform(1.0, 3.0))
                footprint, gap = radius, 12.0
            if np.hypot(*(ends - c).T).min() - footprint < keep_out:
                continue
            if any(float(np.hypot(*(c - o))) - footprint - r < (gap if kind == "post" and r < 4.0
                                                               else 2.0 * d + 4.0)
                   for o, r in items):
                continue
            placed += 1
            items.append((c, footprint))
            if kind == "building":
                height = float(rng.uniform(*MIXED_BUILDING_HEIGHT_M))
                for i in range(cells[0]):
                    for j in range(cells[1]):
                        p = c + POST_SPACING_M * np.array([i - 0.5 * (cells[0] - 1),
                                                           j - 0.5 * (cells[1] - 1)])
                        obstacles.append(Obstacle(next(ids), float(p[0]), float(p[1]),
                                                  POST_RADIUS_M, height_m=height))
            else:
                obstacles.append(Obstacle(next(ids), float(c[0]), float(c[1]), radius,
                                          height_m=float(rng.uniform(*MIXED_POST_HEIGHT_M))))
    return _finish(base, f"mixed-{seed}", leg, obstacles)


KINDS_3D = {"lowwalls": lowwalls_world, "mixed": mixed_world}
