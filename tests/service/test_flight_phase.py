"""Flight phases (may we command at all?), the vertical hold, and the latitude/longitude goal."""
import dataclasses
import math

import pytest

from companion.mavlink import codec
from companion.config.service import GoalConfig
from companion.onboard.flight_phase import (AIRBORNE, LANDED, LANDING, TAKING_OFF, FlightPhase,
                                    FlightPhaseParams, VerticalHold)
from companion.core.flat_earth import LOCATION_SCALING_FACTOR_M
from companion.onboard.goal import goal_north_east
from companion.onboard.pipeline import Pipeline

from .test_pipeline import GOAL, Feed, config, hb, setpoints, started


def test_landed_state_decides_while_fresh():
    phase = FlightPhase()
    phase.on_armed(True)
    for state, name, may in ((1, LANDED, False), (3, TAKING_OFF, False), (2, AIRBORNE, True),
                             (4, LANDING, False)):
        phase.on_landed_state(10.0, state)
        d = phase.decide(10.5)
        assert (d.phase, d.may_command, d.source) == (name, may, "landed_state")
    phase.on_landed_state(10.0, 2)
    assert phase.decide(13.5).source == "unknown"            # stale, no altitude either
    assert not phase.decide(13.5).may_command


def test_disarmed_is_landed_whatever_the_vehicle_says():
    phase = FlightPhase()
    phase.on_landed_state(1.0, 2)
    d = phase.decide(1.0)
    assert (d.phase, d.may_command, d.source) == (LANDED, False, "disarmed")


def fly_altitude(phase, profile, t0=0.0, dt=0.1):
    """profile: list of (seconds, climb m/s); feeds relative_alt at 10 Hz; returns (t, up)."""
    t, up = t0, 0.0 if phase.up_m is None else phase.up_m
    for seconds, climb in profile:
        for _ in range(int(round(seconds / dt))):
            t = round(t + dt, 6)
            up = max(0.0, up + climb * dt)
            phase.on_relative_alt(t, up, -climb)
    return t, up


def test_altitude_fallback_takeoff_until_the_climb_stops_then_airborne_then_landing():
    phase = FlightPhase(FlightPhaseParams(airborne_alt_m=2.0, climb_stopped_s=1.0))
    phase.on_armed(True)
    t, _ = fly_altitude(phase, [(1.0, 0.0)])
    assert phase.decide(t).phase == LANDED
    t, up = fly_altitude(phase, [(3.0, 2.5)], t)               # climbing through 7.5 m
    assert phase.decide(t).phase == TAKING_OFF and not phase.decide(t).may_command
    t, _ = fly_altitude(phase, [(0.5, 0.0)], t)                 # stopped, not long enough yet
    assert phase.decide(t).phase == TAKING_OFF
    t, _ = fly_altitude(phase, [(0.6, 0.0)], t)
    d = phase.decide(t)
    assert (d.phase, d.may_command, d.source) == (AIRBORNE, True, "altitude")
    t, _ = fly_altitude(phase, [(6.0, -1.0)], t)                # below 2 m: landing
    assert phase.decide(t).phase == LANDING
    t, _ = fly_altitude(phase, [(3.0, -1.0), (1.2, 0.0)], t)    # on the ground, at rest
    assert phase.decide(t).phase == LANDED


def test_altitude_fallback_with_a_takeoff_altitude_waits_for_it():
    phase = FlightPhase(FlightPhaseParams(takeoff_alt_m=10.0))
    phase.on_armed(True)
    t, _ = fly_altitude(phase, [(2.0, 2.5), (3.0, 0.0)])       # paused at 5 m for 3 s
    assert phase.decide(t).phase == TAKING_OFF
    t, _ = fly_altitude(phase, [(2.0, 2.5)], t)                 # 10 m reached
    assert phase.decide(t).phase == AIRBORNE


