"""The service in 3D (issue 27): points' z, the vehicle's altitude and the vertical setpoint.

Off unless ``avoidance.vertical: true``; then the service's flights are today's, bit for bit
(the codec's z is carried on the observations but nothing reads it).

On:
- A frame's OBSTACLE_DISTANCE_3D points are grouped into one observation per obstacle, its
  highest and lowest point (core/perception/point_groups.py).
- The navigator judges each against the vehicle's altitude above the takeoff point (the flight
  phase's: GLOBAL_POSITION_INT relative_alt, else LOCAL_POSITION_NED -z over where it stood
  disarmed): the floor (within ``perception.ground_margin_m``) and non-finite z dropped and
  counted, each landmark's top and bottom estimated (core/perception/vertical_extent.py).
- Its decision considers climbing over and sinking under (core/avoidance/vertical.py), around
  the cruise altitude: ``flight.hold_alt_m``, else the altitude at which commanding began (the
  vertical hold's). The setpoint's vz is the decision's climb rate, within
  +-``safety.max_vertical_speed_mps``, never sinking at or below ``avoidance.min_altitude_m`` nor
  climbing at or above ``avoidance.max_altitude_m``, finite; the flight phases stay in force (no
  setpoint at all unless airborne). A safe-action hold holds the altitude it is at (vz 0: over
  a wall the vertical hold would sink toward the cruise altitude).
"""
from __future__ import annotations

import dataclasses
import math

from companion.config.service import CompanionConfig
from companion.core.avoidance.vertical import VerticalParams
from companion.core.estimation.slam_types import Observation
from companion.core.perception.point_groups import group_points
from companion.core.perception.vertical_extent import ExtentParams

SERVICE_VFOV_DEG = 58.0       # the camera's vertical view when perception.camera_vfov_deg is null
DEFAULT_REACH_M = 40.0        # obstacles planned for, when estimator.sensor_max_range_m is null


class ServiceHeights:
    """avoidance.vertical in the service: what the pipeline asks at each step."""

    def __init__(self, config: CompanionConfig) -> None:
        avoidance, perception = config.avoidance, config.perception
        self.on = bool(avoidance.vertical)
        self.hold_alt_m = config.flight.hold_alt_m
        self.max_vertical_speed_mps = config.safety.max_vertical_speed_mps
        self.min_altitude_m = avoidance.min_altitude_m
        self.max_altitude_m = avoidance.max_altitude_m
        self.extent = ExtentParams(perception.vfov_rad(SERVICE_VFOV_DEG),
                                   perception.ground_margin_m) if self.on else None
        self._params = VerticalParams(
            safety_distance_m=config.safety_distance_m, cruise_altitude_m=math.nan,
            max_vertical_speed_mps=config.safety.max_vertical_speed_mps,
            min_altitude_m=avoidance.min_altitude_m, max_altitude_m=avoidance.max_altitude_m,
            cruise_speed_mps=config.commanding.cruise_speed_mps,
            reach_m=config.estimator.sensor_max_range_m or DEFAULT_REACH_M,
            max_accel_mps2=config.commanding.max_accel_mps2, barrier_cost=True) \
            if self.on else None
        self.merged_points = 0

    def vertical_params(self, cruise_up_m: float | None) -> VerticalParams | None:
        """The decision's parameters around ``cruise_up_m`` (None while unknown: the floor of
        the altitude limits, replaced at the first decision with an altitude)."""
        if self._params is None:
            return None
        cruise = cruise_up_m if cruise_up_m is not None and math.isfinite(cruise_up_m) \
            else self.min_altitude_m
        return dataclasses.replace(self._params, cruise_altitude_m=float(cruise))

    def frame(self, observations: list[Observation]) -> list[Observation]:
        """One frame's observations as the navigator gets them (grouped when on)."""
        if not self.on:
            return observations
        grouped, merged = group_points(list(observations))
        self.merged_points += merged
        return grouped

    def cruise_up_m(self, held_up_m: float | None, up_m: float | None) -> float | None:
        """flight.hold_alt_m, else the vertical hold's target (where commanding began), else
        the altitude now (commanding will begin there)."""
        if self.hold_alt_m is not None:
            return self.hold_alt_m
        return held_up_m if held_up_m is not None else up_m

    def sync(self, navigator, up_m: float | None, cruise_up_m: float | None) -> None:
        """Before the navigator reads a frame or decides: the altitude now, the cruise one."""
        if not self.on or navigator is None:
            return
        if up_m is not None and math.isfinite(up_m):
            navigator.on_altitude(up_m)
        if cruise_up_m is not None and math.isfinite(cruise_up_m):
            current = navigator.vertical
            if current is None or current.cruise_altitude_m != cruise_up_m:
                navigator.vertical = self.vertical_params(cruise_up_m)

    def vel_down_mps(self, navigator, up_m: float | None, held_vel_down_mps: float,
                     safe_hold: bool) -> float:
        """vz of a setpoint (down positive): ``held_vel_down_mps`` (the vertical hold's) when
        off or before any 3D decision; 0 for a safe-action hold; else the decision's climb
        rate within the limits (module docstring)."""
        if not self.on:
            return held_vel_down_mps
        if safe_hold:
            return 0.0
        choice = None if navigator is None else navigator.vertical_choice
        if choice is None or up_m is None or not math.isfinite(up_m):
            return held_vel_down_mps
        return -self.limit_climb_mps(choice.climb_mps, up_m)

    def limit_climb_mps(self, climb_mps: float, up_m: float) -> float:
        """A climb rate (up positive) the service may send at altitude ``up_m``."""
        if not math.isfinite(climb_mps):
            return 0.0
        limit = self.max_vertical_speed_mps
        climb = min(limit, max(-limit, float(climb_mps)))
        if climb < 0.0 and up_m <= self.min_altitude_m:
            return 0.0
        if climb > 0.0 and up_m >= self.max_altitude_m:
            return 0.0
        return climb

    def snapshot(self, navigator) -> dict:
        """The report's 3D part (only when on): points dropped and merged, the last plan."""
        if not self.on:
            return {}
        choice = None if navigator is None else navigator.vertical_choice
        extents = {} if navigator is None else {
            str(key): {"top_m": e.top_m, "top_sigma_m": e.top_sigma_m, "bottom_m": e.bottom_m,
                       "sightings": e.sightings} for key, e in navigator.extents.items()}
        return {"vertical": {
            "points": dict(navigator.points) if navigator is not None else {"ground": 0,
                                                                             "bad_z": 0},
            "merged_points": self.merged_points,
            "plan": None if choice is None else {"kind": choice.plan.kind,
                                                 "altitude_m": choice.plan.altitude_m,
                                                 "climb_mps": choice.climb_mps},
            "extents": extents}}
