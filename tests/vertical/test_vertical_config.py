"""Heights in scenario files: clear errors naming the file, the key and the problem."""
import pytest

from companion.config.scenario import load_scenario
from companion.errors import ConfigError

PAPER = open("config/scenarios/paper.yaml").read()
POST = "- {id: 2, north_m: 120.0, east_m: 0.0, radius_m: 2.0}"


def error_for(tmp_path, text):
    path = tmp_path / "site.yaml"
    path.write_text(text)
    with pytest.raises(ConfigError) as info:
        load_scenario(path)
    message = str(info.value)
    assert message.startswith(f"{path}: "), message
    return message


def test_heights_load():
    assert POST in PAPER


@pytest.mark.parametrize("extra,key,problem", [
    ("height_m: -3.0", "world.obstacles[1].height_m", "a height > 0 m"),
    ("height_m: 0.0", "world.obstacles[1].height_m", "a height > 0 m"),
    ("height_m: 4.0, base_m: 6.0", "world.obstacles[1].height_m", "above the obstacle's base_m"),
    ("height_m: .nan", "world.obstacles[1].height_m", "a finite number"),
    ("height_m: .inf", "world.obstacles[1].height_m", "a finite number"),
    ("base_m: -1.0", "world.obstacles[1].base_m", "a height >= 0 m"),
    ("height_m: 'tall'", "world.obstacles[1].height_m", "expected a number"),
])
def test_bad_heights_are_refused(tmp_path, extra, key, problem):
    message = error_for(tmp_path, PAPER.replace(POST, POST[:-1] + f", {extra}}}"))
    assert f": {key}: " in message and problem in message, message


def test_a_wall_with_a_height_below_its_base_is_refused(tmp_path):
    walls = PAPER.replace("sensor:", "sensor:\n  form: sectors", 1).replace(
        "  obstacles:", "  walls:\n    - {id: 7, start: {north_m: 90.0, east_m: -20.0}, end: "
        "{north_m: 90.0, east_m: -10.0}, thickness_m: 0.5, height_m: 2.0, base_m: 3.0}\n"
        "  obstacles:", 1)
    message = error_for(tmp_path, walls)
    assert ": world.walls[0].height_m: " in message and "base_m" in message


def test_sensor_and_avoidance_keys(tmp_path):
    assert "vertical field of view" in error_for(
        tmp_path, PAPER.replace("fov_deg: 90.0 ", "fov_deg: 90.0\n  vfov_deg: 0.0\n  #"))
    message = error_for(tmp_path, PAPER.replace("eta: 1.25 ", "eta: 1.25\n  max_altitude_m: 1.0\n  #"))
    assert ": avoidance.max_altitude_m: " in message and "min_altitude_m" in message
    message = error_for(tmp_path, PAPER.replace("sensor:", "perception: {ground_margin_m: -0.5}\nsensor:"))
    assert ": perception.ground_margin_m: " in message
    message = error_for(tmp_path, PAPER.replace("sensor:", "sensor:\n  form: sectors", 1).replace(
        "eta: 1.25 ", "eta: 1.25\n  vertical: true\n  #"))
    assert ": avoidance.vertical: " in message and "centres" in message


def test_a_scenario_with_heights_loads(tmp_path):
    path = tmp_path / "ok.yaml"
    path.write_text(PAPER.replace(POST, POST[:-1] + ", height_m: 8.0, base_m: 2.0}").replace(
        "eta: 1.25 ", "eta: 1.25\n  vertical: true\n  #"))
    s = load_scenario(path)
    assert (s.world.obstacles[1].height_m, s.world.obstacles[1].base_m) == (8.0, 2.0)
    assert s.world.obstacles[0].height_m is None and s.avoidance.vertical is True
    assert s.sensor.vfov_deg == 58.0 and s.world.start.alt_m == 10.0
