"""sensor.cameras in the centres form (issue 46 item 4): a rig of cameras that differ by yaw only.
The truth sees by any camera, the lifecycle expects a landmark seen by any camera, the seen space
marks each camera's view; one forward camera stays exactly as it was; mounts the centres form
cannot honour are refused naming file, key and problem."""
import math

import numpy as np
import pytest

from companion.config.scenario import load_scenario
from companion.core.avoidance.seen_space import SeenSpace
from companion.core.estimation.lifecycle import LifecycleParams, expected_visible
from companion.core.geometry import is_visible, view_offset_rad, view_offsets_rad
from companion.errors import ConfigError
from companion.sim.simulation import make_navigator
from companion.sim.truth import TruthWorld

FOV = math.radians(90.0)
RIG = (0.0, math.radians(90.0), math.radians(-90.0))
COPTER_YAML = open("config/scenarios/copter.yaml").read()
RIG_YAML = open("config/scenarios/copter-3cam.yaml").read()


@pytest.mark.parametrize("bearing_deg, one, three", [
    (0.0, True, True), (44.0, True, True), (-44.0, True, True),
    (60.0, False, True), (-120.0, False, True), (134.0, False, True),
    (150.0, False, False), (180.0, False, False),
])
def test_a_rig_sees_by_any_camera(bearing_deg, one, three):
    bearing = math.radians(bearing_deg)
    assert is_visible(20.0, bearing, FOV, 40.0) is one
    assert is_visible(20.0, bearing, FOV, 40.0, RIG) is three
    assert not is_visible(41.0, bearing, FOV, 40.0, RIG)


def test_one_forward_camera_is_the_bearing_itself():
    bearings = np.linspace(-3.0, 3.0, 13)
    assert np.array_equal(view_offsets_rad(bearings), np.abs(bearings))
    assert view_offset_rad(-0.3) == 0.3
    assert view_offset_rad(math.radians(100.0), RIG) == pytest.approx(math.radians(10.0))


def test_the_lifecycle_expects_a_landmark_beside_the_vehicle_only_with_the_rig():
    points = np.array([[0.0, 20.0], [20.0, 0.0], [-20.0, 0.0]])   # right, ahead, behind
    one = expected_visible(np.zeros(3), points, LifecycleParams(fov_rad=FOV, max_range_m=40.0))
    rig = expected_visible(np.zeros(3), points, LifecycleParams(fov_rad=FOV, max_range_m=40.0,
                                                                view_yaws_rad=RIG))
    assert one.tolist() == [False, True, False]
    assert rig.tolist() == [True, True, False]


def test_the_seen_space_marks_each_cameras_view():
    seen = SeenSpace(FOV, 40.0)
    for yaw in RIG:
        seen.mark(np.array([0.0, 0.0, yaw]))
    one = SeenSpace(FOV, 40.0)
    one.mark(np.zeros(3))
    side, behind = np.array([[0.0, 25.0]]), np.array([[-25.0, 0.0]])
    assert seen.margin(side)[0] > one.margin(side)[0]
    assert seen.margin(behind)[0] < 10.0


def write(tmp_path, text):
    path = tmp_path / "rig.yaml"
    path.write_text(text)
    return path


def test_the_3cam_scenario_loads_its_rig_and_copter_yaml_keeps_one_camera():
    rig, one = load_scenario("config/scenarios/copter-3cam.yaml"), \
        load_scenario("config/scenarios/copter.yaml")
    assert rig.sensor.view_yaws_deg == (0.0, 90.0, -90.0)
    assert one.sensor.view_yaws_deg == (0.0,)
    nav = make_navigator(rig)
    assert nav.decider.union.view_yaws_rad == pytest.approx(RIG)
    assert nav.lifecycle.params.view_yaws_rad == pytest.approx(RIG)
    assert make_navigator(one).decider.union.view_yaws_rad == (0.0,)


def test_the_truth_sees_a_post_beside_the_vehicle_with_the_rig_only(tmp_path):
    post = "    - {id: 9, north_m: 20.0, east_m: 25.0, radius_m: 1.0}\n"
    seen = {}
    for name, text in (("one", COPTER_YAML), ("rig", RIG_YAML)):
        text = text.replace("  obstacles:                                                  # (paper)\n",
                            "  obstacles:\n" + post, 1)
        truth = TruthWorld(load_scenario(write(tmp_path, text)), np.random.default_rng(0))
        seen[name] = {o.obstacle_id for o in truth.observe()}
    assert 9 not in seen["one"] and 9 in seen["rig"]


@pytest.mark.parametrize("mount, key", [
    ("{yaw_deg: 90.0, pitch_deg: -10.0}", "pitch_deg"),
    ("{yaw_deg: 90.0, roll_deg: 5.0}", "roll_deg"),
    ("{yaw_deg: 90.0, offset_frd_m: [0.1, 0.0, 0.0]}", "offset_frd_m"),
])
def test_a_mount_the_centres_form_cannot_honour_is_refused(tmp_path, mount, key):
    text = RIG_YAML.replace("    - {yaw_deg: 90.0} ", f"    - {mount} ", 1)
    path = write(tmp_path, text)
    with pytest.raises(ConfigError) as info:
        load_scenario(path)
    message = str(info.value)
    assert message.startswith(f"{path}: sensor.cameras: ") and key in message


def test_the_sectors_form_refuses_cameras(tmp_path):
    path = write(tmp_path, RIG_YAML.replace("  cameras:", "  form: sectors\n  cameras:", 1))
    with pytest.raises(ConfigError) as info:
        load_scenario(path)
    assert "sensor.cameras" in str(info.value) and "'sectors'" in str(info.value)
