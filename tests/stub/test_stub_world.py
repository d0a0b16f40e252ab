"""Scenario loading: the paper file loads; every error names file, key and problem."""
import math

import pytest
import yaml

from sitl_stub.world import ScenarioError, load_scenario

from .support import PAPER


def test_paper_scenario_loads():
    sc = load_scenario(PAPER)
    assert sc.world.start.north_m == 20.0 and sc.world.start.yaw_rad == 0.0
    assert [o.obstacle_id for o in sc.world.obstacles] == [1, 2]
    assert sc.vehicle.max_turn_rate_rad_s == pytest.approx(math.radians(30.0))
    assert sc.sensor.fov_rad == pytest.approx(math.pi / 2)
    assert sc.sensor.sector_message is False


def _write(tmp_path, mutate):
    data = yaml.safe_load(PAPER.read_text())
    mutate(data)
    path = tmp_path / "bad.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


@pytest.mark.parametrize("mutate, key, problem", [
    (lambda d: d["vehicle"].update(dt_s="ten"), "vehicle.dt_s", "expected a number"),
    (lambda d: d["vehicle"].pop("dt_s"), "vehicle.dt_s", "missing"),
    (lambda d: d["sensor"].update(fov_dge=90), "sensor.fov_dge", "unknown key"),
    (lambda d: d["world"]["obstacles"][0].update(radius_m=-1), "world.obstacles[0].radius_m", "> 0"),
    (lambda d: d["world"]["obstacles"][1].update(id=1), "world.obstacles[1].id", "duplicate"),
    (lambda d: d["sensor"].update(miss_probability=1.5), "sensor.miss_probability", "<= 1"),
    (lambda d: d["sensor"].update(report_ids="yes"), "sensor.report_ids", "true or false"),
    (lambda d: d.update(vehicel={}), "vehicel", "unknown key"),
])
def test_bad_scenario_names_file_key_and_problem(tmp_path, mutate, key, problem):
    path = _write(tmp_path, mutate)
    with pytest.raises(ScenarioError) as err:
        load_scenario(path)
    text = str(err.value)
    assert text.startswith(str(path) + ": ")
    assert key in text and problem in text


def test_moving_obstacles_and_optional_keys(tmp_path):
    def mutate(d):
        d["world"]["obstacles"][0].update(vel_north_mps=-1.0, vel_east_mps=0.5)
        d["sensor"]["sector_message"] = True
        d["estimator"] = {"anything": 1}      # the companion's section: ignored by the stub
    sc = load_scenario(_write(tmp_path, mutate))
    assert sc.world.obstacles[0].position_at(10.0) == (50.0, 10.0)
    assert sc.world.obstacles[1].position_at(10.0) == (120.0, 0.0)
    assert sc.sensor.sector_message is True


def test_unreadable_and_invalid_yaml(tmp_path):
    with pytest.raises(ScenarioError, match="cannot read"):
        load_scenario(tmp_path / "missing.yaml")
    bad = tmp_path / "broken.yaml"
    bad.write_text("world: [1, 2\n")
    with pytest.raises(ScenarioError, match="not valid YAML"):
        load_scenario(bad)
