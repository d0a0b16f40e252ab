"""companion simulate flies walls.yaml past a wall and a building by sectors alone; the plot's
safety outline of a shape lies at d from its surface; the service config lets the lifecycle
delete."""
import math

import numpy as np
import pytest

from companion.config.scenario import load_scenario
from companion.config.service import load_config
from companion.core import shapes
from companion.sim.plot import offset_outline, plot_run
from companion.sim.simulation import run_once
from companion.sim.worlds import random_world


def test_simulate_flies_past_the_wall_and_the_building_clear_of_their_surfaces(tmp_path):
    scenario = load_scenario("config/scenarios/walls.yaml")
    outcome = run_once(scenario, seed=0)
    s = outcome.summary
    assert s["reached_goal"] and not s["collided"]
    # every point of the true path 9.5 m or more from the wall and the building (surfaces)
    path = np.array(outcome.trace.true_pose)[:, :2]
    for _, shape in scenario.world.shapes():
        assert shapes.polygon_distance_m(path, shape.corners_ne()).min() >= 9.5
    assert s["min_clearance_m"] >= 9.5
    assert s["landmarks"]["obstacles_seen"] == 3          # the post, the wall, the building
    plot_run(tmp_path / "walls.png", scenario, outcome, "walls")
    assert (tmp_path / "walls.png").stat().st_size > 10_000


def test_the_plotted_safety_outline_is_d_from_the_surface():
    corners = shapes.as_counter_clockwise(np.array([[100.0, -4.0], [112.0, -2.0], [118.0, -12.0],
                                                    [112.0, -22.0], [100.0, -20.0]]))
    ring = offset_outline(corners, 10.0)
    assert np.allclose(shapes.polygon_distance_m(ring, corners), 10.0, atol=1e-9)


def test_urban_worlds_hold_walls_buildings_and_posts_with_room_between_shapes():
    base = load_scenario("config/scenarios/sectors.yaml")
    for seed in range(5):
        world = random_world(base, "urban", seed).world
        assert world.walls and world.buildings and len(world.obstacles) >= 3
        outlines = [shape.corners_ne() for _, shape in world.shapes()]
        for i, a in enumerate(outlines):
            for b in outlines[i + 1:]:
                edge = np.concatenate([a + (np.roll(a, -1, 0) - a) * k / 20 for k in range(20)])
                assert shapes.polygon_distance_m(edge, b).min() >= 2 * 10.0
    assert random_world(base, "urban", 3) == random_world(base, "urban", 3)   # seeded


def test_urban_worlds_need_a_depth_camera():
    from companion.errors import ConfigError
    from companion.config.loader import FieldError
    with pytest.raises((FieldError, ConfigError), match="centres cannot see walls"):
        random_world(load_scenario("config/scenarios/paper.yaml"), "urban", 0)


def test_the_service_config_gives_the_lifecycle_the_camera_view():
    params = load_config("config/companion.yaml").estimator.lifecycle_params()
    assert params.fov_rad == pytest.approx(math.radians(87.0))
    assert params.max_range_m == 40.0
