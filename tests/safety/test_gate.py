"""SetpointGate: the one check every outbound setpoint passes; refusals counted by reason."""
import math
from dataclasses import dataclass, replace

import pytest

from companion.mavlink import codec
from companion.onboard.safety.gate import SetpointGate, SetpointLimits

LIMITS = SetpointLimits(max_speed_mps=8.0, max_vertical_speed_mps=2.5,
                        max_yaw_rate_rad_s=math.radians(90.0), max_position_m=1000.0)
GOOD = codec.VelocitySetpoint(1, 1, 10.0, 5.0, 3.0, 0.5, "goal")


@dataclass(frozen=True)
class FullSetpoint:
    """A setpoint with every field the gate knows (vertical velocity, yaw rate, position)."""
    t_s: float = 1.0
    vel_north_mps: float = 1.0
    vel_east_mps: float = 0.0
    vel_down_mps: float = 0.0
    yaw_rad: float = 0.0
    yaw_rate_rad_s: float = 0.0
    north_m: float = 0.0
    east_m: float = 0.0
    down_m: float = -10.0
    some_new_gain: float = 1.0


def test_a_setpoint_within_limits_passes():
    gate = SetpointGate(LIMITS)
    assert gate.check(GOOD).passed and gate.check(FullSetpoint()).passed
    assert gate.refused == {}


@pytest.mark.parametrize("change, reason", [
    (dict(vel_north_mps=math.nan), "vel_north_mps not finite"),
    (dict(vel_east_mps=math.inf), "vel_east_mps not finite"),
    (dict(yaw_rad=math.nan), "yaw_rad not finite"),
    (dict(t_s=math.nan), "t_s not finite"),
    (dict(vel_north_mps=6.0, vel_east_mps=6.0), "speed above max_speed_mps"),
    (dict(yaw_rad=4.0), "yaw_rad outside [-pi, pi]"),
])
def test_each_field_of_a_velocity_setpoint_is_checked(change, reason):
    gate = SetpointGate(LIMITS)
    verdict = gate.check(replace(GOOD, **change))
    assert (verdict.passed, verdict.reason) == (False, reason)
    assert gate.refused == {reason: 1}


@pytest.mark.parametrize("change, reason", [
    (dict(vel_down_mps=3.0), "vel_down_mps above max_vertical_speed_mps"),
    (dict(vel_down_mps=-3.0), "vel_down_mps above max_vertical_speed_mps"),
    (dict(yaw_rate_rad_s=2.0), "yaw_rate_rad_s above max_yaw_rate"),
    (dict(yaw_rate_rad_s=math.nan), "yaw_rate_rad_s not finite"),
    (dict(north_m=3.4e38), "north_m beyond max_position_m"),
    (dict(down_m=-5000.0), "down_m beyond max_position_m"),
    (dict(some_new_gain=math.nan), "some_new_gain not finite"),    # unknown fields: finite
])
def test_vertical_velocity_yaw_rate_position_and_new_fields_are_checked(change, reason):
    gate = SetpointGate(LIMITS)
    verdict = gate.check(FullSetpoint(**change))
    assert (verdict.passed, verdict.reason) == (False, reason)
