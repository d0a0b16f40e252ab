"""CompanionConfig: the shipped file loads; mistakes name the file, the key and the problem."""
import pytest

from companion.config.service import CompanionConfig, config_to_dict, load_config
from companion.errors import ConfigError

SHIPPED = "config/companion.yaml"


def test_shipped_config_loads_with_documented_identity():
    config = load_config(SHIPPED)
    assert isinstance(config, CompanionConfig)
    assert config.link.component_id == 191
    assert config.avoidance.safety_distance_m == 10.0 and config.goal is None


def write(tmp_path, text):
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    return path


BASE = """
estimator: {speed_sigma_mps: 0.3, heading_change_sigma_deg: 0.02, reference_dt_s: 0.1,
            range_sigma_m: 0.1, bearing_sigma_deg: 0.01}
avoidance: {safety_distance_m: 10.0, horizon_s: 4.0, eta: 1.25}
"""


@pytest.mark.parametrize("extra, key, problem", [
    ("commanding: {setpoint_rate_hz: ten}\n", "commanding.setpoint_rate_hz", "expected a number"),
    ("link: {componentid: 191}\n", "link.componentid", "unknown key"),
    ("link: {component_id: 300}\n", "link.component_id", "an id in [1, 255]"),
    ("failsafe: {safe_action: land}\n", "failsafe.safe_action", "expected one of hold, stop"),
    ("commanding: {cruise_speed_mps: 9.0, max_speed_mps: 8.0}\n", "commanding.cruise_speed_mps",
     "<= max_speed_mps"),
    ("goal: {north_m: 1.0}\n", "goal.east_m", "missing"),
    ("failsafe: {require_camera: 1}\n", "failsafe.require_camera", "expected true or false"),
])
def test_mistakes_name_file_key_and_problem(tmp_path, extra, key, problem):
    path = write(tmp_path, BASE + extra)
    with pytest.raises(ConfigError) as err:
        load_config(path)
    text = str(err.value)
    assert text.startswith(f"{path}: {key}:"), text
    assert problem in text


def test_missing_section_and_unreadable_file(tmp_path):
    path = write(tmp_path, "avoidance: {safety_distance_m: 10.0, horizon_s: 4.0, eta: 1.25}\n")
    with pytest.raises(ConfigError, match=r"bad.yaml: estimator: missing"):
        load_config(path)
    with pytest.raises(ConfigError, match="cannot read"):
        load_config(tmp_path / "nope.yaml")


def test_config_round_trips_through_plain_data(tmp_path):
    import yaml
    config = load_config(SHIPPED)
    path = tmp_path / "copy.yaml"
    path.write_text(yaml.safe_dump(config_to_dict(config)))
    assert load_config(path) == config
