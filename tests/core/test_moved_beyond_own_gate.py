"""estimator.moved_beyond_own_gate: a young landmark is taken to have 'moved' only to a sighting
beyond its own association gate. A sighting in that gate's grey zone (NIS between accept_nis and
new_landmark_nis: 1 % of a consistent filter's sightings) is dropped as ambiguous; off (the
default) it relocated the landmark there, throwing its sightings away for that one point."""
import dataclasses
import math

import numpy as np
import pytest

from companion.config.scenario import load_scenario
from companion.core.estimation.range_noise import with_range_model
from companion.core.estimation.slam_types import Observation
from companion.sim.simulation import make_navigator

TRUNK = np.array([8.0, 0.0])
BEYOND_M = 0.6


def navigator(on: bool):
    base = load_scenario("config/scenarios/forest.yaml")
    estimator = dataclasses.replace(base.estimator, moved_beyond_own_gate=on)
    return make_navigator(dataclasses.replace(base, estimator=estimator))


def frame(nav, *observations):
    for _ in range(2):                        # 5 Hz
        nav.predict(0.0, 0.0, 0.1)
    return nav.observe(list(observations))


def grey_zone_sighting(on: bool):
    """A trunk 8 m ahead seen in 6 frames (confirmed, still on probation), then missed for one
    frame while its neighbour 5 m to the right is seen, then one sighting 0.55 m beyond it in
    range: inside a mover's reach, in the grey zone of the trunk's own gate. The report, the
    sighting's NIS against the trunk, and the landmarks after."""
    nav = navigator(on)
    neighbour = Observation(math.hypot(8.0, 5.0), math.atan2(5.0, 8.0))
    for _ in range(6):
        frame(nav, Observation(8.0, 0.0), neighbour)
    key = nav.estimator.slam.landmark_ids()[0]
    assert not nav.lifecycle.is_tentative(key) and key in nav.probation.young
    frame(nav, neighbour)
    sighting = Observation(8.0 + BEYOND_M, 0.0)
    for _ in range(2):
        nav.predict(0.0, 0.0, 0.1)
    slam, options = nav.estimator.slam, nav.estimator.options
    modelled = with_range_model([sighting], slam.noise.range_sigma_m,
                                options.range_sigma_k_per_m, slam.noise.bearing_sigma_rad)[0]
    nis = float(slam.nis_all(np.array([modelled.range_m, modelled.bearing_rad]),
                             modelled.meas_cov_array())[0][slam.landmark_ids().index(key)])
    report = nav.observe([sighting, neighbour])[0]
    return report.action, nis, slam, key


def test_the_sighting_is_in_the_grey_zone():
    _, nis, slam, _ = grey_zone_sighting(True)
    assert slam.gates.accept_nis < nis < slam.gates.new_landmark_nis


def test_off_it_relocates_the_trunk_onto_the_one_sighting():
    action, _, slam, key = grey_zone_sighting(False)
    assert action == "moved"
    trunk = slam.landmarks()[slam.landmark_ids().index(key)]
    assert np.hypot(*(trunk - [8.0 + BEYOND_M, 0.0])) < 0.01


def test_on_it_is_dropped_and_the_trunk_stays_where_its_sightings_put_it():
    action, _, slam, key = grey_zone_sighting(True)
    assert action == "ambiguous"
    assert len(slam.landmarks()) == 2
    assert np.hypot(*(slam.landmarks()[slam.landmark_ids().index(key)] - TRUNK)) < 0.05


def test_on_a_young_landmark_far_beyond_its_gate_still_moves():
    """A walker's landmark: a sighting 1.5 m on (beyond the new-landmark gate, within a mover's
    reach) relocates it, as before."""
    nav = navigator(True)
    for _ in range(3):
        frame(nav, Observation(8.0, 0.0))
    assert frame(nav, Observation(9.5, 0.0))[0].action == "moved"


def test_the_key_is_read_from_yaml_and_off_by_default():
    assert load_scenario("config/scenarios/forest.yaml").estimator.moved_beyond_own_gate
    assert not load_scenario("config/scenarios/copter.yaml").estimator.moved_beyond_own_gate
