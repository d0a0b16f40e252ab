"""The vehicle's clock (time since boot, carried by its messages) and reboot detection."""
from __future__ import annotations

import math
from dataclasses import dataclass

REBOOT_BACKSTEP_S = 1.0          # time_boot_ms stepping back more than this: the vehicle rebooted


@dataclass(frozen=True)
class ClockVerdict:
    accepted: bool
    reason: str                  # 'ok', 'not_finite', 'reboot'


class VehicleClock:
    """Tracks the latest vehicle time seen on the autopilot's own messages."""

    def __init__(self) -> None:
        self.latest_t_s: float | None = None

    def on_autopilot(self, t_s: float) -> ClockVerdict:
        """A time stamp of the autopilot's ATTITUDE or LOCAL_POSITION_NED."""
        if not math.isfinite(t_s):
            return ClockVerdict(False, "not_finite")
        if self.latest_t_s is not None and t_s < self.latest_t_s - REBOOT_BACKSTEP_S:
            self.latest_t_s = t_s
            return ClockVerdict(True, "reboot")
        self.latest_t_s = t_s if self.latest_t_s is None else max(self.latest_t_s, t_s)
        return ClockVerdict(True, "ok")

    def frame_too_old(self, t_s: float) -> bool:
        """An obstacle frame from before the vehicle's clock (or at a non-finite time)."""
        return not math.isfinite(t_s) or (self.latest_t_s is not None
                                          and t_s < self.latest_t_s - REBOOT_BACKSTEP_S)
