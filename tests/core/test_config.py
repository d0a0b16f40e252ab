import pytest

from companion.config.scenario import load_scenario
from companion.errors import ConfigError

PAPER = open("config/scenarios/paper.yaml").read()


def write(tmp_path, text):
    path = tmp_path / "site.yaml"
    path.write_text(text)
    return path


def error_for(tmp_path, text):
    path = write(tmp_path, text)
    with pytest.raises(ConfigError) as info:
        load_scenario(path)
    message = str(info.value)
    assert message.startswith(str(path) + ": "), message
    return message


def test_paper_scenario_loads_with_its_values():
    s = load_scenario("config/scenarios/paper.yaml")
    assert (s.world.start.north_m, s.world.goal.north_m) == (20.0, 180.0)
    assert [(o.north_m, o.east_m, o.radius_m) for o in s.world.obstacles] == [(60, 5, 2), (120, 0, 2)]
    assert (s.avoidance.safety_distance_m, s.avoidance.horizon_s, s.avoidance.eta) == (10, 4, 1.25)
    assert s.sensor.fov_deg == 90 and s.noise.speed_sigma_mps == 0.3


def test_unknown_key_is_refused(tmp_path):
    message = error_for(tmp_path, PAPER.replace("horizon_s: 4.0", "horizon_s: 4.0\n  horizn_s: 4.0"))
    assert "avoidance.horizn_s: unknown key" in message


def test_wrong_type_is_refused(tmp_path):
    message = error_for(tmp_path, PAPER.replace("horizon_s: 4.0 ", "horizon_s: ten "))
    assert "avoidance.horizon_s: expected a number, got 'ten'" in message


@pytest.mark.parametrize("old,new,key", [
    ("safety_distance_m: 10.0", "safety_distance_m: 0", "avoidance.safety_distance_m"),
    ("eta: 1.25 ", "eta: 0.9 ", "avoidance.eta"),
    ("range_sigma_m: 0.1 ", "range_sigma_m: 0 ", "sensor.range_sigma_m"),
    ("speed_sigma_mps: 0.3", "speed_sigma_mps: -0.3", "noise.speed_sigma_mps"),
    ("fov_deg: 90.0 ", "fov_deg: 400.0 ", "sensor.fov_deg"),
    ("goal: {north_m: 180.0, east_m: 0.0", "goal: {north_m: 120.5, east_m: 0.0", "world.goal"),
])
def test_impossible_values_are_refused_naming_the_key(tmp_path, old, new, key):
    assert old in PAPER
    message = error_for(tmp_path, PAPER.replace(old, new))
    assert f": {key}" in message


def test_goal_within_safety_distance_is_refused(tmp_path):
    message = error_for(tmp_path, PAPER.replace("goal: {north_m: 180.0", "goal: {north_m: 128.0"))
    assert "world.goal" in message and "safety distance" in message


def test_missing_key_and_bad_yaml(tmp_path):
    assert "vehicle.speed_mps: missing" in error_for(tmp_path, PAPER.replace("speed_mps: 5.0 ", "#speed_mps: 5.0 "))
    assert "not valid YAML" in error_for(tmp_path, "world: [unclosed")
    with pytest.raises(ConfigError, match="cannot read"):
        load_scenario(tmp_path / "absent.yaml")


def test_a_scenarios_yaw_bias_reaches_the_truth_and_the_filter_of_a_multicopter(tmp_path):
    import math

    import yaml
    data = yaml.safe_load(open("config/scenarios/copter.yaml"))
    data["noise"].update(yaw_bias_sigma_deg=1.2, yaw_bias_tau_s=300.0)
    del data["estimator"]            # the filter matched to the noise, the bias included
    s = load_scenario(write(tmp_path, yaml.safe_dump(data)))
    assert (s.noise.yaw_bias_sigma_deg, s.noise.yaw_bias_tau_s) == (1.2, 300.0)
    est = s.estimator_config()
    assert (est.yaw_bias_sigma_deg, est.yaw_bias_tau_s) == (1.2, 300.0)
    options = est.options()
    assert options.yaw_bias_sigma_rad == pytest.approx(math.radians(1.2))
    assert options.yaw_fix_sigma_rad(0.1) > 10 * options.yaw_sigma_rad
    # The paper's unicycle flown on the stub: no compass bias, but its gyro-integrated yaw walks at
    # the heading-change noise (0.02 deg a 0.1 s sample): a bias that walks as fast, 2 b^2 / tau =
    # (0.2 deg/s)^2 x 0.1 s, its velocity in that yaw's frame (issue 31)
    as_copter = load_scenario("config/scenarios/paper.yaml").estimator_config(flown_as="multicopter")
    assert as_copter.yaw_rate_sigma_deg_s == pytest.approx(0.2)
    assert 2 * as_copter.yaw_bias_sigma_deg ** 2 / as_copter.yaw_bias_tau_s \
        == pytest.approx(0.2 ** 2 * 0.1)
    assert as_copter.velocity_frame == "yaw" and est.velocity_frame == "ned"
    data["noise"]["yaw_bias_tau_s"] = 0
    assert "noise.yaw_bias_tau_s" in error_for(tmp_path, yaml.safe_dump(data))
