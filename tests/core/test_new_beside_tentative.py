"""estimator.new_beside_tentative: a sighting only in the gate's grey zone of a tentative
landmark starts a landmark (on), or is dropped as ambiguous (off, the default)."""
import dataclasses

import pytest

from companion.config.scenario import load_scenario
from companion.core.estimation.slam_types import Observation
from companion.sim.simulation import make_navigator


def _second_sighting(on: bool, beyond_m: float):
    base = load_scenario("config/scenarios/forest.yaml")
    estimator = dataclasses.replace(base.estimator, new_beside_tentative=on)
    nav = make_navigator(dataclasses.replace(base, estimator=estimator))
    assert nav.observe([Observation(18.0, 0.0)])[0].action == "added"
    for _ in range(20):                  # 2 s later: too long ago for a young mover's 'moved'
        nav.predict(0.0, 0.0, 0.1)
    report = nav.observe([Observation(18.0 + beyond_m, 0.0)])[0]
    return report.action, nav.estimator.slam.landmarks()


def test_off_a_grey_zone_sighting_of_a_tentative_landmark_is_dropped():
    action, landmarks = _second_sighting(False, 3.0)
    assert action == "ambiguous" and len(landmarks) == 1


def test_on_it_starts_a_landmark_where_it_was_seen():
    action, landmarks = _second_sighting(True, 3.0)
    assert action == "added" and len(landmarks) == 2
    assert abs(landmarks[1][0] - 21.0) < 0.05


@pytest.mark.parametrize("on", [False, True])
def test_a_sighting_within_the_gate_updates_either_way(on):
    action, landmarks = _second_sighting(on, 1.0)
    assert action == "updated" and len(landmarks) == 1


def test_the_key_is_read_from_yaml():
    assert load_scenario("config/scenarios/forest.yaml").estimator.new_beside_tentative
    assert not load_scenario("config/scenarios/copter.yaml").estimator.new_beside_tentative
