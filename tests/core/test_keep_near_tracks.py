"""avoidance.keep_near_tracks (issue 33): a multicopter's coasting mover track, predicted within the
camera's range but outside its view, outlives its coast (movers.prune's ``keep``) only with the key
on; the key reaches UnionParams from a scenario and from the service's config, and a malformed
value names the file, the key and the problem."""
import math

import numpy as np
import pytest

from companion.config.scenario import load_scenario
from companion.config.service import load_config
from companion.core.avoidance.arc import VehicleLimits
from companion.core.avoidance.guidance import GuidanceParams
from companion.core.avoidance.union import UnionParams
from companion.core.estimation.movers import MoverParams
from companion.core.estimation.slam_types import AssociationGates, SlamNoise
from companion.core.navigation.navigator import Navigator
from companion.errors import ConfigError

NOISE = SlamNoise(0.3, math.radians(0.02), 0.1, 0.1, math.radians(0.01))
COPTER = VehicleLimits(math.radians(30.0), 2.5, lateral_accel_limited=True)
UNICYCLE = VehicleLimits(math.radians(30.0), 2.5)
COAST_S = 30.0
RANGE_M = 40.0


def navigator(keep: bool, limits: VehicleLimits = COPTER, evade: bool = False) -> Navigator:
    """At the origin, nose north (camera 90 deg, 40 m), at rest."""
    params = GuidanceParams(cruise_speed_mps=5.0, safety_distance_m=10.0, horizon_s=4.0, eta=1.25,
                            goal_radius_m=2.0)
    union = UnionParams(fov_rad=math.radians(90.0), sensor_range_m=RANGE_M,
                        keep_near_tracks=keep, evade_movers=evade)
    return Navigator(np.zeros(3), np.eye(3) * 1e-8, NOISE, AssociationGates(), params,
                     np.array([150.0, 0.0]), "union", union, MoverParams(coast_s=COAST_S),
                     limits=limits)


def coasted(nav: Navigator, start_ne_m, velocity_ne_mps) -> bool:
    """A track started at t = 0 and never seen again; after its coast (plus a second) and one
    empty camera frame, whether the navigator still has it."""
    track = nav.movers.create(0.0, np.array(start_ne_m, dtype=float), np.eye(2) * 0.1, None,
                              (np.array(velocity_ne_mps, dtype=float), 0.2))
    nav.predict(0.0, 0.0, COAST_S + 1.0)                   # at rest: the pose stays at the origin
    nav.observe([])
    return track in {s.track_id for s in nav.movers.states(nav.clock_s)}


# started 50 m behind (out of range), coming up at 1 m/s: predicted 19 m behind, 5 m left
BEHIND = ((-50.0, -5.0), (1.0, 0.0))


def test_a_track_predicted_near_and_out_of_view_is_kept_with_the_key_on():
    assert coasted(navigator(keep=True), *BEHIND)


def test_the_same_track_is_dropped_with_the_key_off():
    assert not coasted(navigator(keep=False), *BEHIND)


@pytest.mark.parametrize("start, velocity, where", [
    ((20.0, 2.0), (0.0, 0.0), "ahead, in view: it could have been seen there"),
    ((-80.0, 0.0), (0.0, 0.0), "behind but beyond the camera's range"),
    ((-5.0, 30.0), (0.0, 1.0), "predicted 61 m to the right, beyond range"),
])
def test_with_the_key_on_a_track_that_could_be_seen_or_is_far_is_dropped(start, velocity, where):
    assert not coasted(navigator(keep=True), start, velocity), where


def test_the_key_keeps_only_a_multicopters_tracks():
    # a unicycle's flights stay as they were (navigator.observe: lateral_accel_limited)
    assert not coasted(navigator(keep=True, limits=UNICYCLE), *BEHIND)


def test_the_evasion_keeps_them_too():
    # evade_movers implies the keep (its side-steps leave movers beside the vehicle)
    assert coasted(navigator(keep=False, evade=True), *BEHIND)


# ------------------------------------------------------------------ config
COPTER_YAML = open("config/scenarios/copter.yaml").read()
PAPER_YAML = open("config/scenarios/paper.yaml").read()
SERVICE_YAML = open("config/companion.yaml").read()
SERVICE_LINE = "  keep_near_tracks: false"


def write(tmp_path, text, name="site.yaml"):
    path = tmp_path / name
    path.write_text(text)
    return path


def test_copter_yaml_turns_it_on_and_paper_yaml_leaves_it_off():
    copter, paper = load_scenario("config/scenarios/copter.yaml"), \
        load_scenario("config/scenarios/paper.yaml")
    assert copter.avoidance.union_params(copter.sensor.fov_rad).keep_near_tracks is True
    assert paper.avoidance.union_params(paper.sensor.fov_rad).keep_near_tracks is False


@pytest.mark.parametrize("value", [True, False])
def test_the_scenario_key_reaches_union_params(tmp_path, value):
    text = COPTER_YAML.replace("keep_near_tracks: true", f"keep_near_tracks: {str(value).lower()}")
    scenario = load_scenario(write(tmp_path, text))
    assert scenario.avoidance.keep_near_tracks is value
    assert scenario.avoidance.union_params(scenario.sensor.fov_rad).keep_near_tracks is value


@pytest.mark.parametrize("value", [True, False])
def test_the_service_key_reaches_union_params(tmp_path, value):
    assert SERVICE_LINE in SERVICE_YAML
    text = SERVICE_YAML.replace(SERVICE_LINE, f"  keep_near_tracks: {str(value).lower()}")
    assert load_config(write(tmp_path, text, "companion.yaml")).union_params() \
        .keep_near_tracks is value


@pytest.mark.parametrize("load, text, old", [
    (load_scenario, COPTER_YAML, "keep_near_tracks: true"),
    (load_config, SERVICE_YAML, SERVICE_LINE.strip()),
])
@pytest.mark.parametrize("bad, shown", [("yes please", "'yes please'"), ("1", "1")])
def test_a_malformed_value_names_file_key_and_problem(tmp_path, load, text, old, bad, shown):
    assert old in text
    path = write(tmp_path, text.replace(old, f"keep_near_tracks: {bad}"))
    with pytest.raises(ConfigError) as info:
        load(path)
    assert str(info.value) == \
        f"{path}: avoidance.keep_near_tracks: expected true or false, got {shown}"
