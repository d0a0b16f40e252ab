"""Seeded random worlds for Monte Carlo: sparse, dense and moving obstacle fields, traffic,
rows of posts (gate, trap), and walls with buildings among posts (urban).

``random_world(base, kind, seed)`` keeps everything of ``base`` (vehicle, noise, sensor, guidance)
and replaces the world: a leg of 120 to 300 m due north, obstacles scattered in a corridor around
it. The same seed always gives the same world, so strategies can be compared on identical worlds.
"""
from __future__ import annotations

import dataclasses
import functools
import math
from dataclasses import dataclass

import numpy as np

from companion.config.scenario import Scenario
from companion.config.world import Building, Goal, Obstacle, Point, StartPose, Wall, World
from companion.core import shapes
from companion.core.avoidance.arc import stopping_distance_m
from companion.sim.forest_worlds import FOREST_SPECS, forest_world
from companion.sim.simulation import perception_delay_s
from companion.sim.worlds3d import KINDS_3D
from companion.sim.traffic_speeds import SPEED_KINDS, speed_kind_check


@dataclass(frozen=True)
class FieldSpec:
    """How a kind of world is drawn."""
    count: tuple[int, int]                 # obstacles, inclusive range
    radius_m: tuple[float, float]
    min_spacing_m: float                   # centre to centre
    leg_m: tuple[float, float]             # start-goal distance
    corridor_half_width_m: float
    moving_fraction: float = 0.0
    speed_mps: tuple[float, float] = (0.3, 2.0)
    clear_of_ends_m: float = 15.0          # no obstacle this close to the start or the goal (beyond d)


KINDS = {
    "sparse": FieldSpec(count=(3, 8), radius_m=(1.0, 3.0), min_spacing_m=24.0, leg_m=(120.0, 300.0),
                        corridor_half_width_m=25.0),
    "dense": FieldSpec(count=(5, 20), radius_m=(1.0, 3.0), min_spacing_m=12.0, leg_m=(120.0, 300.0),
                       corridor_half_width_m=25.0),
    "moving": FieldSpec(count=(5, 20), radius_m=(1.0, 3.0), min_spacing_m=12.0, leg_m=(120.0, 300.0),
                        corridor_half_width_m=25.0, moving_fraction=0.3),
    # 1500 m legs through 150 to 300 obstacles (issue 13): long enough for dead reckoning to
    # matter; the corridor is wider (200 m) so that the field averages one obstacle per 1000 to 2000 m^2.
    "long": FieldSpec(count=(150, 300), radius_m=(1.0, 3.0), min_spacing_m=12.0,
                      leg_m=(1500.0, 1500.0), corridor_half_width_m=100.0),
}
PLACEMENT_TRIES_PER_OBSTACLE = 100


def start_stopping_m(base: Scenario) -> float:
    """How far a vehicle that starts cruising needs to stop for an obstacle it has just seen:
    the way flown before the obstacle counts (the perception delay: a new landmark stays out
    of the guidance until confirmed), then the braking distance at max_accel_mps2. Posts are
    kept this far (plus d) from the start and the goal, so every flight can begin. At 10 m/s
    with paper.yaml's 2.5 m/s^2 and its 1 s delay (a confirmation window of 5 frames at 5 Hz):
    10 + 20 m (the braking distance alone, 20 m, left posts 30 m ahead of the start that the
    multicopter could neither stop for nor pass at d: dense seeds 5, 36, 39, 59, 68, 74, 80)."""
    return stopping_distance_m(base.vehicle.speed_mps,
                               perception_delay_s(base.estimator_config(), base),
                               base.vehicle.max_accel_mps2)


