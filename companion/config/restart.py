"""The ``restart:`` section: what a start that finds the vehicle already armed in the air does
(companion/onboard/look_around.py)."""
from __future__ import annotations

import math
from dataclasses import dataclass

from companion.config.checks import require_positive
from companion.config.loader import require
from companion.onboard.look_around import LookAroundParams


@dataclass(frozen=True)
class RestartConfig:
    """A start that finds the vehicle armed in the air (a restart mid-flight): hold and turn the
    nose a full circle before flying on, so the empty map is filled all round
    (companion/onboard/look_around.py)."""
    look_around: bool = True
    look_step_deg: float = 60.0           # yaw steps (< 180: the autopilot turns the short way)
    look_dwell_s: float = 0.5             # held at each step (vehicle time) for the camera
    look_yaw_tolerance_deg: float = 10.0  # a step counts as reached within this
    look_stopped_speed_mps: float = 0.5   # the turn begins once braked below this
    look_timeout_s: float = 40.0          # the look ends after this regardless
    look_clear_margin_m: float = 5.0      # then step back until the nearest mapped obstacle is
                                          # avoidance.safety_distance_m + this away
    look_back_off_speed_mps: float = 1.0

    def __post_init__(self) -> None:
        require(0.0 < self.look_step_deg < 180.0, "look_step_deg", self.look_step_deg,
                "an angle in (0, 180) deg")
        require(0.0 < self.look_yaw_tolerance_deg < self.look_step_deg, "look_yaw_tolerance_deg",
                self.look_yaw_tolerance_deg, "an angle in (0, look_step_deg) deg")
        require(self.look_dwell_s >= 0.0, "look_dwell_s", self.look_dwell_s, "a time >= 0 s")
        require(self.look_clear_margin_m >= 0.0, "look_clear_margin_m", self.look_clear_margin_m,
                "a distance >= 0 m")
        for key in ("look_stopped_speed_mps", "look_timeout_s", "look_back_off_speed_mps"):
            require_positive(key, getattr(self, key))

    def params(self, safety_distance_m: float) -> LookAroundParams:
        return LookAroundParams(self.look_around, math.radians(self.look_step_deg),
                                math.radians(self.look_yaw_tolerance_deg), self.look_dwell_s,
                                self.look_stopped_speed_mps, self.look_timeout_s,
                                safety_distance_m + self.look_clear_margin_m,
                                self.look_back_off_speed_mps)
