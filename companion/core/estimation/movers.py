"""Moving obstacles: constant-velocity tracks, kept out of the static SLAM map.

A landmark whose observations disagree grossly with the static map twice in a row (NIS beyond the
outlier gate, so the update is refused and neither map nor pose moves) is declared a mover: it is
marginalised out of the SLAM state and tracked here, in the world frame given the SLAM pose, by a
constant-velocity Kalman filter (filterpy's KalmanFilter: a 4-state filter is small, and its
textbook form is all it needs). Tracks are predicted forward between observations and deleted
after ``coast_s`` without one. A track starts from the evidence that convicted it: at the last
sighting, with the velocity its sightings' fit shows, that fit's standard error, and the last
point's correlation with the slope (``start_evidence``); at rest with initial_speed_sigma_mps only
when the sightings showed no velocity.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from companion.core.geometry import place, place_jacobians

if TYPE_CHECKING:                 # imported at the first track (MoverTracker.create says why)
    from filterpy.kalman import KalmanFilter


@dataclass(frozen=True)
class MoverParams:
    strikes_to_mover: int = 3            # consecutive outliers that demote an old landmark
    accel_sigma_mps2: float = 0.1        # white-acceleration process noise of the CV model
    initial_speed_sigma_mps: float = 2.0
    coast_s: float = 30.0                # delete a track unseen for this long (predicted meanwhile)
    gate_nis: float = 13.8               # chi-square 2 dof, 99.9%: association of id-less reports
    probation_s: float = 3.0             # a new landmark is watched this long for motion
    min_span_s: float = 1.0              # motion is judged over at least this much history
    speed_threshold_mps: float = 0.15    # slower than this counts as static
    speed_sigmas: float = 5.0            # and the speed must exceed this many standard errors
    young_min_sightings: int = 2         # a landmark on probation (tentative or not) whose this
                                         # many sightings already show motion is flown around as a
                                         # mover (MoverProbation.evidence)


@dataclass(frozen=True)
class MoverState:
    """A track's estimate at some time: world position (2,), velocity (2,), position cov (2,2)."""
    track_id: int
    obstacle_id: int | None
    position_ne_m: np.ndarray
    velocity_ne_mps: np.ndarray
    position_cov: np.ndarray
    velocity_cov: np.ndarray | None = None     # (2,2)
    updates: int = 0                           # sightings absorbed since the track began


def mover_growth(movers: list[MoverState], rows: int, sigmas: float) -> np.ndarray | None:
    """(rows,) how fast each obstacle row's safety radius grows with time (m/s): ``sigmas``
    standard deviations of a mover's velocity along its worst axis, 0 for the static rows that
    come first; None without movers. A track out of view keeps growing: its covariance does."""
    if not movers:
        return None
    growth = np.zeros(rows)
    for k, mover in enumerate(movers):
        if mover.velocity_cov is not None:
            worst = float(np.linalg.eigvalsh(0.5 * (mover.velocity_cov + mover.velocity_cov.T))[-1])
            growth[rows - len(movers) + k] = sigmas * math.sqrt(max(worst, 0.0))
    return growth


def mover_spread(movers: list[MoverState], rows: int, sigmas: float,
                 min_updates: int) -> np.ndarray | None:
    """(rows,) how far each obstacle row may be from its estimate now (m): ``sigmas`` standard
    deviations of a mover track's position along its worst axis, for the tracks that
    ``min_updates`` sightings have confirmed; 0 for the others and for the static rows that come
    first; None without such tracks. A track out of view coasts: its position's covariance, and
    so this, grows until it is seen again. A track with fewer sightings gets none: clutter's
    false alarms start tracks that are never seen again, and widening those lengthened routes
    through cluttered worlds."""
    spread = np.zeros(rows)
    for k, mover in enumerate(movers):
        if mover.updates < min_updates:
            continue
        cov = np.asarray(mover.position_cov, dtype=float)
        worst = float(np.linalg.eigvalsh(0.5 * (cov + cov.T))[-1])
        spread[rows - len(movers) + k] = sigmas * math.sqrt(max(worst, 0.0))
    return spread if spread.any() else None


