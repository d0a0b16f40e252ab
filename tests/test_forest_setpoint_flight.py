"""A forest flight that passed a trunk well inside d when the velocity setpoint, after a stop
and turn with the nose apart, set off from the last setpoint's direction instead of from where
the vehicle flew (guidance.shape_setpoint's ``course_now_rad``)."""
import pytest

from companion.config.scenario import load_scenario
from companion.sim import simulation
from companion.sim.simulation import run_once, with_speed
from companion.sim.worlds import random_world

SCENARIO = "config/scenarios/forest.yaml"


@pytest.mark.slow
def test_forest_dense_7_seed_12_keeps_its_distance_from_the_trunks():
    # before: a time-out after passing trunk 647 at 0.95 m (d 1.8 m) at 118.7 s
    scenario = random_world(with_speed(load_scenario(SCENARIO), 7.0), "forest-dense", 12)
    d = scenario.safety_distance_m
    assert d == pytest.approx(1.8)
    outcome = run_once(scenario, 12)
    assert not outcome.summary["collided"]
    assert outcome.summary["min_clearance_m"] >= 0.95 * d


@pytest.mark.slow
def test_without_the_velocity_s_direction_the_old_pass_comes_back(monkeypatch):
    """The same flight with the setpoint turned from the last setpoint's direction (the rule
    before): the pass inside 0.95 d, so the test above measures the rule, not the world."""
    real = simulation.shape_setpoint

    def old_rule(*args, course_now_rad=None, **kwargs):
        return real(*args, **kwargs)

    monkeypatch.setattr(simulation, "shape_setpoint", old_rule)
    scenario = random_world(with_speed(load_scenario(SCENARIO), 7.0), "forest-dense", 12)
    outcome = run_once(scenario, 12)
    assert outcome.summary["min_clearance_m"] < 0.95 * scenario.safety_distance_m
