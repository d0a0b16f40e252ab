"""When to give up on the estimate and restart it from the autopilot's position.

After a GPS outage longer than the filter can bridge (its dead reckoning drifted more than its
covariance says), the returning fixes land far outside the position gate
(``EkfSlam.update_position`` refuses them, so a glitch cannot drag the pose and the map) and would
be refused for ever. ArduPilot's EKF3 answers the same question the same way: horizontal position
measurements that keep failing their innovation test for ``gpsRetryTimeNoTAS_ms`` (7 s on a
copter, libraries/AP_NavEKF3/AP_NavEKF3.cpp) time out, and the position is reset to the GPS
(``ResetPosition``, AP_NavEKF3_PosVelFusion.cpp). Here: fixes refused without a fused one between
them, for ``after_s`` and at least ``min_refused`` of them, no gap longer than ``max_gap_s``
between two (fixes that stop coming, health lost again, start the count afresh).

What the reset does to the map is the caller's (README, "GPS outage and return"): the service and
``companion simulate`` drop the estimate and start it again from the fix, as after a reboot.
Pure: times come in as arguments.
"""
from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass(frozen=True)
class PositionResetParams:
    """``after_s`` None: never reset (the fixes stay refused while they disagree)."""
    after_s: float | None = 7.0
    min_refused: int = 3
    max_gap_s: float = 3.0

    def __post_init__(self) -> None:
        if self.after_s is not None and not (math.isfinite(self.after_s) and self.after_s > 0.0):
            raise ValueError(f"position reset after_s must be > 0 or None, got {self.after_s}")
        if self.min_refused < 1:
            raise ValueError("position reset min_refused must be >= 1")


@dataclass(frozen=True)
class ResetVerdict:
    """``reset``: restart the estimate from the fix now. ``refused_for_s``: how long fixes have
    been refused in a row (0 after a fused one); ``offset_m``: the last fix's distance from the
    estimate."""
    reset: bool
    reason: str
    refused_for_s: float
    offset_m: float


class PositionResetWatch:
    """Counts refused position fixes in a row (see the module docstring)."""

    def __init__(self, params: PositionResetParams = PositionResetParams()) -> None:
        self.params = params
        self._first_s: float | None = None
        self._last_s: float | None = None
        self._count = 0

    def on_fix(self, t_s: float, action: str, innovation: tuple[float, ...]) -> ResetVerdict:
        """One fix's outcome (``UpdateReport.action``: 'position' fused, 'outlier' refused)."""
        offset = math.hypot(*innovation[:2])
        if action != "outlier":
            self._first_s = self._last_s = None
            self._count = 0
            return ResetVerdict(False, "fused", 0.0, offset)
        params = self.params
        if self._last_s is None or t_s - self._last_s > params.max_gap_s:
            self._first_s, self._count = t_s, 0
        self._last_s = t_s
        self._count += 1
        refused_for = t_s - self._first_s
        if params.after_s is not None and self._count >= params.min_refused \
                and refused_for >= params.after_s - 1e-9:
            self._first_s = self._last_s = None
            self._count = 0
            return ResetVerdict(True, f"fixes refused for {refused_for:.0f} s", refused_for, offset)
        return ResetVerdict(False, "refused", refused_for, offset)


class UnaidedDrift:
    """The position variance the filter adds while the autopilot's velocity is not GPS-aided.

    When the autopilot loses its GPS (position fusion 'auto' sees its position untrusted after
    having trusted it), the NED velocity it reports is no longer GPS-aided: a flow sensor's, a
    drag model's or the IMU's alone, with an error that is slow, not white. Modelled as a constant
    velocity error of ``sigma_mps`` per axis over the spell, its position error after t seconds is
    sigma t, so each step from t0 to t1 of the spell adds sigma^2 (t1^2 - t0^2) to each position
    variance (the white per-sample Q alone would claim sqrt(t) growth). The spell ends when the
    position is trusted again; before the first trusted position nothing is added (at start-up
    the autopilot's position is not yet known to be good or bad). ``sigma_mps`` 0: off.
    """

    def __init__(self, sigma_mps: float) -> None:
        if not (math.isfinite(sigma_mps) and sigma_mps >= 0.0):
            raise ValueError(f"unaided velocity sigma must be >= 0, got {sigma_mps}")
        self.sigma_mps = sigma_mps
        self._ever_aided = False
        self._since_s: float | None = None      # start of the unaided spell
        self._last_s: float | None = None

    def step(self, t_s: float, aided: bool) -> float:
        """The variance (m^2, per axis) to add to the pose's position at this sample."""
        if aided or self.sigma_mps <= 0.0:
            self._ever_aided = self._ever_aided or aided
            self._since_s = self._last_s = None
            return 0.0
        if not self._ever_aided:
            return 0.0
        if self._since_s is None:
            self._since_s = self._last_s = t_s
            return 0.0
        before, after = self._last_s - self._since_s, max(t_s - self._since_s, 0.0)
        self._last_s = max(t_s, self._last_s)
        return self.sigma_mps ** 2 * max(after * after - before * before, 0.0)
