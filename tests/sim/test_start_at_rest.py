"""Issue 46, trees near the start: `companion simulate` used to start every flight cruising, so a
forest whose trees stand from 8 m of the start could not be flown at 10 m/s by any law (a 1 s
perception delay and braking at 2.5 m/s^2 need ~30 m). A real flight starts from a hover after
take-off: ``vehicle.start_at_rest`` starts the truth at rest, and the speed limit from what has
been seen (speed_limit: seen) then lets it gather speed only as fast as it could stop. (On in
forest.yaml, measured: docs/results/speed-limit.md "Trees near the start".)"""
import dataclasses
from pathlib import Path

import numpy as np
import pytest

from companion.config.scenario import load_scenario
from companion.errors import ConfigError
from companion.sim.simulation import run_once, with_speed
from companion.sim.truth import TruthWorld
from companion.sim.worlds import random_world
from sitl_stub.world import ScenarioError, load_scenario as stub_load_scenario

ROOT = Path(__file__).resolve().parents[2]
FOREST = ROOT / "config" / "scenarios" / "forest.yaml"


def forest(at_rest: bool):
    base = load_scenario(FOREST)
    return dataclasses.replace(base, vehicle=dataclasses.replace(base.vehicle,
                                                                 start_at_rest=at_rest))


def test_the_truth_starts_at_rest_with_the_key():
    assert load_scenario(FOREST).vehicle.start_at_rest is True
    rest = TruthWorld(forest(True), np.random.default_rng(0))
    cruising = TruthWorld(forest(False), np.random.default_rng(0))
    assert rest.speed_mps == 0.0 and not np.any(rest.vel_ne_mps)
    assert cruising.speed_mps == 5.0
    assert cruising.vel_ne_mps == pytest.approx([5.0, 0.0])
    # the paper's scenario keeps its cruising start
    assert load_scenario(ROOT / "config" / "scenarios" / "paper.yaml").vehicle.start_at_rest \
        is False


def test_start_at_rest_must_be_true_or_false_for_the_companion_and_the_stub(tmp_path):
    stub_load_scenario(FOREST)          # the stub's vehicle starts at rest anyway: accepted
    text = FOREST.read_text().replace("start_at_rest: true", "start_at_rest: 3")
    bad = tmp_path / "forest.yaml"
    bad.write_text(text)
    with pytest.raises(ConfigError, match="start_at_rest") as error:
        load_scenario(bad)
    assert "forest.yaml" in str(error.value)
    with pytest.raises(ScenarioError, match="vehicle.start_at_rest: expected true or false"):
        stub_load_scenario(bad)


@pytest.mark.parametrize("seed", [0, 3, 7])
def test_trees_near_the_start_are_met_from_rest_at_10_mps(seed):
    """forest-near (trees from 8 m of the start), 10 m/s, the first 8 s: started cruising, the
    vehicle passes inside 0.95 d of a trunk (seed 3 at 0.27 m); started at rest it keeps 0.95 d,
    the line a success keeps (it keeps d by its estimate: since the kept frames of
    speed_limit.unseen_margins seed 0's truth comes 0.01 m inside d, 1.79 m)."""
    closest = {}
    for at_rest in (False, True):
        world = random_world(with_speed(forest(at_rest), 10.0), "forest-near", seed)
        world = dataclasses.replace(world, mission=dataclasses.replace(world.mission,
                                                                       max_time_s=8.0))
        closest[at_rest] = run_once(world, seed).summary["min_clearance_m"]
    d = world.safety_distance_m
    assert closest[False] < 0.95 * d
    assert closest[True] >= 0.95 * d
