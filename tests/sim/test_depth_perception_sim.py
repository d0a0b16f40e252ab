"""simulate's depth form through the companion's perception: a pitched camera's floor is counted
and never mapped; a post on the line is mapped from the pixels, where it stands."""
import dataclasses

import numpy as np

from companion.config.scenario import load_scenario
from companion.config.world import Obstacle
from companion.sim.simulation import run_once


def _short(path: str, seconds: float, obstacles=None):
    scenario = load_scenario(path)
    world = scenario.world if obstacles is None else dataclasses.replace(scenario.world,
                                                                         obstacles=obstacles)
    return dataclasses.replace(scenario, world=world, mission=dataclasses.replace(
        scenario.mission, max_time_s=seconds))


def test_a_pitched_cameras_floor_is_counted_and_none_of_it_mapped():
    scenario = _short("config/scenarios/depth-pitched.yaml", 3.0, ())   # nothing but the floor
    out = run_once(scenario, 0)
    depth = out.summary["depth"]
    assert depth["frames"] >= 40
    assert depth["floor_points"] > 0.5 * depth["points"]
    assert depth["observations"] == 0
    assert out.summary["landmarks"]["final"] == 0


def test_a_post_ahead_is_mapped_from_the_pixels_where_it_stands():
    post = Obstacle(7, 40.0, 3.0, 1.0)
    scenario = _short("config/scenarios/depth.yaml", 3.0, (post,))
    out = run_once(scenario, 0)
    assert out.summary["depth"]["posts"] > 0
    gaps = np.hypot(*(out.landmarks - np.array([40.0, 3.0])).T)
    assert len(gaps) and gaps.min() < 0.5
