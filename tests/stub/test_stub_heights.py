"""The stub's 3D world (issue 27): heights and bases on obstacles, walls and buildings; a camera
with a vertical field of view reporting points with their true z (BODY_FRD, z down) and floor
returns; a 2D world's camera unchanged. vz flown and the altitude reported are pinned in
test_stub_copter.py (test_vz_is_a_climb_rate..., test_nav_takeoff...)."""
import dataclasses
import math

import numpy as np
import pytest
import yaml

from sitl_stub import camera
from sitl_stub import telemetry as tm
from sitl_stub.camera_component import CameraComponent
from sitl_stub.sim import Simulation
from sitl_stub.world import UINT16_MAX, ScenarioError, load_scenario, parse_scenario

from .support import PAPER, REPO

LOWWALL = REPO / "config" / "scenarios" / "lowwall.yaml"
GROUND = REPO / "config" / "scenarios" / "ground.yaml"
EXACT = dataclasses.replace(load_scenario(PAPER).sensor, range_sigma_m=0.0, bearing_sigma_rad=0.0)


def with_obstacle(**extra):
    data = yaml.safe_load(PAPER.read_text())
    data["world"]["obstacles"][0].update(extra)
    return data


def test_heights_and_bases_are_read_from_obstacles_walls_and_buildings():
    scenario = load_scenario(LOWWALL)
    assert scenario.world.obstacles[0].height_m == 3.0 and scenario.world.obstacles[0].base_m == 0.0
    assert scenario.reports_z
    data = with_obstacle(height_m=12.0, base_m=5.0)
    data["world"]["walls"] = [{"id": 9, "start": {"north_m": 90, "east_m": -20},
                               "end": {"north_m": 90, "east_m": 20}, "thickness_m": 0.5,
                               "height_m": 4.0}]
    data["sensor"]["form"] = "both"
    scenario = parse_scenario(data, "s.yaml")
    assert (scenario.world.obstacles[0].height_m, scenario.world.obstacles[0].base_m) == (12.0, 5.0)
    assert scenario.world.shapes[0].height_m == 4.0
    paper = load_scenario(PAPER)
    assert not paper.reports_z and paper.world.obstacles[0].height_m is None


@pytest.mark.parametrize("extra, key, problem", [
    ({"height_m": -1.0}, "height_m", "must be > 0"),
    ({"height_m": 2.0, "base_m": 3.0}, "height_m", "must be above base_m (3 m)"),
    ({"height_m": 3.0, "base_m": 3.0}, "height_m", "must be above base_m"),
    ({"base_m": -0.5}, "base_m", "must be >= 0"),
    ({"height_m": float("nan")}, "height_m", "finite"),
    ({"height_m": "tall"}, "height_m", "expected a number"),
])
def test_a_bad_height_names_file_key_and_problem(extra, key, problem):
    with pytest.raises(ScenarioError) as err:
        parse_scenario(with_obstacle(**extra), "bad.yaml")
    text = str(err.value)
    assert text.startswith("bad.yaml: ") and f"world.obstacles[0].{key}" in text and problem in text


def test_a_3d_camera_reports_the_highest_and_lowest_points_within_its_vertical_view():
    tan = math.tan(0.5 * EXACT.vfov_rad)                 # 58 deg: 0.554 per metre of range
    extents = {1: (0.0, 3.0), 2: (0.0, math.inf), 3: (25.0, 40.0), 4: (12.0, 18.0)}
    obstacles = [(1, 20.0, 0.0, 1.0), (2, 30.0, 5.0, 2.0), (3, 10.0, -2.0, 1.0),
                 (4, 35.0, -8.0, 1.0)]
    heights = camera.Heights(10.0, extents, np.random.default_rng(0))
    cfg = dataclasses.replace(EXACT, bearing_sigma_rad=0.0)
    dets = {d.obstacle_id: d for d in camera.observe(0.0, 0.0, 0.0, obstacles, cfg,
                                                     np.random.default_rng(0), heights)}
    # 3 (25-40 m up, 10.2 m away) lies above the view (10 + 5.6 m): not seen
    assert sorted(dets) == [1, 2, 4]
    z_sigma = camera.Z_SIGMA_FLOOR_M
    # a 3 m wall from 10 m: its top 7 m below the camera, its foot 10 m (the ground)
    assert dets[1].top_down_m == pytest.approx(7.0, abs=4 * z_sigma)
    assert dets[1].bottom_down_m == pytest.approx(10.0, abs=4 * z_sigma)
    # an unbounded column: clipped by the view's upper edge, the ground below
    r2 = math.hypot(30.0, 5.0)
    assert dets[2].top_down_m == pytest.approx(-r2 * tan, abs=4 * z_sigma)
    assert dets[2].bottom_down_m == pytest.approx(10.0, abs=4 * z_sigma)
    # an overhang 12-18 m up: its bottom 2 m above the camera, its top 8 m
    assert dets[4].top_down_m == pytest.approx(-8.0, abs=4 * z_sigma)
    assert dets[4].bottom_down_m == pytest.approx(-2.0, abs=4 * z_sigma)


def test_the_3d_camera_draws_its_heights_from_its_own_stream():
    """The horizontal detections of a 3D world's camera are the 2D camera's, draw for draw."""
    sensor = load_scenario(PAPER).sensor
    obstacles = [(1, 20.0, 0.0, 1.0), (2, 30.0, 5.0, 2.0)]
    flat = camera.observe(0.0, 0.0, 0.1, obstacles, sensor, np.random.default_rng(5))
    tall = camera.observe(0.0, 0.0, 0.1, obstacles, sensor, np.random.default_rng(5),
                          camera.Heights(10.0, {}, np.random.default_rng(9)))
    assert [(d.range_m, d.bearing_rad) for d in flat] == [(d.range_m, d.bearing_rad) for d in tall]
    assert all(d.top_down_m is None for d in flat) and all(d.top_down_m is not None for d in tall)


