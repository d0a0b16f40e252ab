"""Issue 15 item 4: a stereo camera's range noise, sigma_r = floor + k r^2, in both cameras, and the
filter's own range model, configured apart from the truth's."""
import dataclasses
import math

import numpy as np
import pytest

from companion.config.scenario import load_scenario
from companion.config.service import load_config
from companion.config.world import Obstacle
from companion.core.estimation.slam_types import Observation
from companion.core.estimation.range_noise import stereo_k_per_m, stereo_range_sigma_m, with_range_model
from companion.errors import ConfigError
from companion.sim.simulation import make_navigator
from companion.sim.truth import TruthWorld
from sitl_stub import camera
from sitl_stub.world import ScenarioError
from sitl_stub.world import load_scenario as stub_load_scenario

REALISTIC = "config/scenarios/realistic.yaml"
SAMPLES = 4000
# The sample standard deviation of n normal draws has a relative standard error of about
# 1 / sqrt(2 (n - 1)); five of those bound it (a false failure about once in 3 million runs).
STD_BOUND = 5.0 / math.sqrt(2.0 * (SAMPLES - 1))


def assert_std(errors, sigma):
    errors = np.asarray(errors, dtype=float)
    assert len(errors) == SAMPLES
    assert abs(errors.mean()) < 5.0 * sigma / math.sqrt(SAMPLES)          # unbiased
    assert abs(errors.std(ddof=1) / sigma - 1.0) < STD_BOUND


def realistic(obstacles):
    scenario = load_scenario(REALISTIC)
    world = dataclasses.replace(scenario.world, obstacles=tuple(
        Obstacle(i + 1, north, east, 1.0) for i, (north, east) in enumerate(obstacles)))
    return dataclasses.replace(scenario, world=world)


def test_the_camera_figures_give_the_scenario_k():
    # A RealSense D455 (realistic.yaml): 0.1 px of disparity, f = 640 / tan(43.5 deg), B = 95 mm.
    k = stereo_k_per_m(0.1, 640.0 / math.tan(math.radians(43.5)), 0.095)
    assert k == pytest.approx(0.00156, rel=0.01)
    assert load_scenario(REALISTIC).sensor.range_sigma_k_per_m == pytest.approx(k, rel=0.05)
    assert stereo_range_sigma_m(40.0, 0.01, 0.0015) == pytest.approx(2.41)


def test_simulate_camera_range_noise_grows_with_the_square_of_the_range():
    # The vehicle starts at (20, 0) looking north: posts 10, 20 and 35 m ahead.
    scenario = realistic([(30.0, -1.0), (40.0, 1.0), (55.0, 0.0)])
    truth = TruthWorld(scenario, np.random.default_rng(1))
    true = {oid: (math.hypot(n - 20.0, e), math.atan2(e, n - 20.0))
            for oid, (n, e) in zip((1, 2, 3), [(30.0, -1.0), (40.0, 1.0), (55.0, 0.0)])}
    errors = {oid: ([], []) for oid in true}
    report_ids = dataclasses.replace(scenario.sensor, report_ids=True)
    truth.scenario = dataclasses.replace(scenario, sensor=report_ids)
    for _ in range(SAMPLES):
        for obs in truth.observe():
            r, b = true[obs.obstacle_id]
            errors[obs.obstacle_id][0].append(obs.range_m - r)
            errors[obs.obstacle_id][1].append(obs.bearing_rad - b)
    sensor = scenario.sensor
    for oid, (r, _) in true.items():
        assert_std(errors[oid][0], sensor.range_sigma_m + sensor.range_sigma_k_per_m * r * r)
        assert_std(errors[oid][1], math.radians(1.0))
    # 35 m against 10 m: (0.01 + 0.0015 x 1225) / (0.01 + 0.15) = 11.5 times the error
    assert np.std(errors[3][0]) > 8.0 * np.std(errors[1][0])


def test_simulate_depth_sectors_carry_the_same_range_noise():
    scenario = realistic([(45.0, 0.0)])              # a post 25 m ahead, 1 m radius
    truth = TruthWorld(scenario, np.random.default_rng(2))
    ranges = np.array([truth.observe_sectors()[0] for _ in range(SAMPLES)])
    bearings = truth.observe_sectors()[1]
    centre = int(np.argmin(np.abs(bearings)))
    surface = 25.0 - math.sqrt(1.0 - (25.0 * math.sin(bearings[centre])) ** 2)
    assert_std(ranges[:, centre] - surface, scenario.sensor.range_sigma_at(surface))


def test_stub_camera_range_noise_grows_with_the_square_of_the_range():
    cfg = stub_load_scenario(REALISTIC).sensor
    assert cfg.range_sigma_k_per_m == 0.0015 and cfg.range_sigma_m == 0.01
    cfg = dataclasses.replace(cfg, report_ids=True)
    rng = np.random.default_rng(3)
    posts = [(1, 10.0, 0.5, 1.0), (2, 30.0, -0.5, 1.0)]
    errors = {1: [], 2: []}
    for _ in range(SAMPLES):
        for det in camera.observe(0.0, 0.0, 0.0, posts, cfg, rng):
            errors[det.obstacle_id].append(det.range_m - math.hypot(*posts[det.obstacle_id - 1][1:3]))
    for oid, (_, north, east, _) in zip((1, 2), posts):
        assert_std(errors[oid], cfg.range_sigma_at(math.hypot(north, east)))
    # The depth camera's own sectors: the bin straight ahead of a post 30 m away.
    cfg = dataclasses.replace(cfg, sector_count=71)
    ahead = [camera.ray_cast_sectors_cm(0.0, 0.0, 0.0, [(1, 31.0, 0.0, 1.0)], cfg, rng)[0][35]
             for _ in range(SAMPLES)]
    assert_std(np.array(ahead) / 100.0 - 30.0, cfg.range_sigma_at(30.0))