def approaching(track: MoverState, vehicle_ne_m: np.ndarray, vehicle_vel_ne_mps: np.ndarray,
                horizon_s: float, within_m: float, max_spread_m: float = 10.0) -> bool:
    """Whether a track's predicted closest approach to the vehicle comes within ``within_m``
    plus two sigma of its position's spread (at most ``max_spread_m``: the navigator gives the
    guidance's own bound, union.MAX_SPREAD_M) inside ``horizon_s``,
    for the vehicle flying on at its velocity or stopped (it may stop at any time: a mover it
    flew past may still close on it). Whatever the camera's range: a track left behind out of
    view, or beyond the range, is not forgotten while it may still meet the vehicle."""
    gap = np.asarray(track.position_ne_m, dtype=float) - np.asarray(vehicle_ne_m, dtype=float)
    spread = min(2.0 * math.sqrt(max(float(np.linalg.eigvalsh(track.position_cov)[-1]), 0.0)),
                 max_spread_m)
    for vehicle_vel in (np.asarray(vehicle_vel_ne_mps, dtype=float), np.zeros(2)):
        rel = np.asarray(track.velocity_ne_mps, dtype=float) - vehicle_vel
        speed2 = float(rel @ rel)
        t_s = 0.0 if speed2 < 1e-12 else min(max(-float(gap @ rel) / speed2, 0.0), horizon_s)
        if float(np.hypot(*(gap + t_s * rel))) <= within_m + spread:
            return True
    return False


