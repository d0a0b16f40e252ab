"""avoidance.keep_tracks_horizon_s (issue 46 item 4): a multicopter's coasting mover track is kept
past its coast, whatever the camera's range, while its predicted closest approach to the vehicle
(flying on, or stopped) comes within d inside the horizon (movers.approaching). overtaking-7 seed
40 was hit from behind by a mover whose track was dropped once its prediction left the camera's
40 m range (docs/results/movers.md)."""
import math

import numpy as np
import pytest

from companion.config.scenario import load_scenario
from companion.core.avoidance.arc import VehicleLimits
from companion.core.avoidance.guidance import GuidanceParams
from companion.core.avoidance.union import UnionParams
from companion.core.estimation.movers import MoverParams, MoverState, approaching
from companion.core.estimation.slam_types import AssociationGates, SlamNoise
from companion.core.navigation.navigator import Navigator
from companion.errors import ConfigError

NOISE = SlamNoise(0.3, math.radians(0.02), 0.1, 0.1, math.radians(0.01))
COPTER = VehicleLimits(math.radians(30.0), 2.5, lateral_accel_limited=True)
UNICYCLE = VehicleLimits(math.radians(30.0), 2.5)
COAST_S = 30.0
HORIZON_S = 10.0


def navigator(horizon_s, limits=COPTER, keep_near=True) -> Navigator:
    """At the origin, nose north (camera 90 deg, 40 m), at rest; d = 10 m."""
    params = GuidanceParams(cruise_speed_mps=5.0, safety_distance_m=10.0, horizon_s=4.0, eta=1.25,
                            goal_radius_m=2.0)
    union = UnionParams(fov_rad=math.radians(90.0), sensor_range_m=40.0,
                        keep_near_tracks=keep_near, keep_tracks_horizon_s=horizon_s)
    return Navigator(np.zeros(3), np.eye(3) * 1e-8, NOISE, AssociationGates(), params,
                     np.array([150.0, 0.0]), "union", union, MoverParams(coast_s=COAST_S),
                     limits=limits)


def coasted(nav: Navigator, predicted_ne_m, velocity_ne_mps) -> bool:
    """A track that will be predicted at ``predicted_ne_m`` when its coast (plus a second) is
    over, never seen again; after one empty frame then, whether the navigator still has it."""
    velocity = np.array(velocity_ne_mps, dtype=float)
    start = np.array(predicted_ne_m, dtype=float) - (COAST_S + 1.0) * velocity
    track = nav.movers.create(0.0, start, np.eye(2) * 0.1, None, (velocity, 0.05))
    nav.predict(0.0, 0.0, COAST_S + 1.0)
    nav.observe([])
    return track in {s.track_id for s in nav.movers.states(nav.clock_s)}


CLOSING_FROM_BEHIND = ((-60.0, 3.0), (7.0, 0.0))     # beyond the range, 8.6 s from 3 m


def test_a_track_closing_from_beyond_the_range_is_kept_with_the_key():
    assert coasted(navigator(HORIZON_S), *CLOSING_FROM_BEHIND)


def test_without_the_key_the_range_drops_it():
    assert not coasted(navigator(None), *CLOSING_FROM_BEHIND)


@pytest.mark.parametrize("predicted, velocity, why", [
    ((-60.0, 3.0), (-7.0, 0.0), "going away"),
    ((-60.0, 45.0), (7.0, 0.0), "passing 45 m to the side"),
    ((-120.0, 3.0), (7.0, 0.0), "meeting in 17 s, beyond the horizon"),
])
def test_a_track_that_cannot_meet_the_vehicle_inside_the_horizon_is_dropped(predicted, velocity,
                                                                              why):
    assert not coasted(navigator(HORIZON_S), predicted, velocity), why


def test_only_a_multicopters_tracks_are_kept():
    assert not coasted(navigator(HORIZON_S, limits=UNICYCLE), *CLOSING_FROM_BEHIND)


def test_the_key_works_without_keep_near_tracks():
    assert coasted(navigator(HORIZON_S, keep_near=False), *CLOSING_FROM_BEHIND)


def track(position, velocity, sigma_m=0.1) -> MoverState:
    return MoverState(1, None, np.array(position, dtype=float), np.array(velocity, dtype=float),
                      np.eye(2) * sigma_m ** 2)


def test_a_mover_paced_behind_counts_for_the_vehicle_stopping():
    # the vehicle flies on at the mover's speed: never closer; stopped: met in 10 s
    paced = track((-50.0, 0.0), (5.0, 0.0))
    assert approaching(paced, np.zeros(2), np.array([5.0, 0.0]), 10.0, 10.0)
    assert not approaching(paced, np.zeros(2), np.array([5.0, 0.0]), 7.0, 10.0)   # 15 m at 7 s


def test_a_still_mover_ahead_counts_for_the_vehicle_flying_on():
    still = track((45.0, 5.0), (0.0, 0.0))
    assert approaching(still, np.zeros(2), np.array([5.0, 0.0]), 10.0, 10.0)
    assert not approaching(still, np.zeros(2), np.zeros(2), 10.0, 10.0)


def test_the_spread_widens_the_reach_up_to_its_cap():
    far_side = ((-30.0, 18.0), (7.0, 0.0))            # passes 18 m aside: d 10 + 2 sigma
    assert not approaching(track(*far_side, sigma_m=1.0), np.zeros(2), np.zeros(2), 10.0, 10.0)
    assert approaching(track(*far_side, sigma_m=8.0), np.zeros(2), np.zeros(2), 10.0, 10.0)
    assert not approaching(track(*far_side, sigma_m=8.0), np.zeros(2), np.zeros(2), 10.0, 10.0,
                           max_spread_m=5.0)


def test_the_3cam_scenario_turns_it_on_and_copter_yaml_leaves_it_off():
    rig, one = load_scenario("config/scenarios/copter-3cam.yaml"), \
        load_scenario("config/scenarios/copter.yaml")
    assert rig.avoidance.union_params().keep_tracks_horizon_s == 10.0
    assert one.avoidance.union_params().keep_tracks_horizon_s is None


@pytest.mark.parametrize("bad", ["0.0", "-1", "61"])
def test_a_value_out_of_bounds_names_file_key_and_problem(tmp_path, bad):
    text = open("config/scenarios/copter-3cam.yaml").read()
    path = tmp_path / "bad.yaml"
    path.write_text(text.replace("keep_tracks_horizon_s: 10.0", f"keep_tracks_horizon_s: {bad}"))
    with pytest.raises(ConfigError) as info:
        load_scenario(path)
    assert str(info.value).startswith(f"{path}: avoidance.keep_tracks_horizon_s: ")
    assert "(0, 60]" in str(info.value)
