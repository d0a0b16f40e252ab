"""Flights in 3D in-process (companion simulate's loop): over a low wall, around a tall tower,
around a wall under an altitude ceiling, and the paper's leg with a camera that sees the floor."""
import dataclasses
import math

import numpy as np
import pytest

from companion.config.scenario import load_scenario
from companion.config.world import Obstacle
from companion.core.estimation.slam_types import Observation
from companion.sim.simulation import make_navigator, run_once

PAPER = load_scenario("config/scenarios/paper.yaml")


def wall_scenario(height_m: float, vertical: bool = True, **avoidance) -> object:
    """The paper's leg (20 -> 180 m north) with a wall of posts 4 m apart, 60 m long, at 100 m."""
    posts = tuple(Obstacle(i + 1, 100.0, float(e), 1.0, height_m=height_m)
                  for i, e in enumerate(np.arange(-30.0, 30.1, 4.0)))
    world = dataclasses.replace(PAPER.world, obstacles=posts)
    return dataclasses.replace(
        PAPER, world=world, mission=dataclasses.replace(PAPER.mission, max_time_s=200.0),
        avoidance=dataclasses.replace(PAPER.avoidance, vertical=vertical, mission_time_s=200.0,
                                      **avoidance))


@pytest.mark.parametrize("seed", [0, 1])
def test_over_a_3m_wall_and_back_down(seed):
    run = run_once(wall_scenario(3.0), seed).summary
    up = run["vertical"]
    assert run["reached_goal"] and not run["collided"]
    assert run["min_clearance_m"] >= 0.95 * 10.0               # d in 3D
    assert up["max_altitude_m"] >= 3.0 + 10.0                  # it climbed over
    assert up["max_altitude_m"] <= 3.0 + 10.0 + 3.0            # ... by no more than it needed
    assert abs(up["final_altitude_m"] - 10.0) < 1.0            # and came back down
    assert run["path_length_m"] < 170.0                        # straight on (160 m)


def test_around_a_40m_tower():
    tower = dataclasses.replace(PAPER.world.obstacles[1], height_m=40.0)
    world = dataclasses.replace(PAPER.world, obstacles=(PAPER.world.obstacles[0], tower))
    scenario = dataclasses.replace(PAPER, world=world, avoidance=dataclasses.replace(
        PAPER.avoidance, vertical=True))
    run = run_once(scenario, 0).summary
    assert run["reached_goal"] and run["min_clearance_m"] >= 9.5
    assert run["vertical"]["max_altitude_m"] < 10.5            # no climb: around


def test_a_ceiling_below_the_walls_top_goes_around():
    run = run_once(wall_scenario(3.0, max_altitude_m=12.0), 0).summary
    assert run["reached_goal"] and run["min_clearance_m"] >= 9.5
    assert run["vertical"]["max_altitude_m"] <= 12.0 + 0.5
    assert run["path_length_m"] > 175.0                         # round the wall's end


def test_vertical_off_flies_round_the_same_wall():
    off = run_once(wall_scenario(3.0, vertical=False), 0).summary
    on = run_once(wall_scenario(3.0), 0).summary
    assert off["reached_goal"] and off["vertical"]["max_altitude_m"] == 10.0
    assert on["vertical"]["path_3d_m"] < 0.9 * off["vertical"]["path_3d_m"]


def test_a_camera_that_sees_the_floor_flies_the_paper_leg_as_without():
    seeing = dataclasses.replace(PAPER, sensor=dataclasses.replace(PAPER.sensor, sees_ground=True))
    for seed in (0, 1):
        plain, ground = run_once(PAPER, seed).summary, run_once(seeing, seed).summary
        points = ground.pop("vertical")["points"]
        assert points["ground"] > 100 and points["bad_z"] == 0
        assert ground == plain                                  # same flight, bit for bit
        assert ground["landmarks"]["final"] == 2


def test_the_floor_maps_nothing_even_with_ids_off():
    sensor = dataclasses.replace(PAPER.sensor, sees_ground=True, report_ids=False)
    run = run_once(dataclasses.replace(PAPER, sensor=sensor), 0).summary
    assert run["reached_goal"] and run["landmarks"]["final"] == 2
    assert run["vertical"]["points"]["ground"] > 100


def test_points_with_a_bad_z_are_refused_and_counted():
    nav = make_navigator(PAPER)
    nav.on_altitude(10.0)
    nav.observe([Observation(30.0, 0.1, 5, top_down_m=math.nan, bottom_down_m=10.0),
                 Observation(30.0, -0.1, 6, top_down_m=10.0, bottom_down_m=10.0),
                 Observation(30.0, 0.3, 7, top_down_m=5.0, bottom_down_m=10.0)])
    assert nav.points == {"ground": 1, "bad_z": 1}
    assert nav.slam.landmark_ids() == [7]
    assert math.isclose(nav.extents[7].top_m, 5.0)
