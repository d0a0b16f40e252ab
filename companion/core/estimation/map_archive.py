"""A bounded map: landmarks that can no longer matter leave the filter for a read-only archive.

A 5 km route through a forest passes thousands of trees; kept in the EKF, every one of them costs
O(n) per prediction and O(n^2) per update, for good. A landmark that lies behind the vehicle,
farther than ``behind_m``, and has not been detected for ``unseen_s`` is *marginalised* out of the
filter: for a Gaussian, the marginal of the remaining states is the same mean and covariance with
that landmark's rows and columns deleted, exactly (no approximation, and the pose's mean and
covariance are untouched: what the pose knows from that landmark it keeps). Only the link
between that landmark and the rest is lost, so seeing it again cannot close a loop.

Its last mean and marginal 2x2 covariance go to a read-only archive kept for the map output and
the view. Seeing an archived landmark again (the vehicle turned back) makes a fresh landmark from
the new sighting, as any new landmark; the archived entry it matches is then dropped
(``reacquired``), so the map never holds one tree twice. The archived estimate is not put back
into the filter: without its cross-covariances (deleted) it would claim a certainty about the
pose it no longer has, and the filter would turn overconfident.

Pure numpy; positions north/east metres, times in seconds of the navigator's clock.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class ArchiveParams:
    """``behind_m``: archive only landmarks behind the vehicle (outside the half plane ahead of
    its heading) and farther than this; ``unseen_s``: ... and not detected for this long.
    ``match_nis``: a new landmark within this NIS (2 dof, on the sum of both covariances) of an
    archived one is the same landmark seen again."""
    behind_m: float
    unseen_s: float = 10.0
    match_nis: float = 13.8               # chi-square 2 dof, 0.999

    def __post_init__(self) -> None:
        if not (math.isfinite(self.behind_m) and self.behind_m > 0.0):
            raise ValueError(f"archive: behind_m must be a distance > 0 m, got {self.behind_m!r}")
        if not (math.isfinite(self.unseen_s) and self.unseen_s > 0.0):
            raise ValueError(f"archive: unseen_s must be a duration > 0 s, got {self.unseen_s!r}")
        if not self.match_nis > 0.0:
            raise ValueError(f"archive: match_nis must be > 0, got {self.match_nis!r}")


@dataclass(frozen=True)
class ArchivedLandmark:
    """One landmark as it left the filter: its key, mean (2,), marginal covariance (2, 2)."""
    key: int
    position_ne_m: tuple[float, float]
    cov_ne_m2: tuple[tuple[float, float], tuple[float, float]]
    last_seen_s: float
    archived_s: float


def stale(pose: np.ndarray, points: np.ndarray, last_seen_s: np.ndarray, t_s: float,
          params: ArchiveParams) -> np.ndarray:
    """Which landmarks can no longer matter: (n,) bool for ``points`` (n, 2) last detected at
    ``last_seen_s`` (n,), seen from ``pose`` [north_m, east_m, yaw_rad] at ``t_s``. Behind (the
    offset's component along the heading negative), farther than behind_m, unseen for unseen_s."""
    if len(points) == 0:
        return np.zeros(0, dtype=bool)
    offset = points - pose[:2]
    along = offset[:, 0] * math.cos(pose[2]) + offset[:, 1] * math.sin(pose[2])
    far = np.hypot(offset[:, 0], offset[:, 1]) > params.behind_m
    return (along < 0.0) & far & (t_s - last_seen_s > params.unseen_s)


GRID_CELL_M = 10.0        # the archive's spatial hash: square cells of this side


class MapArchive:
    """The landmarks marginalised out of the filter, by key; read-only to everyone else.

    Matching a new landmark against the archive (``reacquire``) looks only at the entries in the
    cells of a spatial hash (GRID_CELL_M squares) that a match can lie in: a gap g between the two
    means has NIS >= |g|^2 / lambda_max(both covariances summed) >= |g|^2 / (lambda_max(new) +
    the largest lambda_max ever archived), so every entry within the gate lies within
    sqrt(match_nis x that) of the new landmark. The answer is the brute force's over the whole
    archive (the same NIS, the first of equal ones in archiving order), at a cost that does not
    grow with the route (``reacquire_brute`` is that brute force, for the tests)."""

    def __init__(self, params: ArchiveParams, cell_m: float = GRID_CELL_M) -> None:
        self.params = params
        self.cell_m = float(cell_m)
        self._entries: dict[int, ArchivedLandmark] = {}
        self._cells: dict[tuple[int, int], dict[int, int]] = {}  # cell -> {key: archiving order}
        self._order = 0
        self._max_var_m2 = 0.0          # the largest lambda_max of an archived covariance, ever
        self.counts = {"archived": 0, "reacquired": 0}

    def __len__(self) -> int:
        return len(self._entries)

    def __contains__(self, key: int) -> bool:
        return key in self._entries

    def entries(self) -> tuple[ArchivedLandmark, ...]:
        return tuple(self._entries.values())

    def points(self) -> np.ndarray:
        """Archived means, (k, 2)."""
        return np.array([e.position_ne_m for e in self._entries.values()], dtype=float).reshape(-1, 2)

    def covs(self) -> np.ndarray:
        """Archived marginal covariances, (k, 2, 2)."""
        return np.array([e.cov_ne_m2 for e in self._entries.values()], dtype=float).reshape(-1, 2, 2)

    def _cell(self, north_m: float, east_m: float) -> tuple[int, int]:
        return (math.floor(north_m / self.cell_m), math.floor(east_m / self.cell_m))

    def add(self, key: int, position: np.ndarray, cov: np.ndarray, last_seen_s: float,
            t_s: float) -> None:
        if key in self._entries:
            self._remove(key)
        entry = ArchivedLandmark(
            key, (float(position[0]), float(position[1])),
            ((float(cov[0, 0]), float(cov[0, 1])), (float(cov[1, 0]), float(cov[1, 1]))),
            float(last_seen_s), float(t_s))
        self._entries[key] = entry
        self._cells.setdefault(self._cell(*entry.position_ne_m), {})[key] = self._order
        self._order += 1
        self._max_var_m2 = max(self._max_var_m2, _largest_var(np.array(entry.cov_ne_m2)))
        self.counts["archived"] += 1

    def _remove(self, key: int) -> None:
        entry = self._entries.pop(key)
        cell = self._cell(*entry.position_ne_m)
        members = self._cells[cell]
        del members[key]
        if not members:
            del self._cells[cell]

    def _candidates(self, position: np.ndarray, cov: np.ndarray) -> list[int]:
        """The keys of every entry a match can be, in archiving order (a superset: see the class
        docstring); all of them when the search would visit more cells than there are."""
        reach = math.sqrt(self.params.match_nis * (_largest_var(cov) + self._max_var_m2))
        lo = self._cell(position[0] - reach, position[1] - reach)
        hi = self._cell(position[0] + reach, position[1] + reach)
        if not (math.isfinite(reach)) or (hi[0] - lo[0] + 1) * (hi[1] - lo[1] + 1) > len(self._cells):
            return list(self._entries)
        found: list[tuple[int, int]] = []
        for i in range(lo[0], hi[0] + 1):
            for j in range(lo[1], hi[1] + 1):
                members = self._cells.get((i, j))
                if members:
                    found.extend((order, key) for key, order in members.items())
        found.sort()
        return [key for _, key in found]

    def reacquire(self, key: int, position: np.ndarray, cov: np.ndarray) -> int | None:
        """A new landmark ``key`` at ``position`` (2,) with covariance ``cov`` (2, 2): drop the
        archived entry it is (the same key, or else the nearest by NIS within match_nis); its key
        or None."""
        match = key if key in self._entries else None
        if match is None and self._entries:
            match = self._nearest(self._candidates(position, cov), position, cov)
        return self._drop(match)

    def reacquire_brute(self, key: int, position: np.ndarray, cov: np.ndarray) -> int | None:
        """reacquire over the whole archive (no hash): what the hash must answer."""
        match = key if key in self._entries else None
        if match is None and self._entries:
            match = self._nearest(list(self._entries), position, cov)
        return self._drop(match)

    def _drop(self, match: int | None) -> int | None:
        if match is not None:
            self._remove(match)
            self.counts["reacquired"] += 1
        return match

    def _nearest(self, keys: list[int], position: np.ndarray, cov: np.ndarray) -> int | None:
        """Of ``keys``, the entry of least NIS if within match_nis (the first of equal ones)."""
        if not keys:
            return None
        entries = [self._entries[k] for k in keys]
        gaps = np.array([e.position_ne_m for e in entries], dtype=float) - position
        total = np.array([e.cov_ne_m2 for e in entries], dtype=float) + cov
        det = total[:, 0, 0] * total[:, 1, 1] - total[:, 0, 1] * total[:, 1, 0]
        nis = (total[:, 1, 1] * gaps[:, 0] ** 2 - 2.0 * total[:, 0, 1] * gaps[:, 0] * gaps[:, 1]
               + total[:, 0, 0] * gaps[:, 1] ** 2) / np.maximum(det, 1e-300)
        best = int(np.argmin(nis))
        return keys[best] if nis[best] <= self.params.match_nis else None


def _largest_var(cov: np.ndarray) -> float:
    """lambda_max of a 2x2 covariance (symmetrised), m^2."""
    a, b, c = float(cov[0, 0]), 0.5 * float(cov[0, 1] + cov[1, 0]), float(cov[1, 1])
    return 0.5 * (a + c) + math.sqrt(0.25 * (a - c) ** 2 + b * b)
