"""avoidance.speed_limit: seen (issue 46, items 1 and 2): never faster than the vehicle stops in
the space its camera has seen free, the loop's latency counted; the last resort brakes sideways.
With the key off every figure is what it was (the flights of every other scenario unchanged)."""
import math
from dataclasses import replace

import numpy as np
import pytest

from companion.core.avoidance import speed_limit
from companion.core.avoidance import velocity_choice as vc
from companion.core.avoidance.arc import VehicleLimits, clearance, fly_out, stopping_distance_m
from companion.core.avoidance.evade import fly_strafe
from companion.core.avoidance.guidance import GuidanceParams
from companion.core.avoidance.seen_space import CELL_M, SeenSpace
from companion.core.avoidance.union import UnionParams, sensed_speed_limit

FOV = math.radians(87.0)
D = 1.8
LIMITS = VehicleLimits(math.radians(60.0), 2.5, lateral_accel_limited=True)
OFF = UnionParams(lookahead_s=3.0, fov_rad=FOV, sensor_range_m=20.0, perception_delay_s=1.0,
                  control_period_s=0.1)
ON = replace(OFF, seen_speed_limit=True)
PARAMS = GuidanceParams(7.0, D, 4.0, 1.25, 2.0)


def test_off_is_as_before_to_the_bit():
    motion = LIMITS.motion(7.0, 0.0, 0.0)
    assert speed_limit.latency_s(motion, OFF) == 1.0
    assert speed_limit.cruise_cap(OFF, D, motion) == sensed_speed_limit(20.0, D, 2.5, 1.0)
    assert speed_limit.seen_need_m(OFF, D, CELL_M) == D - CELL_M
    # only where the stopping distance exceeds d (7 m/s: 16.8 m; 1 m/s: 1.2 m < 1.8 m)
    assert speed_limit.applies(7.0, motion, OFF, D) and not speed_limit.applies(1.0, motion, OFF, D)


def test_the_latency_counts_the_decision_and_a_jerk_shaped_brake():
    plain = LIMITS.motion(7.0, 0.0, 0.0)
    assert speed_limit.latency_s(plain, ON) == pytest.approx(1.1)
    shaped = VehicleLimits(math.radians(60.0), 2.5, True, max_jerk_mps3=5.0).motion(7.0, 0.0, 0.0)
    assert speed_limit.latency_s(shaped, ON) == pytest.approx(1.1 + 2.5 / 10.0)
    assert speed_limit.applies(0.0, plain, ON, D)          # every command, a stop included


def test_the_cap_stops_d_short_of_where_coverage_ends():
    motion = LIMITS.motion(7.0, 0.0, 0.0)
    cap = speed_limit.cruise_cap(ON, D, motion)
    # reaction at the cap over the latency, then braking at 2.5 m/s^2: d short of the coverage
    assert stopping_distance_m(cap, 1.1, 2.5) == pytest.approx(20.0 - 0.5 * CELL_M - D)
    assert cap < speed_limit.cruise_cap(OFF, D, motion)
    assert 6.8 < cap < 7.0                                   # 7.36 m/s without the key


def seen_corridor() -> SeenSpace:
    """What a camera flying north along east 0 from 40 m south, to here, has seen."""
    seen = SeenSpace(FOV, 20.0)
    for north in np.arange(-40.0, 0.1, 0.5):
        seen.mark(np.array([north, 0.0, 0.0]))
    return seen


def test_slow_into_unseen_space_is_refused_only_with_the_key():
    """10.5 m east of the corridor's middle, about 3 m from its seen edge: at 1.2 m/s the stopping
    distance (1.2 m + 0.29 m) is below d, so without the key the seen-space check does not
    apply; with it the braked path must keep d from space never seen: east it cannot, north
    (along the corridor) it can."""
    seen = seen_corridor()
    here = np.array([0.0, 10.5])
    east_motion = LIMITS.motion(1.2, 0.5 * math.pi, 0.5 * math.pi)
    east = np.array([0.5 * math.pi])
    assert vc._unseen_margin(seen, here, east_motion, east, 1.2, OFF, D) is None
    assert vc._unseen_margin(seen, here, east_motion, east, 1.2, ON, D)[0] < 0.0
    north = vc._unseen_margin(seen, here, LIMITS.motion(1.2, 0.0, 0.0), np.zeros(1), 1.2, ON, D)
    assert north[0] >= 0.0