@pytest.mark.parametrize("section", ["sensor", "estimator"])
@pytest.mark.parametrize("value, problem", [("-0.001", "a coefficient in [0, 1.0]"),
                                            ("2.0", "a coefficient in [0, 1.0]"),
                                            ("fast", "expected a number")])
def test_a_bad_k_names_the_file_and_the_key(tmp_path, section, value, problem):
    text = open(REALISTIC).read()
    old = "range_sigma_k_per_m: 0.0015  # (source"
    assert text.count(old) == 1
    if section == "sensor":
        text = text.replace(old, old.replace("0.0015", value))
    else:
        text += ("estimator:\n  motion_model: velocity_ned\n  range_sigma_m: 0.01\n"
                 f"  bearing_sigma_deg: 1.0\n  range_sigma_k_per_m: {value}\n")
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    with pytest.raises(ConfigError) as info:
        load_scenario(path)
    assert str(info.value).startswith(f"{path}: {section}.range_sigma_k_per_m: ")
    assert problem in str(info.value)
    if section == "sensor":                       # the stub reads the sensor with its own parser
        with pytest.raises(ScenarioError, match=f"{path}: sensor.range_sigma_k_per_m: "):
            stub_load_scenario(path)


def test_service_and_existing_scenarios_keep_a_constant_range_sigma():
    assert load_config("config/companion.yaml").estimator.range_sigma_k_per_m == 0.0
    for name in ("paper", "paper-anonymous", "cluttered", "copter", "sectors"):
        scenario = load_scenario(f"config/scenarios/{name}.yaml")
        assert scenario.sensor.range_sigma_k_per_m == 0.0
        assert scenario.estimator_config().options().range_sigma_k_per_m == 0.0
    plain = [Observation(30.0, 0.1, None)]
    assert with_range_model(plain, 0.1, 0.0, 0.01) == plain


def test_an_observation_with_its_own_r_keeps_it():
    blob = Observation(30.0, 0.1, None, ((0.5, 0.0), (0.0, 1e-4)))
    bare = Observation(20.0, -0.1, None)
    kept, built = with_range_model([blob, bare], 0.01, 0.0015, math.radians(1.0))
    assert kept is blob
    assert np.allclose(built.meas_cov, [[0.61 ** 2, 0.0], [0.0, math.radians(1.0) ** 2]])


def test_the_update_takes_r_from_the_filters_model_not_the_truths():
    # The truth's camera is twice as noisy as the filter believes: a new landmark straight ahead
    # at 30 m starts with the filter's sigma_r along the line of sight, floor + k_filter r^2.
    scenario = realistic([])
    truth_sensor = dataclasses.replace(scenario.sensor, range_sigma_k_per_m=0.003)
    est = dataclasses.replace(scenario.estimator_config(), range_sigma_m=0.05, range_sigma_k_per_m=0.001)
    nav = make_navigator(dataclasses.replace(scenario, sensor=truth_sensor, estimator=est))
    nav.observe([Observation(30.0, 0.0, None)])
    cov = nav.slam.landmark_covs()[0]
    along = cov[0, 0] - nav.slam.pose_cov[0, 0]            # north: the line of sight
    assert along == pytest.approx((0.05 + 0.001 * 900.0) ** 2, rel=1e-3)
    across = cov[1, 1] - nav.slam.pose_cov[1, 1]
    assert across == pytest.approx((30.0 * math.radians(1.0)) ** 2, rel=1e-2)


def test_the_scenario_s_mismatch_template_loads_as_the_filter_s_own_r(tmp_path):
    # realistic.yaml ends with a commented estimator section for a mismatch study: uncommented,
    # it loads, and the filter believes the paper's constant 0.1 m while the camera is stereo.
    lines = open(REALISTIC).read().splitlines()
    start = lines.index("# estimator:")
    block = [line[2:] for line in lines[start:] if line.startswith("# ")]
    path = tmp_path / "mismatch.yaml"
    path.write_text("\n".join(lines[:start] + block) + "\n")
    scenario = load_scenario(path)
    assert scenario.sensor.range_sigma_k_per_m == 0.0015
    est = scenario.estimator_config()
    assert (est.range_sigma_m, est.range_sigma_k_per_m, est.motion_model) == (0.1, 0.0, "velocity_ned")
    nav = make_navigator(scenario)
    nav.observe([Observation(30.0, 0.0, None)])
    along = nav.slam.landmark_covs()[0][0, 0] - nav.slam.pose_cov[0, 0]
    assert along == pytest.approx(0.1 ** 2, rel=1e-3)