def world_measurement(pose: np.ndarray, pose_cov: np.ndarray, z: np.ndarray,
                      meas_cov: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A range-bearing observation as a world point (2,) and its covariance (2,2)."""
    jac_pose, jac_z = place_jacobians(pose, z)
    return place(pose, z), jac_pose @ pose_cov @ jac_pose.T + jac_z @ meas_cov @ jac_z.T


class MoverTracker:
    """All mover tracks. Times are the navigator's clock, seconds."""

    def __init__(self, params: MoverParams = MoverParams()) -> None:
        self.params = params
        self._tracks: dict[int, tuple[KalmanFilter, float, int | None]] = {}
        self._updates: dict[int, int] = {}
        self._next_id = 1
        self.by_obstacle_id: dict[int, int] = {}

    def __len__(self) -> int:
        return len(self._tracks)

    def create(self, t_s: float, position: np.ndarray, position_cov: np.ndarray,
               obstacle_id: int | None,
               velocity: tuple[np.ndarray, float] | None = None,
               cross_cov: np.ndarray | None = None) -> int:
        """A new track at a world point; ``velocity``: a first estimate (2,) and its standard
        error (m/s), else at rest with initial_speed_sigma_mps; ``cross_cov`` (2,2): the
        covariance of the point's error with that estimate's (a fit through the point, as
        ``start_evidence`` gives), else none."""
        # Imported at the first track, not with the module: filterpy's package imports
        # scipy.stats (0.5-0.7 s of every start-up, serial before simulate's workers fork),
        # and most flights convict no mover.
        from filterpy.kalman import KalmanFilter
        kf = KalmanFilter(dim_x=4, dim_z=2)
        vel, vel_sigma = (np.zeros(2), self.params.initial_speed_sigma_mps) if velocity is None \
            else (np.asarray(velocity[0], dtype=float), float(velocity[1]))
        kf.x = np.array([position[0], position[1], vel[0], vel[1]])
        kf.P = np.zeros((4, 4))
        kf.P[:2, :2] = position_cov
        kf.P[2:, 2:] = np.eye(2) * vel_sigma ** 2
        if cross_cov is not None:
            kf.P[:2, 2:] = cross_cov
            kf.P[2:, :2] = np.asarray(cross_cov).T
        kf.H = np.hstack([np.eye(2), np.zeros((2, 2))])
        track_id = self._next_id
        self._next_id += 1
        self._tracks[track_id] = (kf, t_s, obstacle_id)
        if obstacle_id is not None:
            self.by_obstacle_id[obstacle_id] = track_id
        return track_id

    def _predict(self, track_id: int, t_s: float) -> KalmanFilter:
        kf, last_t, oid = self._tracks[track_id]
        dt = t_s - last_t
        if dt > 0.0:
            kf.F = np.array([[1, 0, dt, 0], [0, 1, 0, dt], [0, 0, 1, 0], [0, 0, 0, 1]], dtype=float)
            q = self.params.accel_sigma_mps2 ** 2
            g = np.array([[0.5 * dt * dt, 0], [0, 0.5 * dt * dt], [dt, 0], [0, dt]])
            kf.predict(Q=q * g @ g.T)
            self._tracks[track_id] = (kf, t_s, oid)
        return kf

    def update(self, track_id: int, t_s: float, position: np.ndarray, position_cov: np.ndarray) -> float:
        """Update a track with a world point; returns the NIS of the point against the track."""
        kf = self._predict(track_id, t_s)
        innovation = position - kf.x[:2]
        s = kf.P[:2, :2] + position_cov
        nis = float(innovation @ np.linalg.solve(s, innovation))
        kf.update(position, R=position_cov)
        kf.P = 0.5 * (kf.P + kf.P.T)
        self._updates[track_id] = self._updates.get(track_id, 0) + 1
        return nis

    def nearest(self, t_s: float, position: np.ndarray, position_cov: np.ndarray,
                max_jump_m: float = math.inf) -> int | None:
        """The track that gates an id-less world point, if any (smallest NIS under the gate),
        the point at most ``max_jump_m`` from the track's prediction. A track unseen for long
        predicts a wide ellipse (its velocity's sigma times the time unseen: 0.7 m/s over 30 s,
        21 m), and its gate then takes whatever new object comes into view there; the bound
        refuses that, set by a caller who knows how far apart objects stand
        (probation.track_reach)."""
        best, best_nis = None, self.params.gate_nis
        for track_id, (_, _, oid) in self._tracks.items():
            state = self.state(track_id, t_s)
            innovation = position - state.position_ne_m
            if math.hypot(*innovation) > max_jump_m:
                continue
            nis = float(innovation @ np.linalg.solve(state.position_cov + position_cov, innovation))
            if nis < best_nis:
                best, best_nis = track_id, nis
        return best

    def state(self, track_id: int, t_s: float) -> MoverState:
        """The track predicted to ``t_s`` without changing it."""
        kf, last_t, oid = self._tracks[track_id]
        dt = max(t_s - last_t, 0.0)
        position = kf.x[:2] + dt * kf.x[2:]
        q = self.params.accel_sigma_mps2 ** 2
        cov = (kf.P[:2, :2] + dt * (kf.P[:2, 2:] + kf.P[2:, :2]) + dt * dt * kf.P[2:, 2:]
               + q * dt ** 4 / 4.0 * np.eye(2))
        vel_cov = kf.P[2:, 2:] + q * dt * dt * np.eye(2)
        return MoverState(track_id, oid, position, kf.x[2:].copy(), cov, vel_cov,
                          self._updates.get(track_id, 0))

    def states(self, t_s: float) -> list[MoverState]:
        return [self.state(track_id, t_s) for track_id in self._tracks]

    def prune(self, t_s: float, keep=None) -> list[int]:
        """Delete tracks unseen for coast_s; returns their ids. ``keep``: a function of a track's
        predicted MoverState saying it must stay all the same (the navigator's: a track
        predicted near the vehicle but outside the camera's view, where it could not have been
        seen: deleting it forgets a mover that may be beside or behind the vehicle, issue 33)."""
        stale = [tid for tid, (_, last_t, _) in self._tracks.items()
                 if t_s - last_t > self.params.coast_s]
        if keep is not None:
            stale = [tid for tid in stale if not keep(self.state(tid, t_s))]
        for tid in stale:
            _, _, oid = self._tracks.pop(tid)
            self._updates.pop(tid, None)
            if oid is not None and self.by_obstacle_id.get(oid) == tid:
                del self.by_obstacle_id[oid]
        return stale


def apparent_velocity(times_s: np.ndarray, points_ne_m: np.ndarray, point_sigma_m: float,
                      odometry_speed_sigma_mps: float, odometry_dt_s: float
                      ) -> tuple[np.ndarray, float]:
    """Least-squares velocity (2,) of an obstacle's world points, and its standard error (m/s).

    The points are placed from the dead-reckoned pose (odometry only), so a landmark that drags
    the SLAM pose along cannot hide its motion. The error model: independent point noise, plus
    the dead-reckoning random walk, whose slope over a span T has variance sigma_v^2 dt / T.
    """
    span = float(times_s[-1] - times_s[0])
    centred = times_s - times_s.mean()
    denom = float(centred @ centred)
    velocity = centred @ (points_ne_m - points_ne_m.mean(axis=0)) / denom
    sigma = math.sqrt(point_sigma_m ** 2 / denom
                      + odometry_speed_sigma_mps ** 2 * odometry_dt_s / max(span, 1e-9))
    return velocity, sigma


def start_evidence(times_s: np.ndarray, point_sigma_m: float, velocity_sigma_mps: float,
                   position_cov: np.ndarray) -> np.ndarray:
    """(2,2) the covariance of the last of a fit's points with the fitted velocity (what
    ``apparent_velocity`` gives, standard error ``velocity_sigma_mps``): the slope leans on its
    end points, so a track started at the last point with that velocity is a correlated
    estimate; without it a coasting track's position spread would be too small. Scaled down if
    needed so that the start's covariance stays positive definite."""
    centred = np.asarray(times_s, dtype=float) - float(np.mean(times_s))
    denom = float(centred @ centred)
    if denom <= 0.0:
        return np.zeros((2, 2))
    cross = point_sigma_m ** 2 * float(centred[-1]) / denom
    # |corr| < 1 against the smaller position variance and the velocity's
    least = float(np.linalg.eigvalsh(0.5 * (position_cov + position_cov.T))[0])
    bound = 0.95 * math.sqrt(max(least, 0.0)) * velocity_sigma_mps
    return np.eye(2) * max(-bound, min(bound, cross))
