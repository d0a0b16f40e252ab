"""The bounded map (core/estimation/map_archive.py): marginalising landmarks out of the EKF is exact and
leaves the pose alone; stale landmarks are chosen by distance behind and time unseen; a landmark
seen again after it was archived is one landmark, not two."""
import math

import numpy as np
import pytest

from companion.core.estimation.ekf_slam import AssociationGates, EkfSlam, Observation, SlamNoise
from companion.core.estimator_options import EstimatorOptions
from companion.core.avoidance.guidance import GuidanceParams
from companion.core.estimation.map_archive import ArchiveParams, MapArchive, stale
from companion.core.navigation.navigator import Navigator

NOISE = SlamNoise(0.1, math.radians(0.5), 0.1, 0.1, math.radians(1.0))


def _mapped_filter(rng: np.random.Generator, count: int = 6) -> EkfSlam:
    """A filter that has flown a little and seen ``count`` landmarks a few times each, so that
    pose and landmarks are correlated (the covariance is dense)."""
    slam = EkfSlam([0.0, 0.0, 0.0], np.diag([0.1, 0.1, 0.01]), NOISE)
    points = rng.uniform([5.0, -10.0], [30.0, 10.0], (count, 2))
    for _ in range(5):
        slam.predict(1.0, 0.01, 0.1)
        pose = slam.pose
        for oid, p in enumerate(points):
            d = p - pose[:2]
            slam.update(Observation(math.hypot(*d) + rng.normal(0, 0.1),
                                    math.atan2(d[1], d[0]) - pose[2] + rng.normal(0, 0.01), oid))
    return slam


def test_marginalising_leaves_the_pose_and_the_rest_of_the_map_unchanged():
    slam = _mapped_filter(np.random.default_rng(3))
    mean, cov = slam.mean.copy(), slam.cov.copy()
    assert np.abs(cov[:3, 3:]).max() > 1e-6           # correlated: the test could fail
    ids = slam.landmark_ids()
    slam.remove_landmarks([1, 4])
    keep = np.r_[0:3, 3:5, 7:11, 13:15]                # pose, landmarks 0, 2, 3, 5
    np.testing.assert_array_equal(slam.pose_cov, cov[:3, :3])
    np.testing.assert_array_equal(slam.pose, mean[:3])
    np.testing.assert_array_equal(slam.cov, cov[np.ix_(keep, keep)])
    np.testing.assert_array_equal(slam.mean, mean[keep])
    assert slam.landmark_ids() == [ids[0], ids[2], ids[3], ids[5]]
    # ids still find their landmarks after the shift
    assert slam._id_to_index == {ids[0]: 0, ids[2]: 1, ids[3]: 2, ids[5]: 3}


def test_batch_removal_equals_one_at_a_time():
    slam = _mapped_filter(np.random.default_rng(4))
    other = slam.copy()
    slam.remove_landmarks([0, 2, 5])
    for index in (5, 2, 0):
        other.remove_landmark(index)
    np.testing.assert_array_equal(slam.cov, other.cov)
    assert slam.landmark_ids() == other.landmark_ids()


def test_removing_a_landmark_that_is_not_there_is_an_error():
    slam = _mapped_filter(np.random.default_rng(5), count=2)
    with pytest.raises(IndexError):
        slam.remove_landmarks([2])


def test_stale_needs_behind_far_and_unseen():
    params = ArchiveParams(behind_m=20.0, unseen_s=5.0)
    pose = np.array([100.0, 0.0, 0.0])                  # heading north
    points = np.array([[70.0, 0.0],     # behind, far, unseen: stale
                       [130.0, 0.0],    # ahead, far
                       [90.0, 0.0],     # behind, near
                       [70.0, 1.0],     # behind, far, seen recently
                       [99.0, 30.0]])   # beside and a little behind, far: stale
    seen = np.array([0.0, 0.0, 0.0, 8.0, 0.0])
    assert stale(pose, points, seen, 10.0, params).tolist() == [True, False, False, False, True]
    turned = np.array([100.0, 0.0, math.pi])            # heading south: the first is ahead
    assert not stale(turned, points, seen, 10.0, params)[0]


@pytest.mark.parametrize("kwargs", [{"behind_m": 0.0}, {"behind_m": math.inf},
                                    {"behind_m": 10.0, "unseen_s": -1.0}])