def test_the_last_resort_brakes_away_from_a_trunk_dead_ahead():
    """Seed 35 at 7 m/s (docs/results/forests.md): 5 m/s north with a mapped trunk 4 m ahead,
    0.3 m to the right, inside the 5 m stopping distance: no command keeps d. The last resort
    braked straight along the velocity (a stop); with the key it takes the candidate whose
    roll-out keeps the most clearance: a brake with a sideways component, to the left."""
    seen = seen_corridor()
    trunk = np.array([[4.0, 0.3]])
    motion = LIMITS.motion(5.0, 0.0, 0.0)

    def decide(union):
        return vc.choose_velocity(np.zeros(3), 0.0, 150.0, 7.0, 0.0, 0, trunk, np.array([D]),
                                  np.array([0]), PARAMS, union, None, motion, None, None, seen)

    old = decide(OFF)
    assert old.mode == "hold" and old.speed_mps == 0.0 and not old.free_course
    new = decide(ON)
    assert new.mode == "hold" and new.free_course
    assert new.yaw_rad == pytest.approx(0.0)                 # the nose held on the trunk
    assert math.sin(new.heading_rad) < 0.0                   # away from it: to the left (west)
    straight = fly_out(np.zeros(2), motion, np.zeros(1), np.zeros(1), 3.0, FOV)
    aside = fly_strafe(np.zeros(2), motion, np.array([new.heading_rad]),
                       np.array([new.speed_mps]), 3.0)
    kept = clearance(aside, trunk, np.array([D]))[0]
    assert kept > clearance(straight, trunk, np.array([D]))[0] + 0.5
    # a trunk off to the side, where a nose-led turn keeps more: that turn, as before
    trunk = np.array([[4.5, 0.6]])
    assert decide(ON).free_course and decide(OFF).speed_mps > 0.0


def test_the_key_is_read_and_checked():
    from companion.config.scenario import load_scenario
    from companion.config.loader import FieldError
    from companion.config.sections import AvoidanceConfig
    forest = load_scenario("config/scenarios/forest.yaml")
    assert forest.avoidance.union_params(FOV).seen_speed_limit is True
    copter = load_scenario("config/scenarios/copter.yaml")
    assert copter.avoidance.union_params(FOV).seen_speed_limit is False
    with pytest.raises(FieldError, match="speed_limit"):
        AvoidanceConfig(safety_distance_m=1.0, horizon_s=4.0, eta=1.25, speed_limit="fast")


def test_the_follower_keeps_turning_toward_the_wide_way_it_chose():
    """Trunks ahead and beside close the leg and its near offsets; wide ways on both sides pass.
    Without the key the first in the fixed order (+60 deg) is taken whatever was chosen before;
    with it the one last chosen (+90 or -90), so a turn in place goes on instead of swinging
    between sides (forest seeds 4 at 7 m/s and 49 at 10 m/s: 60 s in place)."""
    from companion.core.avoidance import path_follow
    from companion.core.avoidance.guidance import GuidanceInputs
    from companion.core.avoidance.path_search import PathParams
    trunks = np.array([[2.6, 0.0], [3.0, 1.5], [3.0, -1.5]])
    for key, previous_deg, expected_deg in [(False, 90.0, 60.0), (False, -90.0, 60.0),
                                            (True, None, 60.0), (True, 90.0, 90.0),
                                            (True, -90.0, -90.0)]:
        union = replace(OFF, path=PathParams(), seen_speed_limit=key)
        previous = None if previous_deg is None else math.radians(previous_deg)
        inputs = GuidanceInputs(np.zeros(3), np.array([60.0, 0.0]), trunks,
                                previous_heading_rad=previous, motion=LIMITS.motion(0.0, 0.0, 0.0))
        command = path_follow._along(inputs.pose, 0.0, 7.0, trunks, np.full(3, D), PARAMS, union,
                                     inputs, 0.3)
        assert command.mode == "path" and command.speed_mps == 0.0     # a turn in place
        assert math.degrees(command.heading_rad) == pytest.approx(expected_deg)


