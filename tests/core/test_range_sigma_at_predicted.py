"""estimator.range_sigma_at: 'predicted' (EkfSlam.set_range_model): an update evaluates the stereo
range sigma (floor + k r^2) at the landmark's predicted range, not at the sighting's measured one.
R at the measured range gives a sighting measured short more weight than one measured long, and
maps a trunk short (core/estimation/range_noise.py); at the predicted range it does not."""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
import yaml

from companion.config.scenario import load_scenario
from companion.core.estimation.ekf_slam import EkfSlam
from companion.core.estimation.range_noise import stereo_range_sigma_m, with_range_model
from companion.core.estimation.slam_types import AssociationGates, Observation, SlamNoise
from companion.errors import ConfigError
from tests.core.test_ekf_update_paths import correlated_filter, predicted

FLOOR_M, K_PER_M, BEARING_SIGMA_RAD = 0.01, 0.0015, math.radians(1.0)
NOISE = SlamNoise(0.3, math.radians(0.02), 0.1, FLOOR_M, BEARING_SIGMA_RAD)
FOREST = "config/scenarios/forest.yaml"


def modelled(obs: Observation) -> Observation:
    return with_range_model([obs], FLOOR_M, K_PER_M, BEARING_SIGMA_RAD)[0]


def test_the_model_marks_what_it_gave_an_r_and_keeps_an_observations_own():
    own = Observation(12.0, 0.1, None, meas_cov=((0.04, 0.0), (0.0, 1e-4)))
    plain, kept = with_range_model([Observation(12.0, 0.1), own], FLOOR_M, K_PER_M,
                                   BEARING_SIGMA_RAD)
    assert plain.range_modelled and plain.meas_cov[0][0] == pytest.approx(
        stereo_range_sigma_m(12.0, FLOOR_M, K_PER_M) ** 2)
    assert kept is own and not kept.range_modelled


def test_the_update_takes_the_range_sigma_at_the_predicted_range():
    slam = EkfSlam(np.zeros(3), np.diag([1e-4, 1e-4, 1e-6]), NOISE,
                   AssociationGates(outlier_nis=1e12, pose_correction_nis=1e12))
    slam.update(Observation(20.0, 0.0, 7, meas_cov=((0.01, 0.0), (0.0, BEARING_SIGMA_RAD ** 2))))
    slam.set_range_model(FLOOR_M, K_PER_M)
    d = slam.mean[3:5] - slam.mean[:2]
    predicted_m = float(np.hypot(*d))
    obs = modelled(Observation(18.0, 0.0, 7))                 # measured 2 m short
    h = np.zeros((2, 5))
    h[0, [0, 1, 3, 4]] = [-d[0] / predicted_m, -d[1] / predicted_m,
                          d[0] / predicted_m, d[1] / predicted_m]
    q = predicted_m ** 2
    h[1, [0, 1, 2, 3, 4]] = [d[1] / q, -d[0] / q, -1.0, -d[1] / q, d[0] / q]
    at_predicted = stereo_range_sigma_m(predicted_m, FLOOR_M, K_PER_M) ** 2
    s = h @ slam.cov @ h.T + np.diag([at_predicted, BEARING_SIGMA_RAD ** 2])
    v = np.array([18.0 - predicted_m, math.remainder(-math.atan2(d[1], d[0]) + slam.mean[2],
                                                      2 * math.pi)])
    report = slam.update(obs)
    assert report.nis == pytest.approx(float(v @ np.linalg.solve(s, v)), rel=1e-9)
    # at the measured 18 m the sigma would have been 19% smaller, the NIS 40% larger
    assert at_predicted > 1.3 * obs.meas_cov[0][0]


def test_the_id_path_and_the_associated_path_agree_to_the_bit():
    """_update_known (the id hot path) writes out _innovation's arithmetic: with the range model
    too (tests/core/test_ekf_update_paths.py checks the rest)."""
    for landmark_only in (False, True):
        first, rng = correlated_filter()
        first.set_range_model(FLOOR_M, K_PER_M)
        second = first.copy()
        obs = modelled(Observation(*predicted(first, 11, rng), 11))
        one = first.update(obs, landmark_only=landmark_only)
        two = second.update_landmark(np.array([obs.range_m, obs.bearing_rad]), 11,
                                     landmark_only, obs.meas_cov_array(), range_modelled=True)
        assert one.nis == two.nis
        assert np.array_equal(first.mean, second.mean)
        assert np.array_equal(first.cov, second.cov)


