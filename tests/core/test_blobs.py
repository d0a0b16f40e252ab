"""Depth sectors to landmarks: a post, a wall, two posts close together, bin-centre bearings."""
import math

import numpy as np
import pytest

from companion.config.scenario import load_scenario
from companion.config.world import Goal, Obstacle, StartPose, World
from companion.core.perception.blobs import BlobParams, blob_observations, group_bins, sector_centres_rad
from companion.sim.truth import TruthWorld

FOV = math.radians(90.0)
PARAMS = BlobParams(range_sigma_m=0.0, bearing_sigma_rad=0.0)


def scan(circles, count=72, pose=(0.0, 0.0, 0.0)):
    """Exact sectors of circles [(north, east, radius)] from ``pose`` by the simulator's ray-cast."""
    import dataclasses
    base = load_scenario("config/scenarios/paper-anonymous.yaml")
    sensor = dataclasses.replace(base.sensor, range_sigma_m=1e-9, form="sectors",
                                 sector_count=count)
    world = World(StartPose(*pose[:2], math.degrees(pose[2])), Goal(500.0, 0.0),
                  tuple(Obstacle(i + 1, n, e, r) for i, (n, e, r) in enumerate(circles)))
    truth = TruthWorld(dataclasses.replace(base, world=world, sensor=sensor),
                       np.random.default_rng(0))
    return truth.observe_sectors()


def test_bins_are_at_their_centres():
    bearings = sector_centres_rad(72, FOV)
    assert math.degrees(bearings[0]) == pytest.approx(-44.375)
    assert math.degrees(bearings[-1]) == pytest.approx(44.375)
    _, scan_bearings, increment = scan([])
    assert np.allclose(scan_bearings, bearings) and increment == pytest.approx(FOV / 72)


def test_a_post_becomes_one_landmark_at_its_centre():
    north, east, radius = 25.0, 3.0, 2.0
    ranges, bearings, increment = scan([(north, east, radius)])
    assert 4 <= np.isfinite(ranges).sum() <= 7           # 2 asin(2/25.2) = 9.1 deg of 1.25 deg bins
    obs = blob_observations(ranges, bearings, increment, PARAMS)
    assert len(obs) == 1
    centre = obs[0].range_m * np.array([math.cos(obs[0].bearing_rad), math.sin(obs[0].bearing_rad)])
    assert np.hypot(*(centre - (north, east))) < 1.0
    var_r, var_b = obs[0].meas_cov[0][0], obs[0].meas_cov[1][1]
    # the bearing is known to a fraction of a bin, the range to the radius's spread
    assert math.sqrt(var_b) == pytest.approx(
        math.sqrt(PARAMS.correlation_inflation / 24.0) * increment, rel=0.05)
    assert 0.05 < math.sqrt(var_r) < 2.0


def test_a_wall_becomes_a_chain_that_leaves_no_gap():
    # a wall 20 m ahead, 30 m long across the view, as touching circles of 0.5 m radius
    wall = [(20.0, e, 0.5) for e in np.arange(-15.0, 15.01, 0.5)]
    ranges, bearings, increment = scan(wall)
    obs = blob_observations(ranges, bearings, increment, PARAMS)
    points = np.array([[o.range_m * math.cos(o.bearing_rad), o.range_m * math.sin(o.bearing_rad)]
                       for o in obs])
    assert len(obs) >= 8
    assert np.allclose(points[:, 0], 19.5, atol=0.3)                    # on the wall's face
    gaps = np.hypot(*np.diff(points[np.argsort(points[:, 1])], axis=0).T)
    assert gaps.max() <= PARAMS.chain_spacing_m + 1.0                  # no gap a vehicle fits
    assert points[:, 1].min() < -13.0 and points[:, 1].max() > 13.0    # to its ends


def test_two_posts_close_together_are_two_landmarks():
    posts = [(20.0, -3.0, 1.5), (20.0, 3.0, 1.5)]        # 3 m of free space between them
    ranges, bearings, increment = scan(posts)
    assert len(group_bins(ranges, PARAMS.max_jump_m)) == 2
    obs = blob_observations(ranges, bearings, increment, PARAMS)
    centres = sorted((o.range_m * math.cos(o.bearing_rad), o.range_m * math.sin(o.bearing_rad))
                     for o in obs)
    assert len(centres) == 2
    for (n, e), (pn, pe, _) in zip(sorted(centres, key=lambda c: c[1]), posts):
        assert math.hypot(n - pn, e - pe) < 1.0


