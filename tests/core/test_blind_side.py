"""core/avoidance/blind_side.py (issue 46 item 4): the bearing a meeting mover holds, the widest
one over its courses, the vehicle speed from which a view sees them all, and the cruise cap from
which a mover met head-on at the camera's range can be dodged; the cap reaches the velocity
choice from avoidance.mover_max_speed_mps."""
import math

import numpy as np
import pytest

from companion.config.scenario import load_scenario
from companion.core.avoidance.blind_side import (dodge_speed_cap_mps, dodge_time_s,
                                                 meeting_bearing_rad, seeing_speed_mps,
                                                 widest_meeting_bearing_rad)
from companion.errors import ConfigError

H90 = math.radians(45.0)      # one 90 deg camera's half view


def meets(vehicle_mps, mover_mps, course_rad, bearing_rad, range_m=50.0):
    """Place the mover at ``bearing_rad``, ``range_m`` and fly both straight: the miss (m)."""
    mover = range_m * np.array([math.cos(bearing_rad), math.sin(bearing_rad)])
    rel = mover_mps * np.array([math.cos(course_rad), math.sin(course_rad)]) \
        - np.array([vehicle_mps, 0.0])
    t_s = -float(mover @ rel) / float(rel @ rel)
    return float(np.hypot(*(mover + t_s * rel)))


@pytest.mark.parametrize("v, u, course_deg", [(5.0, 7.0, -90.0), (5.0, 7.0, -100.0),
                                              (5.0, 3.0, -120.0), (10.0, 7.0, 170.0)])
def test_a_mover_placed_on_its_meeting_bearing_meets_the_vehicle(v, u, course_deg):
    course = math.radians(course_deg)
    assert meets(v, u, course, meeting_bearing_rad(v, u, course)) < 1e-6
    assert meets(v, u, course, meeting_bearing_rad(v, u, course) + 0.05) > 1.0


def test_a_square_7_mps_crosser_is_out_of_one_cameras_view_at_5_mps():
    # crossing-7's collisions: 54.5 deg off the course, beyond the 45 deg half view
    bearing = meeting_bearing_rad(5.0, 7.0, math.radians(-90.0))
    assert math.degrees(bearing) == pytest.approx(54.46, abs=0.01)
    assert bearing > H90


def test_the_widest_bearing_is_reached_over_the_courses():
    courses = np.radians(np.linspace(-180.0, 180.0, 7201))
    for v, u in ((5.0, 3.0), (10.0, 7.0)):
        widest = max(abs(meeting_bearing_rad(v, u, c)) for c in courses)
        assert widest == pytest.approx(widest_meeting_bearing_rad(v, u), abs=1e-3)
    assert widest_meeting_bearing_rad(5.0, 7.0) == math.pi


def test_the_seeing_speed_sees_every_meeting_and_slower_does_not():
    v = seeing_speed_mps(7.0, H90)
    assert v == pytest.approx(9.899, abs=1e-3)
    assert widest_meeting_bearing_rad(v, 7.0) <= H90 + 1e-12
    assert widest_meeting_bearing_rad(0.9 * v, 7.0) > H90
    assert widest_meeting_bearing_rad(5.0, 7.0) > H90           # slowing down widens it
    assert seeing_speed_mps(7.0, math.radians(135.0)) > 7.0     # three cameras: faster than it
    assert seeing_speed_mps(7.0, math.pi) == 0.0


def test_the_dodge_cap_gives_the_time_to_move_d_aside_from_first_sight():
    t = dodge_time_s(10.0, 2.5, 1.1)
    assert t == pytest.approx(1.1 + math.sqrt(8.0))
    cap = dodge_speed_cap_mps(40.0, 10.0, 2.5, 1.1, 7.0)
    assert cap == pytest.approx(40.0 / t - 7.0)
    assert cap == pytest.approx(3.18, abs=0.01)
    # from first sight at the range, closing at cap + 7, the meeting is the dodge time away
    assert 40.0 / (cap + 7.0) == pytest.approx(t)
    assert dodge_speed_cap_mps(40.0, 10.0, 2.5, 1.1, 12.0) == 0.0


def test_the_key_caps_the_velocity_choices_cruise(tmp_path):
    from companion.sim.simulation import make_navigator
    text = open("config/scenarios/copter-3cam.yaml").read()
    path = tmp_path / "cap.yaml"
    path.write_text(text.replace("  keep_tracks_horizon_s: 10.0",
                                 "  mover_max_speed_mps: 7.0\n  keep_tracks_horizon_s: 10.0", 1))
    capped, free = make_navigator(load_scenario(path)), \
        make_navigator(load_scenario("config/scenarios/copter-3cam.yaml"))
    assert capped.decider.union.mover_max_speed_mps == 7.0
    assert free.decider.union.mover_max_speed_mps is None
    for nav in (capped, free):
        nav.on_velocity(0.0, 5.0, 0.0, 0.0, 0.0)
        nav.observe([])
    command, _ = capped.decide(0.1)
    # copter.yaml's latency is its perception delay, 5 frames at 5 Hz (no speed_limit key)
    assert command.speed_mps == pytest.approx(40.0 / (1.0 + math.sqrt(8.0)) - 7.0)
    assert free.decide(0.1)[0].speed_mps == pytest.approx(5.0)


def test_a_bad_value_names_file_key_and_problem(tmp_path):
    text = open("config/scenarios/copter-3cam.yaml").read()
    path = tmp_path / "bad.yaml"
    path.write_text(text.replace("  keep_tracks_horizon_s: 10.0",
                                 "  mover_max_speed_mps: 0.0\n  keep_tracks_horizon_s: 10.0", 1))
    with pytest.raises(ConfigError) as info:
        load_scenario(path)
    assert str(info.value).startswith(f"{path}: avoidance.mover_max_speed_mps: ")