def test_archive_params_refuse_bad_values(kwargs):
    with pytest.raises(ValueError, match="archive"):
        ArchiveParams(**kwargs)


def test_reacquire_by_key_or_by_nearness():
    archive = MapArchive(ArchiveParams(behind_m=10.0))
    archive.add(7, np.array([10.0, 0.0]), 0.01 * np.eye(2), 1.0, 20.0)
    archive.add(-3, np.array([20.0, 5.0]), 0.01 * np.eye(2), 1.0, 20.0)
    assert archive.reacquire(99, np.array([50.0, 50.0]), 0.01 * np.eye(2)) is None
    assert archive.reacquire(-8, np.array([20.1, 5.0]), 0.01 * np.eye(2)) == -3
    assert archive.reacquire(7, np.array([0.0, 0.0]), 0.01 * np.eye(2)) == 7
    assert len(archive) == 0 and archive.counts == {"archived": 2, "reacquired": 2}


def _navigator(archive: ArchiveParams | None) -> Navigator:
    params = GuidanceParams(cruise_speed_mps=2.0, safety_distance_m=2.0, horizon_s=4.0, eta=1.25,
                            goal_radius_m=2.0)
    options = EstimatorOptions(motion_model="velocity_ned", archive=archive)
    return Navigator(np.zeros(3), np.diag([1e-4, 1e-4, 1e-4]), NOISE, AssociationGates(), params,
                     np.array([500.0, 0.0]), "union", options=options)


def _observe(nav: Navigator, truth_xy: np.ndarray, trees: np.ndarray, yaw: float,
             with_ids: bool) -> None:
    frame = []
    for oid, tree in enumerate(trees, start=1):
        d = tree - truth_xy
        bearing = math.remainder(math.atan2(d[1], d[0]) - yaw, 2 * math.pi)
        if math.hypot(*d) < 25.0 and abs(bearing) < math.radians(45.0):
            frame.append(Observation(math.hypot(*d), bearing, oid if with_ids else None))
    nav.observe(frame)


def _fly(nav: Navigator, trees: np.ndarray, legs: list[tuple[float, float]], with_ids: bool,
         t_s: float = 0.0) -> float:
    """Fly ``legs`` of (yaw_rad, seconds) at 2 m/s, exact odometry, a frame every 0.2 s."""
    xy = nav.slam.pose[:2].copy()
    nav.on_velocity(t_s, 0.0, 0.0, legs[0][0], 0.0)
    for yaw, seconds in legs:
        vel = 2.0 * np.array([math.cos(yaw), math.sin(yaw)])
        for _ in range(int(round(seconds / 0.1))):
            t_s += 0.1
            xy = xy + 0.1 * vel
            nav.on_velocity(t_s, vel[0], vel[1], yaw, 0.0)
            if round(t_s * 10) % 2 == 0:
                _observe(nav, xy, trees, yaw, with_ids)
    return t_s


@pytest.mark.parametrize("with_ids", [True, False])
def test_an_archived_landmark_seen_again_is_one_landmark(with_ids):
    trees = np.array([[10.0, 4.0], [14.0, -5.0], [60.0, 4.0]])
    nav = _navigator(ArchiveParams(behind_m=15.0, unseen_s=3.0))
    t_s = _fly(nav, trees, [(0.0, 25.0)], with_ids)           # out to 50 m north
    assert len(nav.archive) == 2                              # the first two trees, behind
    assert nav.slam.landmark_count == 1
    _fly(nav, trees, [(math.pi, 15.0)], with_ids, t_s)        # back toward them: seen again
    live, kept = nav.slam.landmarks(), nav.archive.points()
    assert nav.archive.counts["reacquired"] == 2
    for tree in trees[:2]:
        copies = int(np.sum(np.hypot(*(live - tree).T) < 1.0)) \
            + int(np.sum(np.hypot(*(kept - tree).T) < 1.0))
        assert copies == 1