def test_a_post_in_front_of_a_farther_one_is_split_by_the_range_jump():
    ranges, bearings, increment = scan([(15.0, 0.0, 1.0), (30.0, 1.5, 2.0)])
    blobs = group_bins(ranges, PARAMS.max_jump_m)
    assert len(blobs) >= 2
    # the farther post shows only its east side past the nearer one: a centre from that cut
    # width would lie metres off; without a fit (no range noise given) it gives its surface
    # points, loose (R of the chain spacing's spread), and the nearer post its centre
    obs = blob_observations(ranges, bearings, increment, PARAMS)
    near = [o for o in obs if o.range_m < 20.0]
    far = [o for o in obs if o.range_m >= 20.0]
    assert len(near) == 1 and near[0].range_m == pytest.approx(15.0, abs=0.3)
    spread = PARAMS.correlation_inflation * PARAMS.chain_spacing_m ** 2 / 12.0
    assert far and all(o.meas_cov[0][0] >= spread for o in far)
    # on the far post's surface: from the origin, between its nearest point and its tangents
    assert all(math.hypot(30.0, 1.5) - 2.0 - 0.1 <= o.range_m <= 30.0 for o in far)


def test_a_post_cut_by_the_edge_of_the_view_is_placed_by_a_fit_or_left_loose():
    # 45 deg off the heading at 20 m: half of it outside the 90 deg view
    post = (20.0 * math.cos(math.radians(45.0)), 20.0 * math.sin(math.radians(45.0)), 2.0)
    ranges, bearings, increment = scan([post])
    assert np.isfinite(ranges[-1])                     # the last bin holds its surface
    spread = PARAMS.correlation_inflation * PARAMS.chain_spacing_m ** 2 / 12.0
    loose = blob_observations(ranges, bearings, increment, PARAMS)     # exact ranges: no fit
    assert loose and all(o.meas_cov[0][0] >= spread for o in loose)
    noisy = ranges + np.random.default_rng(0).normal(0.0, 0.1, len(ranges))
    (fitted,) = blob_observations(noisy, bearings, increment, BlobParams(range_sigma_m=0.1))
    centre = fitted.range_m * np.array([math.cos(fitted.bearing_rad), math.sin(fitted.bearing_rad)])
    assert np.hypot(*(centre - post[:2])) < 1.0


def test_a_post_seen_across_enough_bins_is_placed_by_a_circle_fit():
    # range noise 0.1 m a bin: the fit's centre within a few of its own sigmas, R from the fit
    north, east, radius = 18.0, -2.0, 2.5
    import dataclasses
    base = load_scenario("config/scenarios/paper-anonymous.yaml")
    sensor = dataclasses.replace(base.sensor, range_sigma_m=0.1, form="sectors")
    world = World(StartPose(0.0, 0.0, 0.0), Goal(500.0, 0.0), (Obstacle(1, north, east, radius),))
    truth = TruthWorld(dataclasses.replace(base, world=world, sensor=sensor),
                       np.random.default_rng(3))
    errors, width_var = [], PARAMS.correlation_inflation * increment_of(72) ** 2 / 24.0
    for _ in range(200):
        (obs,) = blob_observations(*truth.observe_sectors(), BlobParams(range_sigma_m=0.1))
        if obs.meas_cov[1][1] >= width_var:
            continue                                   # the width's estimate: the fit refused
        e = np.array([obs.range_m - math.hypot(north, east),
                      obs.bearing_rad - math.atan2(east, north)])
        errors.append(float(e @ np.linalg.solve(np.array(obs.meas_cov), e)))
    assert len(errors) >= 180                          # fitted in nearly every frame
    # the fit's R is honest (NIS mean about 2 for 2 dof, well under the 9.2 of a 99% gate)
    assert 0.5 < np.mean(errors) < 3.0


def increment_of(count):
    return FOV / count
