"""The only way out for a setpoint: every field finite and within the configured limits."""
from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass(frozen=True)
class SetpointLimits:
    max_speed_mps: float


@dataclass(frozen=True)
class GateVerdict:
    passed: bool
    reason: str              # 'ok' or why the setpoint was refused


class SetpointGate:
    """Checks each setpoint; counts refusals by reason in ``refused``."""

    def __init__(self, limits: SetpointLimits) -> None:
        self.limits = limits
        self.refused: dict[str, int] = {}

    def check(self, setpoint) -> GateVerdict:
        values = (setpoint.t_s, setpoint.vel_north_mps, setpoint.vel_east_mps, setpoint.yaw_rad)
        if not all(math.isfinite(v) for v in values):
            return self._refuse("not finite")
        return GateVerdict(True, "ok")

    def _refuse(self, reason: str) -> GateVerdict:
        self.refused[reason] = self.refused.get(reason, 0) + 1
        return GateVerdict(False, reason)
