"""What the Monte Carlo table scripts share (forest_table.py, forest_heldout.py, speed_table.py):
a row's name ``KIND@SPEED[+suffix]``, its seeds flown one after another through
``simulation.run_once``, and each run scored as ``companion simulate`` scores it (success: the
goal reached with every obstacle's centre at least 0.95 d away, d the row's speed's own)."""
from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Callable, Iterable

import numpy as np

from companion.config.scenario import Scenario
from companion.sim.simulation import run_once


def parse_row(row: str) -> tuple[str, float, str]:
    """``"forest@7"`` -> ("forest", 7.0, ""); ``"gate@5+gaps"`` -> ("gate", 5.0, "gaps")."""
    kind, _, speed = row.partition("@")
    speed, _, suffix = speed.partition("+")
    return kind, float(speed), suffix


@dataclass(frozen=True)
class RowFigures:
    """One row's runs, an entry per seed (in ``seeds`` order), and its wall time."""
    seeds: np.ndarray
    ok: np.ndarray              # success, as simulate scores it
    hit: np.ndarray             # collided
    clear_m: np.ndarray         # closest approach to a centre
    surface_m: np.ndarray       # closest approach to a surface
    path_m: np.ndarray          # path length
    detour_m: np.ndarray        # path length minus the straight line to the goal circle
    late: np.ndarray            # timed out (never declared arrival)
    wall_s: float

    def failed(self) -> str:
        """The failed seeds with their closest centre: "7003 (1.19 m), 7010 (0.62 m, late)"."""
        return ", ".join(f"{self.seeds[i]} ({self.clear_m[i]:.2f} m{', late' if self.late[i] else ''})"
                         for i in np.flatnonzero(~self.ok))


def fly_row(world_of: Callable[[int], Scenario], seeds: Iterable[int],
            safety_distance_m: float) -> RowFigures:
    """Fly ``world_of(seed)`` with ``seed`` for each seed, one after another."""
    start = time.perf_counter()
    seeds = np.array(list(seeds))
    rows = []
    for seed in seeds:
        world = world_of(int(seed))
        s = run_once(world, int(seed)).summary
        goal, begin = world.world.goal, world.world.start
        straight = np.hypot(goal.north_m - begin.north_m, goal.east_m - begin.east_m) - goal.radius_m
        rows.append((s["reached_goal"] and s["min_clearance_m"] >= 0.95 * safety_distance_m,
                     s["collided"], s["min_clearance_m"], s.get("min_surface_clearance_m", np.nan),
                     s["path_length_m"], s["path_length_m"] - straight, not s["arrived"]))
    ok, hit, clear, surface, path, detour, late = map(np.array, zip(*rows))
    return RowFigures(seeds, ok, hit, clear, surface, path, detour, late,
                      time.perf_counter() - start)
