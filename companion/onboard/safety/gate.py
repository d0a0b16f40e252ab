"""The only way out for a setpoint: every field finite and within the configured limits.

:meth:`SetpointGate.check` looks at every float field of the setpoint, whatever its type, so a
field added later (vertical velocity, yaw rate, position) is at least checked for finiteness;
fields it knows by name are held to their limit:

- ``vel_north_mps``, ``vel_east_mps``: horizontal speed <= max_speed_mps
- any other ``vel_*_mps`` and ``climb_rate_mps``: |value| <= max_vertical_speed_mps
- ``yaw_rad``: in [-pi, pi]
- ``yaw_rate_rad_s``: |value| <= max_yaw_rate_rad_s
- ``north_m``, ``east_m``, ``down_m``, ``alt_m``: |value| <= max_position_m
"""
from __future__ import annotations

import dataclasses
import functools
import math
from dataclasses import dataclass

HORIZONTAL = ("vel_north_mps", "vel_east_mps")
POSITIONS = ("north_m", "east_m", "down_m", "alt_m")


@dataclass(frozen=True)
class SetpointLimits:
    max_speed_mps: float
    max_vertical_speed_mps: float = 3.0
    max_yaw_rate_rad_s: float = math.radians(90.0)
    max_position_m: float = 100_000.0


@dataclass(frozen=True)
class GateVerdict:
    passed: bool
    reason: str              # 'ok' or why the setpoint was refused


@functools.lru_cache(maxsize=16)
def _field_names(kind: type) -> tuple[str, ...]:
    return tuple(f.name for f in dataclasses.fields(kind))


class SetpointGate:
    """Checks each setpoint; counts refusals by reason in ``refused``."""

    def __init__(self, limits: SetpointLimits) -> None:
        self.limits = limits
        self.refused: dict[str, int] = {}

    def check(self, setpoint) -> GateVerdict:
        values = {name: value for name in _field_names(type(setpoint))
                  if isinstance(value := getattr(setpoint, name), float)}
        for name, value in values.items():
            if not math.isfinite(value):
                return self._refuse(f"{name} not finite")
        limits = self.limits
        if math.hypot(*(values.get(n, 0.0) for n in HORIZONTAL)) > limits.max_speed_mps + 1e-9:
            return self._refuse("speed above max_speed_mps")
        for name, value in values.items():
            if (name.startswith("vel_") and name.endswith("_mps") and name not in HORIZONTAL) \
                    or name == "climb_rate_mps":
                if abs(value) > limits.max_vertical_speed_mps + 1e-9:
                    return self._refuse(f"{name} above max_vertical_speed_mps")
            elif name == "yaw_rad" and not -math.pi <= value <= math.pi:
                return self._refuse("yaw_rad outside [-pi, pi]")
            elif name == "yaw_rate_rad_s" and abs(value) > limits.max_yaw_rate_rad_s + 1e-9:
                return self._refuse("yaw_rate_rad_s above max_yaw_rate")
            elif name in POSITIONS and abs(value) > limits.max_position_m:
                return self._refuse(f"{name} beyond max_position_m")
        return GateVerdict(True, "ok")

    def _refuse(self, reason: str) -> GateVerdict:
        self.refused[reason] = self.refused.get(reason, 0) + 1
        return GateVerdict(False, reason)