def test_local_position_z_is_taken_from_the_ground_where_it_was_disarmed():
    phase = FlightPhase()
    phase.on_local_position(1.0, 3.0, 0.0)                      # EKF origin 3 m above the pad
    phase.on_armed(True)
    t = 1.0
    for k in range(60):                                          # climb to 12 m above the pad
        t = round(t + 0.1, 6)
        phase.on_local_position(t, 3.0 - min(12.0, 0.25 * (k + 1)), -2.5 if k < 48 else 0.0)
    assert phase.up_m == pytest.approx(12.0)
    assert phase.decide(t).phase == AIRBORNE


def test_vertical_hold_holds_the_altitude_commanding_began_at_with_bounded_vz():
    hold = VerticalHold(FlightPhaseParams(vertical_gain_per_s=0.5, max_vertical_speed_mps=1.0))
    assert hold.vel_down_mps(None) == 0.0
    assert hold.vel_down_mps(10.0) == 0.0 and hold.target_up_m == 10.0
    assert hold.vel_down_mps(9.0) == pytest.approx(-0.5)         # 1 m low: climb 0.5 m/s
    assert hold.vel_down_mps(20.0) == pytest.approx(1.0)         # far high: descend at the bound
    hold.reset()
    assert hold.vel_down_mps(15.0) == 0.0 and hold.target_up_m == 15.0
    fixed = VerticalHold(FlightPhaseParams(hold_alt_m=12.0))
    assert fixed.vel_down_mps(10.0) == pytest.approx(-1.0)


@pytest.mark.parametrize("state", [codec.LANDED_STATE_ON_GROUND, codec.LANDED_STATE_TAKEOFF,
                                   codec.LANDED_STATE_LANDING])
def test_no_setpoint_hold_included_unless_airborne(state):
    feed = started(require_camera=True, obstacle_timeout_s=1.0)   # stale camera: would hold
    feed.landed_state = state
    feed.camera_alive = False
    for _ in range(40):
        feed.step()
    assert setpoints(feed.outputs) == []
    assert sum(v for k, v in feed.p.counters.items() if k.startswith("no_setpoint_")) >= 30
    feed.landed_state = codec.LANDED_STATE_IN_AIR
    for _ in range(11):
        feed.step()
    assert setpoints(feed.outputs)                               # airborne: the hold goes out


def test_setpoints_carry_the_vertical_hold():
    feed = started()
    for _ in range(5):
        feed.step()
    sps = setpoints(feed.outputs)
    assert sps and all(sp.vel_down_mps == 0.0 for sp in sps)     # at the held 10 m
    assert feed.p.vertical.target_up_m == pytest.approx(10.0)
    msg = codec.set_position_target(dataclasses.replace(sps[-1], vel_down_mps=0.4))
    assert msg.type_mask == codec.VELOCITY_YAW_TYPE_MASK and msg.vz == pytest.approx(0.4)


def test_lat_lon_conversion_matches_arduPilot_scaling():
    lat0, lon0 = -35.363261, 149.165230
    north, east = goal_north_east(lat0 + 100.0 / (LOCATION_SCALING_FACTOR_M * 1e7), lon0,
                                  lat0, lon0, 0.0, 0.0)
    assert (north, east) == (pytest.approx(100.0), pytest.approx(0.0))
    dlon = 50.0 / (LOCATION_SCALING_FACTOR_M * 1e7 * math.cos(math.radians(lat0)))
    north, east = goal_north_east(lat0, lon0 + dlon, lat0, lon0, 20.0, -3.0)  # from HOME
    assert (north, east) == (pytest.approx(20.0), pytest.approx(47.0, abs=1e-3))
    with pytest.raises(ValueError, match="km from"):
        goal_north_east(lat0 + 2.0, lon0, lat0, lon0, 0.0, 0.0)


