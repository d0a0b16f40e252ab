"""Seeded forests for Monte Carlo (issue 28): Poisson-disc trees at a stated density.

``forest_world(base, seed, kind)`` keeps everything of ``base`` (vehicle, noise, sensor,
guidance) and replaces the world: a 200 m leg due north through a corridor 60 m wide filled with
trees of 0.1 to 0.4 m radius, drawn by dart throwing (random sequential addition, a Poisson-disc
process): candidates uniform over the corridor, kept if no closer than ``min_spacing_m`` to any
tree already kept, until the wanted count (density x area) is reached. The minimum spacings are
chosen below the process's saturation (about 0.7 / r^2 trees per m^2 at spacing r: 4.2 m at 400
per ha, 2.9 m at 800 per ha) so that the count is always reached:

- ``forest``: 400 trees per ha (one per 25 m^2, about 5 m apart: the mean nearest-neighbour
  distance is printed with each run), at least 3.5 m centre to centre;
- ``forest-dense``: 800 per ha (one per 12.5 m^2), at least 2.5 m centre to centre
  (AvoidBench's trees stand 2.5 to 6 m apart);
- ``forest-near``: as ``forest``, but trees from 8 m of the start at any speed (issue 46: a
  vehicle that starts cruising cannot stop short of them; one that starts at rest,
  ``vehicle.start_at_rest``, as a real flight does after take-off, can).

The start and the goal stand in small clearings: no tree within d + 3 m of either (the vehicle
starts cruising, so at 10 m/s also none within the stopping distance ahead of the start, see
``start_clearing_m``; forest-near's start clearing is 8 m). The run summary prints the drawn
density and spacing (``world_figures``).
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from companion.config.scenario import Scenario
from companion.config.world import Goal, Obstacle, StartPose, World
from companion.core.avoidance.arc import stopping_distance_m
from companion.sim.simulation import perception_delay_s

SQUARE_M_PER_HA = 10_000.0


@dataclass(frozen=True)
class ForestSpec:
    """How a forest is drawn."""
    density_per_ha: float
    min_spacing_m: float                   # centre to centre (the Poisson disc's diameter)
    radius_m: tuple[float, float] = (0.1, 0.4)
    leg_m: float = 200.0
    corridor_half_width_m: float = 30.0    # 60 m wide
    margin_m: float = 10.0                 # trees also this far before the start and past the goal
    clearing_extra_m: float = 3.0          # no tree within d + this of the start or the goal
    start_clearing_m: float | None = None  # no tree this close to the start (None: as
                                           # start_clearing_m below)


FOREST_SPECS = {
    "forest": ForestSpec(density_per_ha=400.0, min_spacing_m=3.5),
    "forest-dense": ForestSpec(density_per_ha=800.0, min_spacing_m=2.5),
    # issue 46: trees from 8 m of the start, whatever the speed; a vehicle that starts cruising
    # at 10 m/s cannot stop short of them, one that starts at rest (vehicle.start_at_rest) can
    "forest-near": ForestSpec(density_per_ha=400.0, min_spacing_m=3.5, start_clearing_m=8.0),
}
MAX_TRIES_PER_TREE = 200


def start_clearing_m(base: Scenario, spec: ForestSpec) -> float:
    """No tree this close to the start: the spec's own clearing, else d + clearing_extra_m, or
    d + the stopping distance of a vehicle that starts cruising (its perception delay, then
    braking), whichever is more."""
    if spec.start_clearing_m is not None:
        return spec.start_clearing_m
    d = base.safety_distance_m
    stop = stopping_distance_m(base.vehicle.speed_mps,
                               perception_delay_s(base.estimator_config(), base),
                               base.vehicle.max_accel_mps2)
    return d + max(spec.clearing_extra_m, stop)


def poisson_disc(rng: np.random.Generator, lo: np.ndarray, hi: np.ndarray, count: int,
                 min_spacing_m: float) -> np.ndarray:
    """Up to ``count`` points uniform in the box [lo, hi] (2,), no two closer than
    ``min_spacing_m`` (dart throwing on a grid of cells of side spacing / sqrt 2, which holds at
    most one point each): (k, 2)."""
    cell = min_spacing_m / math.sqrt(2.0)
    shape = np.ceil((hi - lo) / cell).astype(int) + 1
    grid = -np.ones(shape, dtype=int)
    points: list[np.ndarray] = []
    spacing2 = min_spacing_m * min_spacing_m
    for _ in range(MAX_TRIES_PER_TREE * count):
        if len(points) == count:
            break
        p = lo + rng.random(2) * (hi - lo)
        i, j = ((p - lo) / cell).astype(int)
        near = grid[max(0, i - 2):i + 3, max(0, j - 2):j + 3]
        if any(float(np.sum((points[k] - p) ** 2)) < spacing2 for k in near[near >= 0].tolist()):
            continue
        grid[i, j] = len(points)
        points.append(p)
    return np.array(points).reshape(-1, 2)


def forest_world(base: Scenario, seed: int, kind: str = "forest",
                 spec: ForestSpec | None = None) -> Scenario:
    """A scenario like ``base`` flying a freshly drawn forest of ``kind`` (FOREST_SPECS), or of
    ``spec`` in its place (a variant: depth_forest_quality.py's trunk radii)."""
    spec = FOREST_SPECS[kind] if spec is None else spec
    rng = np.random.default_rng([seed, 0xF0257])       # independent of the run's noise stream
    leg = spec.leg_m
    lo = np.array([-spec.margin_m, -spec.corridor_half_width_m])
    hi = np.array([leg + spec.margin_m, spec.corridor_half_width_m])
    area_m2 = float(np.prod(hi - lo))
    count = int(round(spec.density_per_ha * area_m2 / SQUARE_M_PER_HA))
    trees = poisson_disc(rng, lo, hi, count, spec.min_spacing_m)
    radii = rng.uniform(*spec.radius_m, len(trees))
    d = base.safety_distance_m
    start_gap = np.hypot(trees[:, 0], trees[:, 1])
    goal_gap = np.hypot(trees[:, 0] - leg, trees[:, 1])
    keep = (start_gap > start_clearing_m(base, spec)) & (goal_gap > d + spec.clearing_extra_m)
    obstacles = tuple(Obstacle(id=i + 1, north_m=float(c[0]), east_m=float(c[1]),
                               radius_m=float(r))
                      for i, (c, r) in enumerate(zip(trees[keep], radii[keep])))
    world = World(start=StartPose(0.0, 0.0, 0.0), goal=Goal(float(leg), 0.0, base.world.goal.radius_m),
                  obstacles=obstacles, origin=base.world.origin)
    max_time = max(base.mission.max_time_s, 3.0 * leg / base.vehicle.speed_mps)
    mission = dataclasses.replace(base.mission, max_time_s=max_time)
    avoidance = dataclasses.replace(base.avoidance, mission_time_s=max_time)
    return dataclasses.replace(base, name=f"{kind}-{seed}", world=world, mission=mission,
                               avoidance=avoidance)


def world_figures(worlds: list[Scenario], kind: str) -> dict:
    """The drawn forests' density and spacing, for the run summary: trees per ha over the
    corridor (before the clearings), the mean nearest-neighbour distance and the smallest."""
    spec = FOREST_SPECS[kind]
    area_ha = (spec.leg_m + 2.0 * spec.margin_m) * 2.0 * spec.corridor_half_width_m / SQUARE_M_PER_HA
    nn_mean, nn_min, counts = [], [], []
    for world in worlds:
        centres = np.array([[o.north_m, o.east_m] for o in world.world.obstacles])
        counts.append(len(centres))
        if len(centres) < 2:
            continue
        nearest = np.empty(len(centres))
        for i, c in enumerate(centres):       # O(n^2) in chunks of one row: a summary, not a hot path
            gaps = np.hypot(*(centres - c).T)
            gaps[i] = math.inf
            nearest[i] = gaps.min()
        nn_mean.append(float(nearest.mean()))
        nn_min.append(float(nearest.min()))
    return {"kind": kind, "target_density_per_ha": spec.density_per_ha,
            "min_spacing_m": spec.min_spacing_m, "corridor_width_m": 2.0 * spec.corridor_half_width_m,
            "leg_m": spec.leg_m, "tree_radius_m": list(spec.radius_m),
            "density_per_ha": float(np.mean(counts)) / area_ha if counts else None,
            "mean_nearest_neighbour_m": float(np.mean(nn_mean)) if nn_mean else None,
            "min_nearest_neighbour_m": float(np.min(nn_min)) if nn_min else None}


def lane_forest(base: Scenario, leg_m: float, seed: int, density_per_ha: float = 400.0,
                lane_extra_m: float = 1.5) -> Scenario:
    """A forest like ``forest`` (3.5 m Poisson disc, 60 m wide) along a ``leg_m`` leg due north
    with a straight lane of half-width d + ``lane_extra_m`` kept free of trees along the centre
    line: the flight goes the whole way on the straight line, whatever the guidance does, so a
    long route measures the map (benchmarks/forest_scale.py, the bounded map's NEES test)."""
    spec = FOREST_SPECS["forest"]
    rng = np.random.default_rng([seed, 0x5CA1E])
    lo = np.array([-spec.margin_m, -spec.corridor_half_width_m])
    hi = np.array([leg_m + spec.margin_m, spec.corridor_half_width_m])
    count = int(round(density_per_ha * float(np.prod(hi - lo)) / SQUARE_M_PER_HA))
    trees = poisson_disc(rng, lo, hi, count, spec.min_spacing_m)
    lane = base.safety_distance_m + lane_extra_m
    trees = trees[(np.abs(trees[:, 1]) > lane) & (np.hypot(trees[:, 0], trees[:, 1]) > 10.0)]
    radii = rng.uniform(*spec.radius_m, len(trees))
    world = World(start=StartPose(0.0, 0.0, 0.0), goal=Goal(float(leg_m), 0.0, base.world.goal.radius_m),
                  obstacles=tuple(Obstacle(i + 1, float(c[0]), float(c[1]), float(r))
                                  for i, (c, r) in enumerate(zip(trees, radii))),
                  origin=base.world.origin)
    max_time = max(base.mission.max_time_s, 2.0 * leg_m / base.vehicle.speed_mps)
    return dataclasses.replace(base, name=f"forest-lane-{leg_m:g}m-{seed}", world=world,
                               mission=dataclasses.replace(base.mission, max_time_s=max_time),
                               avoidance=dataclasses.replace(base.avoidance,
                                                             mission_time_s=max_time))
