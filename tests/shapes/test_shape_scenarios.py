"""Walls and buildings in scenario files: both loaders (companion/config/world.py and the stub's own
sitl_stub/world.py) read config/scenarios/walls.yaml alike and refuse the same mistakes with
`file: key: problem`."""
import math

import numpy as np
import pytest

from companion.config.scenario import load_scenario
from companion.errors import ConfigError
from sitl_stub.world import ScenarioError, load_scenario as stub_load_scenario
from tests.shapes.support import BAD_SHAPES, WALLS


def test_both_loaders_read_the_wall_and_the_building():
    s = load_scenario("config/scenarios/walls.yaml")
    (wall,), (building,) = s.world.walls, s.world.buildings
    assert (wall.id, wall.start.east_m, wall.end.east_m, wall.thickness_m) == (10, -25.0, 8.0, 0.4)
    assert building.id == 20 and len(building.corners) == 5
    stub = stub_load_scenario("config/scenarios/walls.yaml")
    kinds = {shape.obstacle_id: (shape.kind, sorted(shape.outline)) for shape in stub.world.shapes}
    assert kinds[10] == ("wall", sorted(map(tuple, wall.corners_ne().tolist())))
    assert kinds[20][0] == "building"
    assert np.allclose(sorted(kinds[20][1]), sorted(map(tuple, building.corners_ne().tolist())))


@pytest.mark.parametrize("old,new,key,problem", BAD_SHAPES)
def test_both_loaders_refuse_a_bad_shape_naming_file_and_key(tmp_path, old, new, key, problem):
    path = tmp_path / "site.yaml"
    path.write_text(WALLS.replace(old, new))
    with pytest.raises(ConfigError) as companion_error:
        load_scenario(path)
    with pytest.raises(ScenarioError) as stub_error:
        stub_load_scenario(path)
    for message in (str(companion_error.value), str(stub_error.value)):
        assert message.startswith(f"{path}: {key}"), message
        assert problem in message, message


def test_the_goal_within_the_safety_distance_of_a_wall_is_refused(tmp_path):
    path = tmp_path / "site.yaml"
    # the goal (180, 0) 8 m past a wall's face: inside the 10 m safety distance
    path.write_text(WALLS.replace("start: {north_m: 65.0, east_m: -25.0}, end: {north_m: 65.0",
                                  "start: {north_m: 172.0, east_m: -25.0}, end: {north_m: 172.0"))
    with pytest.raises(ConfigError, match="world.goal: .*safety distance .* wall 10"):
        load_scenario(path)


def test_the_centres_form_is_refused_with_shapes_but_both_is_read(tmp_path):
    path = tmp_path / "site.yaml"
    path.write_text(WALLS.replace("  form: sectors", "  form: both"))
    assert load_scenario(path).sensor.form == "both"
    assert stub_load_scenario(path).sensor.form == "both"
    assert math.isfinite(load_scenario(path).world.walls[0].thickness_m)