def test_the_follower_leaves_its_first_view_from_rest():
    """Started at rest, the camera has seen one view: the vehicle stands at its apex, about d
    from space never seen behind it. Every roll-out begins in the vehicle's own cell, so none
    keeps the path's hold (0.3 m) beyond d from that space; the follower takes off along the leg
    keeping what the vehicle has here (forest-near at rest, seeds 8, 10, 13, 19: 120 s turning
    in place). A leg out of the view still turns first, and a vehicle short of d still gains."""
    from companion.core.avoidance import path_follow
    from companion.core.avoidance.guidance import GuidanceInputs
    from companion.core.avoidance.path_search import PathParams
    seen = SeenSpace(FOV, 20.0)
    for yaw_deg in (-40.0, 0.0, 40.0):                       # the nose swung, as in those flights
        seen.mark(np.array([0.0, 0.0, math.radians(yaw_deg)]))
    here = float(seen.margin(np.zeros((1, 2)))[0])
    assert D <= here < D + 0.3                               # at the apex: short of the hold
    trunks = np.array([[15.0, 6.0]])
    union = replace(ON, path=PathParams())
    inputs = GuidanceInputs(np.zeros(3), np.array([60.0, 0.0]), trunks,
                            motion=LIMITS.motion(0.0, 0.0, 0.0), seen=seen)
    command = path_follow._along(inputs.pose, 0.0, 7.0, trunks, np.full(1, D), PARAMS, union,
                                 inputs, 0.3)
    assert command is not None and command.mode == "path" and command.speed_mps > 0.0
    assert abs(command.heading_rad) <= math.radians(10.0)
    behind = path_follow._along(inputs.pose, math.pi, 7.0, trunks, np.full(1, D), PARAMS, union,
                                inputs, 0.3)
    assert behind is None or behind.speed_mps == 0.0 or \
        abs(math.remainder(behind.heading_rad - math.pi, 2 * math.pi)) > math.radians(90.0)
    assert path_follow._unseen_room(seen, np.zeros(2), union, D) == pytest.approx(here - D)
    assert path_follow._unseen_room(seen, np.array([-30.0, 0.0]), union, D) == 0.0
    assert path_follow._unseen_room(None, np.zeros(2), union, D) == math.inf


def test_the_steady_follower_rolls_out_half_a_second_before_its_stop():
    """A trunk 5.5 m ahead on the leg (the path bends round it): held a whole second and then
    braked, half of cruise runs 3.75 m and comes within d + 0.3 m of it, so a 1 s roll-out
    crawls at a quarter (dense forest at 5 m/s: 1.25 m/s among trunks 2.9 m apart, time-outs).
    path_steady holds a command half a second, five decision periods: half of cruise passes,
    its stop still keeps d + 0.3 m, and three quarters still does not."""
    from companion.core.avoidance import path_follow
    from companion.core.avoidance.guidance import GuidanceInputs
    from companion.core.avoidance.path_search import STEADY_PATH
    trunks = np.array([[5.5, 0.0]])
    motion = LIMITS.motion(2.5, 0.0, 0.0)
    inputs = GuidanceInputs(np.zeros(3), np.array([60.0, 0.0]), trunks, motion=motion)
    speeds = {}
    for follow_s in (1.0, STEADY_PATH.follow_s):
        union = replace(ON, path=replace(STEADY_PATH, follow_s=follow_s))
        command = path_follow._along(inputs.pose, 0.0, 5.0, trunks, np.full(1, D), PARAMS,
                                     union, inputs, 0.3)
        assert command.mode == "path" and command.heading_rad == 0.0
        speeds[follow_s] = command.speed_mps
        for speed, kept in ((command.speed_mps, True), (command.speed_mps + 1.25, False)):
            rolled = fly_out(np.zeros(2), motion, np.zeros(1), np.full(1, speed), follow_s, FOV)
            assert (clearance(rolled, trunks, np.full(1, D))[0] >= 0.3) == kept
    assert STEADY_PATH.follow_s == 0.5
    assert speeds == {1.0: 1.25, 0.5: 2.5}


def test_the_service_reads_the_key_over_the_shipped_config(tmp_path):
    """A user's one-key layer turns it on for `companion run`, with the setpoint period as the
    control period; a wrong value names the user's file and the key."""
    from companion.config.loader import ConfigError
    from companion.config.service import load_config
    layer = tmp_path / "user.yaml"
    layer.write_text("avoidance:\n  speed_limit: seen\n")
    union = load_config(layer, over="config/companion.yaml").union_params()
    assert union.seen_speed_limit and union.control_period_s == pytest.approx(0.1)
    assert not load_config("config/companion.yaml").union_params().seen_speed_limit
    layer.write_text("avoidance:\n  speed_limit: fast\n")
    with pytest.raises(ConfigError, match="avoidance.speed_limit"):
        load_config(layer, over="config/companion.yaml")
