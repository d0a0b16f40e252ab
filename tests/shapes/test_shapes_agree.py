"""The stub and companion simulate see the same walls and buildings, each through its own code:
the depth frames ray-cast from the same true poses agree to the stub's centimetre, and so do the
surface distances; a wall seen by sectors becomes a chain of landmarks that blocks the way."""
import dataclasses
import math

import numpy as np
import pytest

from companion.config.scenario import load_scenario
from companion.config.world import Point, Wall
from companion.core.perception.blobs import BlobParams, blob_observations
from companion.core.avoidance.union import blocking
from companion.sim.truth import TruthWorld
from sitl_stub import camera as stub_camera
from sitl_stub import shapes as stub_shapes
from sitl_stub.world import load_scenario as stub_load_scenario

POSES = [(40.0, 0.0, 0.0), (90.0, 10.0, math.radians(-120.0)), (95.0, -30.0, math.radians(60.0)),
         (130.0, 5.0, math.radians(200.0)), (64.0, 15.0, math.radians(-100.0))]


def companion_truth(scenario, pose):
    exact = dataclasses.replace(scenario, sensor=dataclasses.replace(scenario.sensor,
                                                                     range_sigma_m=1e-12))
    truth = TruthWorld(exact, np.random.default_rng(0))
    truth.pose = np.array(pose)
    return truth


@pytest.mark.parametrize("pose", POSES)
def test_depth_frames_agree(pose):
    scenario = load_scenario("config/scenarios/walls.yaml")
    stub = stub_load_scenario("config/scenarios/walls.yaml")
    ranges, _, _ = companion_truth(scenario, pose).observe_sectors()
    exact = dataclasses.replace(stub.sensor, range_sigma_m=0.0)
    circles = [(o.obstacle_id, o.north_m, o.east_m, o.radius_m) for o in stub.world.obstacles]
    cm, _, _ = stub_camera.ray_cast_sectors_cm(*pose, circles, exact, np.random.default_rng(0),
                                               [list(s.outline) for s in stub.world.shapes])
    stub_m = np.array(cm[:exact.sector_count], dtype=float) / 100.0
    stub_m[stub_m > exact.max_range_m] = np.nan
    assert np.array_equal(np.isfinite(ranges), np.isfinite(stub_m))
    assert np.isfinite(ranges).sum() >= 5                  # each pose sees something
    assert np.nanmax(np.abs(ranges - stub_m)) <= 0.005     # the stub's centimetres


@pytest.mark.parametrize("pose", POSES)
def test_surface_distances_agree(pose):
    scenario = load_scenario("config/scenarios/walls.yaml")
    stub = stub_load_scenario("config/scenarios/walls.yaml")
    clear = companion_truth(scenario, pose).clearance()
    stub_nearest = min(stub_shapes.surface_distance_m(pose[0], pose[1], list(s.outline))
                       for s in stub.world.shapes)
    posts = min(math.hypot(pose[0] - o.north_m, pose[1] - o.east_m) for o in stub.world.obstacles)
    assert clear.clearance_m == pytest.approx(min(stub_nearest, posts))
    assert clear.surface_m == pytest.approx(
        min(stub_nearest, min(math.hypot(pose[0] - o.north_m, pose[1] - o.east_m) - o.radius_m
                              for o in stub.world.obstacles)))


def test_a_wall_seen_by_sectors_is_a_chain_that_blocks_every_heading_through_it():
    # a 30 m wall, 0.3 m thick, 20 m ahead across the view, nothing else
    scenario = load_scenario("config/scenarios/walls.yaml")
    wall = Wall(10, Point(20.0, -15.0), Point(20.0, 15.0), 0.3)
    world = dataclasses.replace(scenario.world, start=dataclasses.replace(
        scenario.world.start, north_m=0.0), obstacles=(), walls=(wall,), buildings=())
    truth = companion_truth(dataclasses.replace(scenario, world=world), (0.0, 0.0, 0.0))
    ranges, bearings, increment = truth.observe_sectors()
    obs = blob_observations(ranges, bearings, increment, BlobParams(0.0, 0.0))
    points = np.array([[o.range_m * math.cos(o.bearing_rad), o.range_m * math.sin(o.bearing_rad)]
                       for o in obs])
    assert np.allclose(points[:, 0], 19.85, atol=0.1)              # on the wall's face
    assert points[:, 1].min() < -14.0 and points[:, 1].max() > 14.0  # to its ends
    d = scenario.avoidance.safety_distance_m
    # every heading that would cross the wall enters some chain point's cone
    headings = np.radians(np.linspace(-36.0, 36.0, 145))            # atan(15 / 20) = 36.9 deg
    blocked = blocking(headings, np.zeros(2), points, np.full(len(points), d),
                       scenario.avoidance.eta, reach_m=40.0).any(axis=1)
    assert blocked.all()
    # and the chain leaves no point of the face more than sqrt(d^2 - (spacing/2)^2) from a landmark
    face = np.column_stack((np.full(61, 19.85), np.linspace(-15.0, 15.0, 61)))
    nearest = np.hypot(*(face[:, None, :] - points[None, :, :]).transpose(2, 0, 1)).min(axis=1)
    assert nearest.max() <= 0.5 * BlobParams().chain_spacing_m + 0.2