def test_the_map_is_bounded_and_off_by_default():
    rng = np.random.default_rng(9)
    trees = np.column_stack([rng.uniform(5.0, 400.0, 120), rng.choice([-1, 1], 120)
                             * rng.uniform(3.0, 15.0, 120)])
    bounded, everything = (_navigator(ArchiveParams(behind_m=15.0, unseen_s=3.0)),
                           _navigator(None))
    for nav in (bounded, everything):
        _fly(nav, trees, [(0.0, 190.0)], True)
    assert everything.archive is None
    assert everything.slam.landmark_count > 100
    assert bounded.slam.landmark_count < 40
    assert bounded.slam.landmark_count + len(bounded.archive) == everything.slam.landmark_count


@pytest.mark.slow
@pytest.mark.parametrize("position_fusion", ["auto", "off"])
def test_the_pose_stays_consistent_on_a_long_forest_route(position_fusion):
    """Four seeded 300 m flights through a forest (400 trees per ha, a straight lane kept free
    so every flight goes the whole way) with the bounded map on: most trees leave the filter,
    and the pose NEES averaged over the runs stays in its 95% band on at least 90% of steps,
    with the autopilot's position fused and GPS-denied alike."""
    import dataclasses

    from companion.config.scenario import load_scenario
    from companion.sim.forest_worlds import lane_forest
    from companion.sim.simulation import aggregate, run_once, with_position_fusion, with_speed

    base = with_position_fusion(with_speed(load_scenario("config/scenarios/forest.yaml"), 8.0),
                                position_fusion)
    assert base.estimator_config().options().archive is not None
    outcomes = [run_once(lane_forest(base, 300.0, seed), seed) for seed in range(4)]
    assert all(o.summary["reached_goal"] for o in outcomes)
    for o in outcomes:
        marks = o.summary["landmarks"]
        assert marks["final"] < 0.6 * (marks["final"] + marks["in_archive"])   # the map was bounded
    nees = aggregate(outcomes, base.avoidance.safety_distance_m)["nees"]
    assert nees["in_band_fraction"] >= 0.9, nees


def _filled(seed: int, count: int, spread_m: float) -> tuple[MapArchive, MapArchive, np.random.Generator]:
    """Two archives holding the same random entries (positions over spread_m, covariances of
    varied size and shape, some large), and the generator for the queries."""
    rng = np.random.default_rng(seed)
    a, b = MapArchive(ArchiveParams(behind_m=10.0)), MapArchive(ArchiveParams(behind_m=10.0))
    for key in range(count):
        position = rng.uniform(0.0, spread_m, 2)
        root = rng.normal(0.0, rng.choice([0.05, 0.3, 2.0]), (2, 2))
        cov = root @ root.T + 1e-4 * np.eye(2)
        a.add(key, position, cov, 0.0, 1.0)
        b.add(key, position, cov, 0.0, 1.0)
    return a, b, rng


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_grid_matches_equal_brute_force(seed):
    # the spatial hash's answer is the brute force's over the whole archive, query after query
    # (each match drops an entry from both, so later queries see the same archive)
    grid, brute, rng = _filled(seed, 400, 300.0)
    matched = 0
    for q in range(300):
        if q % 3 == 0:       # near an archived entry: a match is likely
            entry = brute.entries()[int(rng.integers(len(brute)))]
            position = np.array(entry.position_ne_m) + rng.normal(0.0, 0.5, 2)
        else:
            position = rng.uniform(-20.0, 320.0, 2)
        root = rng.normal(0.0, rng.choice([0.05, 0.5, 3.0]), (2, 2))
        cov = root @ root.T + 1e-4 * np.eye(2)
        key = int(rng.integers(1000, 2000)) if q % 7 else int(rng.integers(0, 400))
        expected = brute.reacquire_brute(key, position, cov)
        assert grid.reacquire(key, position, cov) == expected
        matched += expected is not None
        assert len(grid) == len(brute)
    assert matched > 50                       # the queries did exercise matches
    assert grid.counts == brute.counts


def test_grid_looks_at_few_entries_on_a_long_route():
    # a 5 km line of archived trees: a query far along it sees only the cells near it
    archive = MapArchive(ArchiveParams(behind_m=10.0))
    for key in range(5000):
        archive.add(key, np.array([float(key), 3.0]), 0.04 * np.eye(2), 0.0, 1.0)
    near = archive._candidates(np.array([2500.0, 0.0]), 0.04 * np.eye(2))
    assert 0 < len(near) < 50
    assert all(abs(archive._entries[k].position_ne_m[0] - 2500.0) < 30.0 for k in near)