def random_world(base: Scenario, kind: str, seed: int) -> Scenario:
    """A scenario like ``base`` flying a freshly drawn world of ``kind`` (see WORLD_KINDS)."""
    if kind in TRAFFIC_KINDS:
        return traffic_world(base, kind, seed=seed)
    if kind in SPEED_KINDS:
        return traffic_world(base, *SPEED_KINDS[kind], seed=seed, name=kind)
    if kind in POST_KINDS:
        return POST_KINDS[kind](base, seed)
    if kind not in KINDS:
        raise ValueError(f"unknown world kind {kind!r} (expected one of {', '.join(WORLD_KINDS)})")
    spec = KINDS[kind]
    rng = np.random.default_rng([seed, 0x5EED])     # independent of the run's noise stream
    leg = rng.uniform(*spec.leg_m)
    d = base.safety_distance_m
    keep_out = d + max(spec.clear_of_ends_m, start_stopping_m(base))
    wanted = int(rng.integers(spec.count[0], spec.count[1] + 1))
    centres: list[np.ndarray] = []
    for _ in range(max(2000, PLACEMENT_TRIES_PER_OBSTACLE * wanted)):
        if len(centres) == wanted:
            break
        c = np.array([rng.uniform(0.0, leg), rng.uniform(-1.0, 1.0) * spec.corridor_half_width_m])
        if np.hypot(*c) < keep_out or np.hypot(c[0] - leg, c[1]) < keep_out:
            continue
        if any(np.hypot(*(c - o)) < spec.min_spacing_m for o in centres):
            continue
        centres.append(c)
    obstacles = []
    for i, c in enumerate(centres):
        vel = (0.0, 0.0)
        if rng.random() < spec.moving_fraction:
            speed, heading = rng.uniform(*spec.speed_mps), rng.uniform(-math.pi, math.pi)
            vel = (speed * math.cos(heading), speed * math.sin(heading))
        obstacles.append(Obstacle(id=i + 1, north_m=float(c[0]), east_m=float(c[1]),
                                  radius_m=float(rng.uniform(*spec.radius_m)),
                                  vel_north_mps=vel[0], vel_east_mps=vel[1]))
    world = World(start=StartPose(0.0, 0.0, 0.0), goal=Goal(float(leg), 0.0, base.world.goal.radius_m),
                  obstacles=tuple(obstacles), origin=base.world.origin)
    # Long legs and detours need time: allow three times the straight-line flight.
    max_time = max(base.mission.max_time_s, 3.0 * leg / base.vehicle.speed_mps)
    mission = dataclasses.replace(base.mission, max_time_s=max_time)
    avoidance = dataclasses.replace(base.avoidance, mission_time_s=max_time)
    return dataclasses.replace(base, name=f"{kind}-{seed}", world=world, mission=mission,
                               avoidance=avoidance)


# Movers at 3 to 5 m/s timed to meet the vehicle (issue 16): among a sparse static field,
# head-on (along the leg toward the start), crossing (across it, 10 to 40 degrees from square toward
# the vehicle) or overtaken (along the leg, slower than the vehicle).
TRAFFIC_KINDS = {
    "traffic": ("head-on", "crossing", "crossing"),
    "head-on": ("head-on", "head-on"),
    "crossing": ("crossing", "crossing", "crossing"),
    "overtaking": ("overtaking", "overtaking"),
}
TRAFFIC_SPEED_MPS = (3.0, 5.0)


def traffic_world(base: Scenario, kind: str, mover_speed_mps: float | None = None, *,
                  seed: int, name: str | None = None) -> Scenario:
    """A sparse world of ``base`` (same seed) plus the movers of ``kind``, each placed so that it
    would meet the vehicle flying straight at cruise speed: the worst case, not a chance one.
    ``mover_speed_mps``: every mover at this speed (traffic_speeds.py), the rest drawn alike."""
    if mover_speed_mps is not None:
        speed_kind_check(kind, mover_speed_mps, base.vehicle.speed_mps)
    world = random_world(base, "sparse", seed)
    rng = np.random.default_rng([seed, 0x7AFF1C])
    leg = world.world.goal.north_m
    speed = base.vehicle.speed_mps
    movers = []
    next_id = len(world.world.obstacles) + 1
    for pattern in TRAFFIC_KINDS[kind]:
        mover_speed = rng.uniform(*TRAFFIC_SPEED_MPS)     # drawn always: the same stream
        if mover_speed_mps is not None:
            mover_speed = mover_speed_mps
        meet_north = rng.uniform(0.3, 0.8) * leg
        meet_t = meet_north / speed
        if pattern == "head-on":
            heading = math.pi + rng.uniform(-0.1, 0.1)
        elif pattern == "crossing":
            # 10 to 40 degrees from square, toward the vehicle: the camera can see it coming
            # (one that gains on the vehicle from behind the camera's view never can)
            heading = rng.choice([-1.0, 1.0]) * (0.5 * math.pi + rng.uniform(math.radians(10.0), math.radians(40.0)))
        else:                                    # overtaken: slower, same way, just ahead
            mover_speed = min(mover_speed, 0.6 * speed)
            heading = rng.uniform(-0.1, 0.1)
        vel = mover_speed * np.array([math.cos(heading), math.sin(heading)])
        start = np.array([meet_north, rng.uniform(-3.0, 3.0)]) - vel * meet_t
        movers.append(Obstacle(id=next_id, north_m=float(start[0]), east_m=float(start[1]),
                               radius_m=float(rng.uniform(1.0, 2.0)),
                               vel_north_mps=float(vel[0]), vel_east_mps=float(vel[1])))
        next_id += 1
    # a mover's circle may not start over the vehicle: the flight could not begin
    d = base.safety_distance_m
    movers = [m for m in movers if math.hypot(m.north_m, m.east_m) > 2.0 * d]
    new_world = dataclasses.replace(world.world, obstacles=world.world.obstacles + tuple(movers))
    return dataclasses.replace(world, name=f"{name or kind}-{seed}", world=new_world)


