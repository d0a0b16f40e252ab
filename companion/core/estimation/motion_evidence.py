"""Is a young landmark's history the track of one moving object, or clutter?

A landmark on probation is judged moving when the least-squares velocity of its dead-reckoned
points is fast and many standard errors from zero (MoverProbation.judge, core/estimation/movers.py). Two
points always fit a straight line, so two false alarms a few metres apart, or a false alarm and
the first sighting of a post beside it, look like an object moving at metres a second. A track
is evidence of motion only when at least ``MIN_TRACK_POINTS`` points lie on one constant-velocity
line within their noise: the fit's residuals, normalised by each point's sigma, must pass the
chi-square gate of 2 (n - 2) degrees of freedom. Clutter does not line up; a mover does.
"""
from __future__ import annotations

import numpy as np

from companion.core.estimation.consistency import chi2_quantile

MIN_TRACK_POINTS = 4            # two points always fit a line, and three hardly test it
TRACK_PROBABILITY = 0.999       # a mover's own track fails the gate once in a thousand verdicts


def straight_track_nis(times_s: np.ndarray, points_ne_m: np.ndarray,
                       sigmas_m: np.ndarray) -> tuple[float, int]:
    """Weighted residual sum of squares of a constant-velocity fit to the points (n, 2) at
    times (n,), each with its own sigma (n,) per axis; and its degrees of freedom, 2 (n - 2)."""
    times = np.asarray(times_s, dtype=float)
    points = np.asarray(points_ne_m, dtype=float)
    weights = 1.0 / np.asarray(sigmas_m, dtype=float) ** 2
    t_mean = float(weights @ times / weights.sum())
    p_mean = weights @ points / weights.sum()
    centred = times - t_mean
    denom = float(weights @ centred ** 2)
    velocity = (weights * centred) @ (points - p_mean) / denom if denom > 0.0 else np.zeros(2)
    residuals = points - p_mean - np.outer(centred, velocity)
    return float(weights @ np.sum(residuals ** 2, axis=1)), 2 * (len(times) - 2)


def is_straight_track(times_s, points_ne_m, sigmas_m,
                      probability: float = TRACK_PROBABILITY) -> bool:
    """Whether the points are one object's constant-velocity track within their noise."""
    if len(times_s) < MIN_TRACK_POINTS:
        return False
    nis, dof = straight_track_nis(times_s, points_ne_m, sigmas_m)
    return nis <= chi2_quantile(probability, dof)


def shared_yaw_velocity_cov(times_s, ranges_m, directions_rad, yaw_vars_rad2,
                            yaw_log_transfers) -> np.ndarray:
    """(2, 2) covariance of the unweighted least-squares velocity (as movers.apparent_velocity
    fits it) that the pose's yaw error puts into points placed with it.

    A point seen at range r along world direction a (the pose's yaw plus the bearing) is
    displaced by r (-sin a, cos a) e by the pose's yaw error e. The filter's yaw errors at two
    frames are not independent: through a predict the error carries over whole (plus new,
    independent noise); through a correction it is scaled by (1 - K H) of the yaw, so
    Cov(e_i, e_j) = exp(L_j - L_i) P_i for t_i <= t_j, where P_i is the yaw variance the point
    i was placed with and L the running log of the corrections' factors
    (Estimator.yaw_transfer_log). Two frames 0.2 s apart share nearly all of their yaw error,
    and it cancels in their difference instead of counting twice.
    """
    times = np.asarray(times_s, dtype=float)
    order = np.argsort(times, kind="stable")
    times = times[order]
    ranges = np.asarray(ranges_m, dtype=float)[order]
    directions = np.asarray(directions_rad, dtype=float)[order]
    variances = np.asarray(yaw_vars_rad2, dtype=float)[order]
    logs = np.asarray(yaw_log_transfers, dtype=float)[order]
    centred = times - times.mean()
    denom = float(centred @ centred)
    if denom <= 0.0:
        return np.zeros((2, 2))
    # yaw-error covariance between the points (earlier index i, later j)
    i, j = np.meshgrid(np.arange(len(times)), np.arange(len(times)), indexing="ij")
    early, late = np.minimum(i, j), np.maximum(i, j)
    yaw_cov = np.exp(np.minimum(logs[late] - logs[early], 0.0)) * variances[early]
    lateral = np.column_stack([-np.sin(directions), np.cos(directions)])
    weights = (centred / denom * ranges)[:, None] * lateral           # (n, 2)
    return weights.T @ yaw_cov @ weights
