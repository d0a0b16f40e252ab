"""avoidance.safety_distance_rest_m / safety_full_speed_mps: a safety distance d that grows with
the cruise speed (issue 28, forest.yaml), used by the guidance, the worlds and the scoring alike;
without the two keys d is safety_distance_m at every speed, as before."""
import json
import subprocess
import sys

import pytest
import yaml

from companion.config.scenario import load_scenario
from companion.config.sections import AvoidanceConfig
from companion.errors import ConfigError
from companion.sim.aggregate import aggregate_summaries
from companion.sim.simulation import with_speed

FOREST = "config/scenarios/forest.yaml"


def law(**keys) -> AvoidanceConfig:
    return AvoidanceConfig(safety_distance_m=1.5, horizon_s=4.0, eta=1.25, **keys)


def test_d_is_linear_in_the_cruise_speed_up_to_the_full_speed_then_flat():
    avoidance = law(safety_distance_rest_m=0.75, safety_full_speed_mps=5.0)   # 0.15 s a m/s
    assert avoidance.safety_distance_at(0.0) == pytest.approx(0.75)
    assert avoidance.safety_distance_at(3.0) == pytest.approx(1.2)
    assert avoidance.safety_distance_at(4.0) == pytest.approx(1.35)
    assert avoidance.safety_distance_at(5.0) == pytest.approx(1.5)
    assert avoidance.safety_distance_at(10.0) == pytest.approx(1.5)


def test_without_the_law_d_is_the_same_at_every_speed():
    avoidance = law()
    assert {avoidance.safety_distance_at(v) for v in (0.0, 1.0, 3.0, 10.0, 50.0)} == {1.5}


def test_the_scenario_flies_and_scores_the_d_of_its_cruise_speed():
    base = load_scenario(FOREST)
    for speed, d in ((3.0, 1.2), (5.0, 1.5), (7.0, 1.8), (10.0, 1.8)):
        scenario = with_speed(base, speed)
        assert scenario.safety_distance_m == pytest.approx(d)
        assert scenario.guidance_params().safety_distance_m == pytest.approx(d)
        assert scenario.avoidance.safety_distance_m == 1.8      # the file's key is untouched


def test_a_flight_between_0_95_d_of_its_speed_and_of_the_fastest_counts_only_at_the_slow_speed():
    summary = {"reached_goal": True, "min_clearance_m": 1.3, "min_surface_clearance_m": 1.0,
               "collided": False, "final_position_error_m": 0.2, "path_length_m": 200.0}
    slow = with_speed(load_scenario(FOREST), 3.0).safety_distance_m
    fast = with_speed(load_scenario(FOREST), 10.0).safety_distance_m
    assert aggregate_summaries([summary], [[3.0]], slow)["success_rate"] == 1.0
    assert aggregate_summaries([summary], [[3.0]], fast)["success_rate"] == 0.0


@pytest.mark.parametrize("keys, key, problem", [
    ({"safety_distance_rest_m": 1.0}, "safety_distance_rest_m", "safety_full_speed_mps"),
    ({"safety_full_speed_mps": 5.0}, "safety_full_speed_mps", "safety_distance_rest_m"),
    ({"safety_distance_rest_m": 2.0, "safety_full_speed_mps": 5.0}, "safety_distance_rest_m",
     "(0, safety_distance_m = 1.8]"),
    ({"safety_distance_rest_m": 1.0, "safety_full_speed_mps": 0.0}, "safety_full_speed_mps",
     "a value > 0"),
])
def test_a_malformed_law_names_the_file_the_key_and_the_problem(tmp_path, keys, key, problem):
    data = yaml.safe_load(open(FOREST))
    for name in ("safety_distance_rest_m", "safety_full_speed_mps"):
        data["avoidance"].pop(name)
    data["avoidance"].update(keys)
    path = tmp_path / "law.yaml"
    path.write_text(yaml.safe_dump(data))
    with pytest.raises(ConfigError) as err:
        load_scenario(path)
    assert str(err.value).startswith(f"{path}: avoidance.{key}: ")
    assert problem in str(err.value)


def test_simulate_reports_the_d_it_scored_against(tmp_path):
    out = tmp_path / "one.json"
    scenario = tmp_path / "short.yaml"
    # forest.yaml's own world (one tree on a 200 m line) over a shorter leg: a quick flight
    scenario.write_text(open(FOREST).read().replace("north_m: 200.0", "north_m: 40.0")
                        .replace("north_m: 100.0", "north_m: 20.0"))
    done = subprocess.run([sys.executable, "-m", "companion", "simulate", "--scenario", str(scenario),
                           "--speed-mps", "3", "--jobs", "1", "--json", str(out)],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert json.loads(out.read_text())["aggregate"]["safety_distance_m"] == pytest.approx(1.2)
    assert "d = 1.20 m" in done.stdout
