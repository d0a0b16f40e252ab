"""The obstacle view: what the decision sees of the estimate.

The map's landmarks (tentative ones left out unless configured), the mover tracks after them,
the landmarks on probation whose sightings already show motion flown round as movers, each row's
stable name, and its vertical extent for the 3D plans. ``guidance_keys`` names the landmark rows
of the last ``obstacles()``.
"""
from __future__ import annotations

import numpy as np

from companion.core.avoidance import vertical as vertical3d
from companion.core.avoidance.arc import Motion
from companion.core.avoidance.union import UnionParams
from companion.core.estimation.estimator import Estimator
from companion.core.estimation.landmark_manager import LandmarkManager
from companion.core.estimation.movers import mover_spread
from companion.core.estimation.probation import MoverProbation

SPREAD_MIN_UPDATES = 5         # a track's position sigma widens its safety distance once this
                               # many sightings confirm it (one second in view at 5 Hz)


class ObstacleView:
    """Guidance's rows: positions, velocities, covariances, and which obstacle each row is."""

    def __init__(self, estimator: Estimator, landmarks: LandmarkManager,
                 probation: MoverProbation, union: UnionParams) -> None:
        self.estimator = estimator
        self.landmarks = landmarks
        self.probation = probation
        self.union = union
        self.guidance_keys: list = []          # landmark key of each landmark row of obstacles()
        self.young_found: dict = {}            # probation.evidence() of this decision, by key
        self.young_movers: list[tuple] = []  # (key, position, velocity) of those flown round
        self.young_spread: np.ndarray | None = None   # their extrapolation's sigma, m (by row)

    def obstacles(self, inflate: bool, young_movers: bool = False
                  ) -> tuple[np.ndarray, np.ndarray | None, np.ndarray | None, list]:
        """Everything guidance must avoid: positions (n,2); velocities (n,2), or None when all
        are static; relative-position covariances (n,2,2), or None when the safety distance is
        not inflated (``inflate``); and the movers, whose rows follow the landmarks'.
        ``young_movers`` (the velocity choice): the landmarks on probation whose sightings
        already show motion (``probation.evidence``) are kept even while tentative, for
        ``young_motion``."""
        slam = self.estimator.slam
        lifecycle = self.landmarks.lifecycle
        landmarks = slam.landmarks()
        rel_covs = slam.relative_covs() if inflate else None
        keys = slam.landmark_ids()
        if young_movers:
            self.young_found = self.probation.evidence()
        if not lifecycle.params.tentative_in_guidance:
            keep = [i for i, key in enumerate(keys) if not lifecycle.is_tentative(key)
                    or (young_movers and key in self.young_found)]
            landmarks, keys = landmarks[keep], [keys[i] for i in keep]
            rel_covs = rel_covs[keep] if rel_covs is not None else None
        self.guidance_keys = keys
        movers = self.probation.movers.states(self.estimator.clock_s)
        if not movers:
            return landmarks, None, rel_covs, movers
        positions = np.vstack([landmarks, [m.position_ne_m for m in movers]])
        velocities = np.vstack([np.zeros_like(landmarks), [m.velocity_ne_mps for m in movers]])
        if inflate:
            pose_cov = slam.pose_cov[:2, :2]
            rel_covs = np.concatenate([rel_covs, [m.position_cov + pose_cov for m in movers]])
        return positions, velocities, rel_covs, movers

    def young_motion(self, obstacles: np.ndarray, velocities: np.ndarray | None,
                     growth: np.ndarray | None) -> tuple[np.ndarray, np.ndarray | None,
                                                         np.ndarray | None]:
        """Guidance's view of the landmarks still on probation: one whose sightings so far
        already show motion (``probation.evidence``, before its min_span_s) is flown around as a
        mover at its apparent velocity, its radius growing by that velocity's uncertainty,
        while the map keeps it as a landmark until it is judged. A crossing mover in view for
        half a second, then out of it, stays in the decision where it goes, not where it was
        seen. (The velocity choice only: rows as ``obstacles()``'s, just before.)"""
        found = [(row, *self.young_found[key]) for row, key in enumerate(self.guidance_keys)
                 if key in self.young_found]
        self.young_movers = []
        self.young_spread = None
        if not found:
            return obstacles, velocities, growth
        clock_s, mover_sigmas = self.estimator.clock_s, self.union.mover_sigmas
        n = len(obstacles)
        obstacles = np.array(obstacles, dtype=float)
        velocities = np.zeros((n, 2)) if velocities is None else velocities.copy()
        growth = np.zeros(n) if growth is None else growth.copy()
        self.young_spread = np.zeros(n)
        for row, velocity, sigma, mean_t in found:
            # the landmark's static estimate sits near its sightings' mean: move it on from there
            obstacles[row] = obstacles[row] + velocity * (clock_s - mean_t)
            velocities[row] = velocity
            growth[row] = mover_sigmas * sigma
            # ... and that extrapolation is as uncertain as the velocity times its age
            self.young_spread[row] = mover_sigmas * sigma * (clock_s - mean_t)
            self.young_movers.append((self.guidance_keys[row], obstacles[row].copy(), velocity))
        return obstacles, velocities, growth

    def spread(self, movers: list, rows: int, motion: Motion | None) -> np.ndarray | None:
        """(rows,) how far each obstacle may be from its estimate now, for the velocity choice
        (None: nowhere): confirmed tracks' position sigma (movers.mover_spread) and the
        extrapolation of the landmarks on probation flown round as movers (young_motion)."""
        if motion is None:
            return None
        spread = mover_spread(movers, rows, self.union.mover_sigmas, SPREAD_MIN_UPDATES)
        if self.young_spread is None:
            return spread
        return self.young_spread if spread is None else spread + self.young_spread

    def key(self, index: int | None, movers: list) -> tuple | None:
        """A stable name for obstacle row ``index``: landmark ids shift as movers leave the map."""
        if index is None:
            return None
        landmarks = len(self.guidance_keys)
        if index >= landmarks:
            return ("mover", movers[index - landmarks].track_id)
        oid = self.guidance_keys[index]
        return ("landmark", oid if oid is not None else index)

    def drop_rows(self, skip: frozenset, obstacles: np.ndarray, velocities=None, rel_covs=None,
                  *per_row):
        """The guidance arrays without the landmark rows ``skip``; ``guidance_keys`` follows
        (the urgency's key names the rows left). ``per_row``: more (n,) arrays or None."""
        if not skip:
            return obstacles, velocities, rel_covs, per_row
        keep = [i for i in range(len(obstacles)) if i not in skip]
        self.guidance_keys = [k for i, k in enumerate(self.guidance_keys) if i not in skip]
        pick = (lambda a: None if a is None else a[keep])
        return (obstacles[keep], pick(velocities), pick(rel_covs),
                tuple(pick(a) for a in per_row))

    def extent_of(self, key) -> "vertical3d.Extent":
        """Landmark ``key``'s vertical extent as the 3D plans take it."""
        extent = self.landmarks.extents.get(key)
        if extent is None or extent.top_m is None:
            return vertical3d.Extent(None, 0.0, 0.0 if extent is None else extent.bottom_m,
                                     extent is not None and extent.bottom_var_m2 is not None)
        return vertical3d.Extent(extent.top_m, extent.top_sigma_m or 0.0, extent.bottom_m,
                                 extent.bottom_var_m2 is not None)