def test_without_the_model_a_modelled_r_is_used_as_given():
    first, rng = correlated_filter()
    second = first.copy()
    obs = modelled(Observation(*predicted(first, 5, rng), 5))
    first.update(obs)
    second.update(dataclasses.replace(obs, range_modelled=False))
    assert np.array_equal(first.mean, second.mean)
    assert np.array_equal(first.cov, second.cov)


def mapped_range_error_m(at_predicted: bool, sightings: int = 3000, true_range_m: float = 20.0,
                         seed: int = 3) -> float:
    """A trunk 20 m ahead of a vehicle held still and known, sighted ``sightings`` times with
    the stereo noise (0.61 m at 20 m): the mapped range minus the true one."""
    rng = np.random.default_rng(seed)
    slam = EkfSlam(np.zeros(3), np.diag([1e-12, 1e-12, 1e-14]), NOISE,
                   AssociationGates(outlier_nis=1e12, pose_correction_nis=1e12))
    if at_predicted:
        slam.set_range_model(FLOOR_M, K_PER_M)
    sigma = stereo_range_sigma_m(true_range_m, FLOOR_M, K_PER_M)
    for _ in range(sightings):
        slam.update(modelled(Observation(true_range_m + rng.normal(0.0, sigma),
                                         rng.normal(0.0, BEARING_SIGMA_RAD), 1)))
    return float(np.hypot(*slam.landmarks()[0])) - true_range_m


def test_r_at_the_measured_range_maps_a_trunk_short_and_at_the_predicted_one_it_does_not():
    # weights ~ r^-4 pull the mean short by about 4 sigma^2 / r = 7.4 cm; the standard error of
    # 3000 sightings is 1.1 cm, and both ways see the same noise (seed 3), so their difference
    # is the bias alone
    measured, at_predicted = mapped_range_error_m(False), mapped_range_error_m(True)
    assert abs(at_predicted) < 0.035
    assert measured - at_predicted == pytest.approx(-4 * 0.61 ** 2 / 20.0, abs=0.015)


def test_forest_yaml_takes_the_predicted_range_and_a_bad_value_names_the_file_and_key(tmp_path):
    assert load_scenario(FOREST).estimator_config().options().range_sigma_at_predicted
    data = yaml.safe_load(open(FOREST))
    data["estimator"]["range_sigma_at"] = "true"
    path = tmp_path / "bad.yaml"
    path.write_text(yaml.safe_dump(data))
    with pytest.raises(ConfigError) as err:
        load_scenario(path)
    assert str(err.value).startswith(f"{path}: estimator.range_sigma_at: ")
    assert "expected one of measured, predicted, got 'true'" in str(err.value)


@pytest.mark.slow
def test_the_pose_stays_consistent_in_the_dense_forest():
    """Four seeded forest-dense flights at 3 m/s (800 trees per ha, 20 trunks a frame), as
    forest.yaml flies them: the pose NEES averaged over the runs stays near its 3 dof and in
    its 95% band on most steps. With R at the measured range the same flights gave a mean of
    5.3, rising from 2 to 10-17 over each flight (docs/forest.md)."""
    from companion.sim.simulation import aggregate, run_once, with_speed
    from companion.sim.worlds import random_world

    base = with_speed(load_scenario(FOREST), 3.0)
    outcomes = [run_once(random_world(base, "forest-dense", seed), seed) for seed in range(4)]
    nees = aggregate(outcomes, base.safety_distance_m)["nees"]
    assert nees["mean"] < 3.6 and nees["in_band_fraction"] >= 0.7, nees


@pytest.mark.parametrize("at_predicted, k_per_m, expected", [
    (True, K_PER_M, (FLOOR_M, K_PER_M)),
    (True, 0.0, None),                 # a constant R: nothing to evaluate again
    (False, K_PER_M, None),
])
def test_the_estimator_sets_the_model_only_when_asked_and_the_range_model_is_on(
        at_predicted, k_per_m, expected):
    from companion.core.estimation.estimator import Estimator
    from companion.core.estimator_options import EstimatorOptions

    options = EstimatorOptions(range_sigma_k_per_m=k_per_m, range_sigma_at_predicted=at_predicted)
    estimator = Estimator(np.zeros(3), np.eye(3) * 1e-4, NOISE, AssociationGates(), options)
    assert estimator.slam._range_model == expected