def test_floor_returns_lie_on_the_ground_where_the_view_meets_it():
    sensor = dataclasses.replace(load_scenario(GROUND).sensor, ground_points_per_frame=500)
    points = camera.ground_points(camera.Heights(10.0, {}, np.random.default_rng(2)), sensor)
    assert len(points) == 500
    near = 10.0 / math.tan(0.5 * sensor.vfov_rad)          # 18.0 m from 10 m up
    ranges = np.array([math.hypot(x, y) for x, y, _ in points])
    assert ranges.min() >= near - 1e-9 and ranges.max() <= sensor.max_range_m + 1e-9
    assert all(abs(math.atan2(y, x)) <= sensor.fov_rad / 2 for x, y, _ in points)
    zs = np.array([z for _, _, z in points])
    assert abs(zs.mean() - 10.0) < 0.05 and zs.std() < 0.2      # 10 m below the camera
    assert camera.ground_points(camera.Heights(0.0, {}, np.random.default_rng(2)), sensor) == []
    off = dataclasses.replace(sensor, sees_ground=False)
    assert camera.ground_points(camera.Heights(10.0, {}, np.random.default_rng(2)), off) == []


def test_the_sectors_see_a_low_wall_only_while_it_is_in_the_vertical_view():
    cfg = dataclasses.replace(EXACT, sector_count=9, fov_rad=math.radians(10.0))
    wall = [(20.0, -5.0), (20.5, -5.0), (20.5, 5.0), (20.0, 5.0)]
    rng = np.random.default_rng(0)
    near = camera.ray_cast_sectors_cm(0.0, 0.0, 0.0, [], cfg, rng, [wall],
                                      camera.Heights(10.0, {}, rng), ((0.0, 3.0),))[0]
    assert near[4] == 2000                                  # its top (3 m) within the view at 20 m
    high = camera.ray_cast_sectors_cm(0.0, 0.0, 0.0, [], cfg, rng, [wall],
                                      camera.Heights(20.0, {}, rng), ((0.0, 3.0),))[0]
    assert high[4] == int(round(cfg.max_range_m * 100)) + 1  # 20 m up: below the view's edge
    flat = camera.ray_cast_sectors_cm(0.0, 0.0, 0.0, [], cfg, rng, [wall])[0]
    assert flat[4] == 2000                                  # the 2D camera: as before


def airborne(scenario, altitude_m=10.0, seed=0):
    sim = Simulation(scenario, seed=seed)
    sim.truth = dataclasses.replace(sim.truth, up_m=altitude_m)
    return sim


def test_the_camera_component_sends_two_points_per_obstacle_and_the_floor_without_id():
    data = yaml.safe_load(GROUND.read_text())
    data["world"]["obstacles"] = [{"id": 1, "north_m": 40.0, "east_m": 0.0, "radius_m": 1.0,
                                   "height_m": 4.0}]
    sim = airborne(parse_scenario(data, "g.yaml"))
    out = [msg for _, msg in CameraComponent(sim).periodic(0.0)
           if msg.get_type() == "OBSTACLE_DISTANCE_3D"]
    wall = [m for m in out if m.obstacle_id == 1]
    floor = [m for m in out if m.obstacle_id == UINT16_MAX]
    assert len(wall) == 2 and len(floor) == sim.scenario.sensor.ground_points_per_frame
    assert wall[0].x == wall[1].x and wall[0].y == wall[1].y        # one centre, two heights
    assert wall[0].z == pytest.approx(6.0, abs=0.3) and wall[1].z == pytest.approx(10.0, abs=0.3)
    assert all(m.frame == tm.mavlink.MAV_FRAME_BODY_FRD for m in out)
    assert all(m.z == pytest.approx(10.0, abs=0.5) for m in floor)
    assert len({m.time_boot_ms for m in out}) == 1


def test_a_2d_world_sends_what_it_sent_before():
    sim = airborne(load_scenario(PAPER))
    sim.truth = dataclasses.replace(sim.truth, north_m=50.0)
    out = [msg for _, msg in CameraComponent(sim).periodic(0.0)
           if msg.get_type() == "OBSTACLE_DISTANCE_3D"]
    assert [m.obstacle_id for m in out] == [1] and out[0].z == 0.0      # one point, z 0


def test_the_camera_beside_an_autopilot_reports_z_from_its_altitude_in_a_3d_world():
    from .test_external_camera import attitude, autopilot_heartbeat, heard, origin_at
    from pymavlink.dialects.v20 import ardupilotmega as mavlink
    from sitl_stub.external_camera import ExternalCamera
    scenario = load_scenario(LOWWALL)            # 3 m posts across north 100
    cam = ExternalCamera(scenario, np.random.default_rng(0))
    cam.handle(autopilot_heartbeat(), 0.0)
    cam.handle(origin_at(0.0, 0.0), 0.0)
    out = []
    for t_ms in range(1000, 2000, 100):          # 12 m up at north 75: the wall 25 m ahead
        out += cam.handle(attitude(t_ms), 0.0)
        out += cam.handle(heard(7, 1, mavlink.MAVLink_local_position_ned_message(
            t_ms, 75.0, 0.0, -12.0, 0, 0, 0)), 0.0)
    points = [m for m in out if m.get_type() == "OBSTACLE_DISTANCE_3D" and m.obstacle_id == 8]
    assert len(points) >= 2 and len(points) % 2 == 0
    assert points[0].z == pytest.approx(9.0, abs=0.3) and points[1].z == pytest.approx(12.0, abs=0.3)
