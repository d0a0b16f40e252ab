"""The stub's centres camera as a rig (sensor.cameras by yaw, issue 46 item 4; its own parser and
geometry, not companion's): copter-3cam.yaml loads, a post beside the vehicle is seen by the side
camera only with the rig, and a mount the centres form cannot honour is refused."""
import math

import numpy as np
import pytest

from sitl_stub.camera import in_view, observe
from sitl_stub.world import ScenarioError, load_scenario

RIG = "config/scenarios/copter-3cam.yaml"


def test_the_rig_loads_with_its_three_yaws():
    cfg = load_scenario(RIG).sensor
    assert [round(math.degrees(m.yaw_rad)) for m in cfg.cameras] == [0, 90, -90]
    assert load_scenario("config/scenarios/copter.yaml").sensor.cameras == ()


@pytest.mark.parametrize("bearing_deg, one, rig", [(0.0, True, True), (80.0, False, True),
                                                   (-130.0, False, True), (170.0, False, False)])
def test_in_view_by_any_camera(bearing_deg, one, rig):
    with_rig = load_scenario(RIG).sensor
    without = load_scenario("config/scenarios/copter.yaml").sensor
    bearing = math.radians(bearing_deg)
    assert in_view(20.0, bearing, without) is one
    assert in_view(20.0, bearing, with_rig) is rig
    assert not in_view(41.0, bearing, with_rig)


def test_detect_reports_a_post_beside_the_vehicle_with_the_rig():
    cfg = load_scenario(RIG).sensor
    posts = [(9, 0.0, 25.0, 1.0)]
    seen = observe(0.0, 0.0, 0.0, posts, cfg, np.random.default_rng(0))
    assert [d.obstacle_id for d in seen] == [9]
    assert math.degrees(seen[0].bearing_rad) == pytest.approx(90.0, abs=0.5)


def test_a_pitched_mount_in_the_centres_form_is_refused(tmp_path):
    text = open(RIG).read().replace("    - {yaw_deg: 90.0} ", "    - {yaw_deg: 90.0, pitch_deg: -5} ", 1)
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    with pytest.raises(ScenarioError) as info:
        load_scenario(str(path))
    assert "sensor.cameras[1]" in str(info.value) and "yaw_deg only" in str(info.value)