POST_SPACING_M = 4.0          # walls are rows of posts (circles) this far apart, 1 m radius
POST_RADIUS_M = 1.0


def _posts(a: np.ndarray, b: np.ndarray) -> list[np.ndarray]:
    """Post centres from a to b (inclusive), POST_SPACING_M apart."""
    n = max(1, int(round(float(np.hypot(*(b - a))) / POST_SPACING_M)))
    return [a + (b - a) * k / n for k in range(n + 1)]


def _post_world(base: Scenario, name: str, leg: float, centres: list[np.ndarray]) -> Scenario:
    obstacles = tuple(Obstacle(id=i + 1, north_m=float(c[0]), east_m=float(c[1]),
                               radius_m=POST_RADIUS_M) for i, c in enumerate(centres))
    world = World(start=StartPose(0.0, 0.0, 0.0), goal=Goal(float(leg), 0.0, base.world.goal.radius_m),
                  obstacles=obstacles, origin=base.world.origin)
    max_time = max(base.mission.max_time_s, 4.0 * leg / base.vehicle.speed_mps)
    mission = dataclasses.replace(base.mission, max_time_s=max_time)
    avoidance = dataclasses.replace(base.avoidance, mission_time_s=max_time)
    return dataclasses.replace(base, name=name, world=world, mission=mission, avoidance=avoidance)


def gate_world(base: Scenario, seed: int, margin_m: float | None = None) -> Scenario:
    """A 160 m wall of posts across a 200 m leg with one gate whose safety circles leave 2 to 4 m
    (centre to centre 2 d + 2 to 4 m, or 2 d + ``margin_m``), 0 to 20 m off the straight line."""
    rng = np.random.default_rng([seed, 0x6A7E])
    d = base.safety_distance_m
    leg, wall_north = 200.0, 100.0
    width = 2.0 * d + rng.uniform(2.0, 4.0)
    if margin_m is not None:
        width = 2.0 * d + margin_m
    centre = rng.uniform(-20.0, 20.0)
    left = _posts(np.array([wall_north, -80.0]), np.array([wall_north, centre - width / 2]))
    right = _posts(np.array([wall_north, centre + width / 2]), np.array([wall_north, 80.0]))
    return _post_world(base, f"gate-{seed}", leg, left + right)


def trap_world(base: Scenario, seed: int) -> Scenario:
    """A U of posts opening toward the start, across the straight line: 30 to 40 m wide inside,
    20 to 30 m deep; the way round is outside it."""
    rng = np.random.default_rng([seed, 0x7A1F])
    leg = 200.0
    half = rng.uniform(15.0, 20.0)
    depth = rng.uniform(20.0, 30.0)
    back = rng.uniform(90.0, 110.0)
    offset = rng.uniform(-5.0, 5.0)
    corners = [np.array([back - depth, offset - half]), np.array([back, offset - half]),
               np.array([back, offset + half]), np.array([back - depth, offset + half])]
    centres = _posts(corners[0], corners[1]) + _posts(corners[1], corners[2])[1:] \
        + _posts(corners[2], corners[3])[1:]
    return _post_world(base, f"trap-{seed}", leg, centres)


# Walls and buildings among posts (issue 15): 1 to 3 walls 10 to 30 m long (0.2 to 1 m thick, any
# direction), 1 to 3 buildings (4 to 6 corners on an ellipse of 4 to 10 m semi-axes: always
# convex), 3 to 10 posts as in the dense worlds, in the dense worlds' corridor. Every two shapes
# (walls, buildings, and a post from a shape) leave URBAN_GAP_M between their surfaces, more than
# two safety circles, so no pair closes a gap; posts keep the dense spacing among themselves.
URBAN_LEG_M = (150.0, 300.0)
URBAN_CORRIDOR_HALF_WIDTH_M = 25.0
URBAN_GAP_EXTRA_M = 4.0
URBAN_TRIES = 2000


def _outline_gap_m(a: np.ndarray, b: np.ndarray) -> float:
    """Surface-to-surface distance of two convex outlines (their edges sampled every 0.25 m)."""
    return min(float(shapes.polygon_distance_m(_edge_points(a), b).min()),
               float(shapes.polygon_distance_m(_edge_points(b), a).min()))


def _edge_points(corners: np.ndarray, step_m: float = 0.25) -> np.ndarray:
    points = []
    for p, q in zip(corners, np.roll(corners, -1, axis=0)):
        n = max(1, int(np.ceil(np.hypot(*(q - p)) / step_m)))
        points.extend(p + (q - p) * k / n for k in range(n))
    return np.array(points)


