"""Does the estimator still know where it is? A consistency monitor.

Two tests, both on what the filter itself produces:

- **Innovations.** The normalised innovation squared (NIS) of every pose-correcting measurement
  (established landmarks, the autopilot's yaw and position) over the last ``window_s`` seconds.
  For a consistent filter their sum is chi-square with the summed degrees of freedom; a sum
  beyond its ``nis_probability`` quantile says the filter is more certain than it should be, or
  its model is wrong (a biased odometry, a bad yaw). A refused measurement counts too, capped at
  ``nis_cap`` so one glitch cannot dominate a window.
- **Covariance growth.** The pose's 2-sigma radius (twice the square root of the largest
  eigenvalue of the position covariance): dead reckoning without landmarks or fixes grows it.

States: ``ok``; ``degraded`` when the NIS test fails or the radius exceeds ``degraded_radius_m``;
``lost`` when the radius exceeds ``lost_radius_m`` or the NIS test has failed for
``lost_after_s`` without a break. Pure: time is an argument.
"""
from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass
from statistics import NormalDist

import numpy as np

STATES = ("ok", "degraded", "lost")


def chi2_quantile(p: float, dof: int) -> float:
    """Chi-square quantile: exact for 1 and 2 dof, else Wilson-Hilferty (within 1% of the exact
    value from 20 dof; below that up to 4% high at the 0.9999 tail, the safe side for a bound).
    Written out so that the daemon need not import scipy.stats."""
    if dof <= 0:
        return 0.0
    if dof == 1:
        return NormalDist().inv_cdf(0.5 + 0.5 * p) ** 2
    if dof == 2:
        return -2.0 * math.log1p(-p)
    z = NormalDist().inv_cdf(p)
    c = 2.0 / (9.0 * dof)
    return dof * (1.0 - c + z * math.sqrt(c)) ** 3


def radius_2sigma_m(pose_cov: np.ndarray) -> float:
    """Twice the standard deviation of the position along its worst axis, metres."""
    xx, xy, yy = float(pose_cov[0, 0]), float(pose_cov[0, 1]), float(pose_cov[1, 1])
    half_trace = 0.5 * (xx + yy)
    worst = half_trace + math.sqrt(max(0.25 * (xx - yy) ** 2 + xy * xy, 0.0))
    return 2.0 * math.sqrt(max(worst, 0.0))


@dataclass(frozen=True)
class MonitorParams:
    window_s: float = 10.0
    nis_probability: float = 0.9999       # windowed NIS sum beyond this quantile: inconsistent
    min_dof: int = 10                     # fewer degrees of freedom in the window: not judged
    lost_after_s: float = 10.0            # the NIS test failing this long without a break: lost
    degraded_radius_m: float = 5.0        # pose 2-sigma radius
    lost_radius_m: float = 20.0
    nis_cap: float = 25.0

    def __post_init__(self) -> None:
        if not (self.window_s > 0 and 0.0 < self.nis_probability < 1.0
                and 0.0 < self.degraded_radius_m <= self.lost_radius_m and self.nis_cap > 0):
            raise ValueError("monitor: window_s > 0, 0 < nis_probability < 1, "
                             "0 < degraded_radius_m <= lost_radius_m, nis_cap > 0")


@dataclass(frozen=True)
class Consistency:
    """One assessment: the state, why, and the figures it was decided on."""
    t_s: float
    state: str
    reason: str
    nis_sum: float
    nis_bound: float
    dof: int
    radius_2sigma_m: float


class ConsistencyMonitor:
    """Windowed NIS against its chi-square bound, plus the pose's 2-sigma radius."""

    def __init__(self, params: MonitorParams = MonitorParams()) -> None:
        self.params = params
        self._window: deque[tuple[float, float, int]] = deque()     # (t_s, nis, dof)
        self._nis_sum = 0.0
        self._dof = 0
        self._failing_since_s: float | None = None
        self.last: Consistency | None = None

    def add(self, t_s: float, nis: float, dof: int) -> None:
        """One measurement's NIS (a refused one's too) with its degrees of freedom."""
        value = min(nis, self.params.nis_cap) if math.isfinite(nis) else self.params.nis_cap
        self._window.append((t_s, value, dof))
        self._nis_sum += value
        self._dof += dof

    def _expire(self, t_s: float) -> None:
        while self._window and self._window[0][0] < t_s - self.params.window_s:
            _, nis, dof = self._window.popleft()
            self._nis_sum -= nis
            self._dof -= dof
        if not self._window:
            self._nis_sum, self._dof = 0.0, 0

    def assess(self, t_s: float, pose_cov: np.ndarray) -> Consistency:
        """The state now, from the window ending at ``t_s`` and the pose covariance (3,3)."""
        params = self.params
        self._expire(t_s)
        bound = chi2_quantile(params.nis_probability, self._dof) if self._dof else math.inf
        inconsistent = self._dof >= params.min_dof and self._nis_sum > bound
        if inconsistent:
            if self._failing_since_s is None:
                self._failing_since_s = t_s
        else:
            self._failing_since_s = None
        radius = radius_2sigma_m(pose_cov)
        if not math.isfinite(radius) or radius > params.lost_radius_m:
            state, reason = "lost", f"pose 2-sigma {radius:.1f} m"
        elif inconsistent and t_s - self._failing_since_s >= params.lost_after_s:
            state, reason = "lost", f"innovations inconsistent for {t_s - self._failing_since_s:.0f} s"
        elif inconsistent:
            state, reason = "degraded", f"NIS {self._nis_sum:.0f} > {bound:.0f} ({self._dof} dof)"
        elif radius > params.degraded_radius_m:
            state, reason = "degraded", f"pose 2-sigma {radius:.1f} m"
        else:
            state, reason = "ok", ""
        self.last = Consistency(t_s, state, reason, self._nis_sum, bound, self._dof, radius)
        return self.last
