"""When and what to publish of the map: the OBSTACLE_DISTANCE scan at ``map_out.rate_hz`` of
vehicle time, from the current estimate (companion/core/perception/sector_map.py does the geometry).

Only a finite pose and finite landmark centres are published (a diverged estimate sends nothing;
ArduPilot then drops the sensor after 500 ms, which is the honest answer). Mapped movers are not
in it: their positions move between scans and ArduPilot keeps each face until it is refreshed.
"""
from __future__ import annotations

import math

import numpy as np

from companion.mavlink import codec
from companion.config.service import MapOutputConfig
from companion.core.perception.sector_map import scan_map

TIME_EPS_S = 1e-6


class MapPublisher:
    def __init__(self, config: MapOutputConfig) -> None:
        self.config = config
        self._last_t_s: float | None = None
        self.published = 0

    def due(self, t_s: float) -> bool:
        rate = self.config.rate_hz
        return rate > 0.0 and (self._last_t_s is None or t_s < self._last_t_s
                               or t_s - self._last_t_s >= 1.0 / rate - TIME_EPS_S)

    def scan(self, t_s: float, pose: np.ndarray, landmarks_ne_m: np.ndarray) -> codec.SectorMap | None:
        """The scan at t_s if one is due and the estimate is finite, else None."""
        if not self.due(t_s):
            return None
        landmarks = np.asarray(landmarks_ne_m, dtype=float).reshape(-1, 2)
        if not (np.all(np.isfinite(pose)) and np.all(np.isfinite(landmarks))):
            return None
        cfg = self.config
        result = scan_map(pose, landmarks, cfg.obstacle_radius_m, cfg.max_distance_m)
        self._last_t_s = t_s
        self.published += 1
        return codec.SectorMap(t_s, tuple(result.distances_m.tolist()),
                               math.degrees(result.increment_rad), cfg.min_distance_m,
                               cfg.max_distance_m)