def _random_building(rng: np.random.Generator, centre: np.ndarray) -> np.ndarray:
    semi = rng.uniform(4.0, 10.0, 2)
    angles = np.sort(rng.uniform(0.0, 2.0 * math.pi, int(rng.integers(4, 7))))
    while np.max(np.diff(np.concatenate([angles, angles[:1] + 2.0 * math.pi]))) > 0.75 * math.pi:
        angles = np.sort(rng.uniform(0.0, 2.0 * math.pi, len(angles)))   # no sliver of a footprint
    turn = rng.uniform(0.0, math.pi)
    rot = np.array([[math.cos(turn), -math.sin(turn)], [math.sin(turn), math.cos(turn)]])
    points = np.column_stack((semi[0] * np.cos(angles), semi[1] * np.sin(angles))) @ rot.T
    return shapes.as_counter_clockwise(points + centre)


def urban_world(base: Scenario, seed: int) -> Scenario:
    """Walls, buildings and posts on a 150 to 300 m leg (see URBAN_LEG_M); needs a depth camera
    (sensor.form sectors or both), as the scenario itself checks."""
    rng = np.random.default_rng([seed, 0x0B1D])
    leg = float(rng.uniform(*URBAN_LEG_M))
    d = base.safety_distance_m
    keep_out = d + max(15.0, start_stopping_m(base))
    gap = 2.0 * d + URBAN_GAP_EXTRA_M
    ends = np.array([[0.0, 0.0], [leg, 0.0]])
    outlines: list[np.ndarray] = []
    walls, buildings, posts = [], [], []
    want = {"wall": int(rng.integers(1, 4)), "building": int(rng.integers(1, 4)),
            "post": int(rng.integers(3, 11))}
    for kind in ("wall", "building", "post"):
        placed = 0
        for _ in range(URBAN_TRIES):
            if placed == want[kind]:
                break
            centre = np.array([rng.uniform(0.0, leg),
                               rng.uniform(-1.0, 1.0) * URBAN_CORRIDOR_HALF_WIDTH_M])
            if kind == "wall":
                length, heading = rng.uniform(10.0, 30.0), rng.uniform(0.0, math.pi)
                half = 0.5 * length * np.array([math.cos(heading), math.sin(heading)])
                thickness = float(rng.uniform(0.2, 1.0))
                outline = shapes.wall_corners(centre - half, centre + half, thickness)
            elif kind == "building":
                outline = _random_building(rng, centre)
            else:
                radius = float(rng.uniform(1.0, 3.0))
                outline = None
            if outline is not None:
                if shapes.polygon_distance_m(ends, outline).min() < keep_out:
                    continue
                if any(_outline_gap_m(outline, o) < gap for o in outlines):
                    continue
                if any(float(shapes.polygon_distance_m(p[:2], outline)[0]) - p[2] < gap
                       for p in posts):
                    continue
            else:
                if np.hypot(*(ends - centre).T).min() - radius < keep_out:
                    continue
                if any(float(shapes.polygon_distance_m(centre, o)[0]) - radius < gap
                       for o in outlines):
                    continue
                if any(np.hypot(*(centre - p[:2])) < KINDS["dense"].min_spacing_m for p in posts):
                    continue
            placed += 1
            if kind == "wall":
                outlines.append(outline)
                walls.append((centre - half, centre + half, thickness))
            elif kind == "building":
                outlines.append(outline)
                buildings.append(outline)
            else:
                posts.append(np.array([centre[0], centre[1], radius]))
    ids = iter(range(1, 1000))
    world = World(
        start=StartPose(0.0, 0.0, 0.0), goal=Goal(leg, 0.0, base.world.goal.radius_m),
        obstacles=tuple(Obstacle(next(ids), float(p[0]), float(p[1]), float(p[2])) for p in posts),
        origin=base.world.origin,
        walls=tuple(Wall(next(ids), Point(float(a[0]), float(a[1])), Point(float(b[0]), float(b[1])),
                         t) for a, b, t in walls),
        buildings=tuple(Building(next(ids), tuple(Point(float(c[0]), float(c[1])) for c in o))
                        for o in buildings))
    max_time = max(base.mission.max_time_s, 3.0 * leg / base.vehicle.speed_mps)
    mission = dataclasses.replace(base.mission, max_time_s=max_time)
    avoidance = dataclasses.replace(base.avoidance, mission_time_s=max_time)
    return dataclasses.replace(base, name=f"urban-{seed}", world=world, mission=mission,
                               avoidance=avoidance)


POST_KINDS = {"gate": gate_world, "trap": trap_world, "urban": urban_world,
              **{kind: functools.partial(forest_world, kind=kind) for kind in FOREST_SPECS},
              **KINDS_3D}              # lowwalls, mixed: worlds3d.py
WORLD_KINDS = tuple(KINDS) + tuple(TRAFFIC_KINDS) + tuple(POST_KINDS) + tuple(SPEED_KINDS)