def test_a_lat_lon_goal_waits_for_the_ekf_origin_then_guides():
    lat0, lon0 = -35.363261, 149.165230
    goal = GoalConfig(lat_deg=lat0 + 180.0 / (LOCATION_SCALING_FACTOR_M * 1e7), lon_deg=lon0)
    feed = Feed(Pipeline(config(require_camera=False), goal))
    feed.send(hb())
    for _ in range(10):
        feed.step()
    assert setpoints(feed.outputs) == [] and feed.p.needs_geo_reference
    feed.send(codec.GeoReference(1, 1, "home", lat0 + 1e-4, lon0, 11.1, 0.0))   # HOME first
    assert feed.p.goal_ne == (pytest.approx(180.0 - 11.13 + 11.1, abs=0.05), pytest.approx(0.0))
    assert feed.p.needs_geo_reference                             # the origin is still better
    feed.send(codec.GeoReference(1, 1, "origin", lat0, lon0, 0.0, 0.0))
    assert feed.p.goal_ne == (pytest.approx(180.0), pytest.approx(0.0))
    assert not feed.p.needs_geo_reference
    assert list(feed.p.navigator.goal) == [pytest.approx(180.0), pytest.approx(0.0)]
    for _ in range(3):
        feed.step()
    assert setpoints(feed.outputs)[-1].vel_north_mps == pytest.approx(5.0)


def test_goal_config_forms_and_mistakes():
    assert GoalConfig(1.0, 2.0).is_geographic is False
    assert GoalConfig(lat_deg=1.0, lon_deg=2.0, radius_m=3.0).is_geographic
    from companion.config.loader import FieldError
    with pytest.raises(FieldError, match="not both"):
        GoalConfig(north_m=1.0, east_m=2.0, lat_deg=1.0, lon_deg=2.0)
    with pytest.raises(FieldError, match="lon_deg: missing"):
        GoalConfig(lat_deg=1.0)
    with pytest.raises(FieldError, match="latitude"):
        GoalConfig(lat_deg=91.0, lon_deg=0.0)
    assert GOAL.north_m == 180.0


@pytest.mark.parametrize("text, expected", [
    ("180,0", GoalConfig(north_m=180.0, east_m=0.0)),
    ("10,-5,3", GoalConfig(north_m=10.0, east_m=-5.0, radius_m=3.0)),
    ("geo:-35.3616,149.1652", GoalConfig(lat_deg=-35.3616, lon_deg=149.1652)),
    ("GEO:-35.3616,149.1652,4", GoalConfig(lat_deg=-35.3616, lon_deg=149.1652, radius_m=4.0)),
])
def test_goal_command_line_forms(text, expected):
    from companion.cli.run import parse_goal
    assert parse_goal(text) == expected


@pytest.mark.parametrize("text, message", [
    ("geo:91,0", "--goal: lat_deg: expected a latitude in [-90, 90]"),
    ("geo:1", "--goal: expected geo:LAT,LON"),
    ("1,nan", "--goal: expected finite numbers"),
    ("north", "--goal: expected NORTH,EAST"),
    ("1,2,0", "--goal: radius_m: expected a value > 0"),
])
def test_goal_command_line_mistakes_are_clear(text, message):
    from companion.cli.run import parse_goal
    from companion.errors import ConfigError
    with pytest.raises(ConfigError) as err:
        parse_goal(text)
    assert str(err.value).startswith(message), err.value


def test_goal_config_file_forms(tmp_path):
    from companion.config.service import load_config
    from companion.errors import ConfigError
    base = open("config/companion.yaml").read()
    good = tmp_path / "geo.yaml"
    good.write_text(base.replace("goal: null", "goal: {lat_deg: -35.36, lon_deg: 149.16}"))
    assert load_config(good).goal == GoalConfig(lat_deg=-35.36, lon_deg=149.16)
    bad = tmp_path / "bad.yaml"
    bad.write_text(base.replace("goal: null", "goal: {lat_deg: -35.36, north_m: 3.0}"))
    with pytest.raises(ConfigError, match=r"bad.yaml: goal.lat_deg: give north_m and east_m"):
        load_config(bad)
