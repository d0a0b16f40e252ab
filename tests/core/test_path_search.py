"""The forests' path search (core/avoidance/path_search.py) and its follower (path_follow.py)."""
import math
from dataclasses import replace

import numpy as np
import pytest

from companion.core.avoidance.arc import VehicleLimits, clearance, fly_out
from companion.core.avoidance.guidance import GuidanceInputs, GuidanceParams
from companion.core.avoidance.path_follow import guide_along_path
from companion.core.avoidance.path_search import (STEADY_PATH, PathParams, clearance_at,
                                                 off_path, off_path_grid, plan_path)
from companion.core.avoidance.union import UnionParams

D = 1.5


def _wall(gap_east_m: float, half_gap_m: float, north_m: float = 10.0) -> np.ndarray:
    """Posts every metre along east at ``north_m`` except a gap centred at ``gap_east_m``."""
    return np.array([[north_m, e] for e in np.arange(-20.0, 20.5, 1.0)
                     if abs(e - gap_east_m) > half_gap_m])


def test_straight_when_nothing_is_mapped_near_the_line():
    obstacles = np.array([[10.0, 8.0], [20.0, -8.0]])
    plan = plan_path(np.zeros(2), np.array([100.0, 0.0]), obstacles, np.full(2, D))
    assert plan.found
    assert abs(plan.heading_rad) < math.radians(1.0)


@pytest.mark.parametrize("gap_east_m", [-7.0, 6.0])
def test_through_the_only_gap_of_a_wall_keeping_the_margin(gap_east_m):
    wall = _wall(gap_east_m, 3.0)
    radii = np.full(len(wall), D)
    params = PathParams()
    plan = plan_path(np.zeros(2), np.array([30.0, 0.0]), wall, radii, params)
    assert plan.found
    # the path crosses the wall's line inside the gap, and keeps the margin all along
    crossing = plan.points_ne_m[np.argmin(np.abs(plan.points_ne_m[:, 0] - 10.0))]
    assert abs(crossing[1] - gap_east_m) < 1.0
    assert clearance_at(plan.points_ne_m[1:], wall, radii).min() >= params.margin_m - 1e-9
    # the first leg heads toward the gap's side
    assert np.sign(plan.heading_rad) == np.sign(gap_east_m)


def test_no_path_through_a_closed_wall():
    wall = np.array([[10.0, e] for e in np.arange(-25.0, 25.5, 1.0)])
    plan = plan_path(np.zeros(2), np.array([30.0, 0.0]), wall, np.full(len(wall), D),
                     PathParams(side_m=20.0))
    assert not plan.found


def test_a_gap_narrower_than_twice_d_plus_the_margin_is_not_taken():
    # posts 2 x (d + 0.4) apart: free space between their circles is 0.8 m, but the path must
    # keep d + 0.5 (margin_m): it goes round the row's end instead
    row = np.array([[10.0, -3.8], [10.0, 0.0]])
    plan = plan_path(np.zeros(2), np.array([30.0, -1.9]), row, np.full(2, D))
    assert plan.found
    crossing = plan.points_ne_m[np.argmin(np.abs(plan.points_ne_m[:, 0] - 10.0))]
    assert not -3.8 < crossing[1] < 0.0


def test_the_last_heading_keeps_the_side_of_a_symmetric_tree():
    tree = np.array([[8.0, 0.0]])
    left = plan_path(np.zeros(2), np.array([40.0, 0.0]), tree, np.full(1, D),
                     previous_heading_rad=math.radians(-30.0))
    right = plan_path(np.zeros(2), np.array([40.0, 0.0]), tree, np.full(1, D),
                      previous_heading_rad=math.radians(30.0))
    assert left.heading_rad < 0.0 < right.heading_rad


def test_a_vehicle_inside_the_margin_finds_its_way_out():
    tree = np.array([[2.0, 0.0]])
    start = np.array([0.0, 0.3])           # 2.02 m from the centre: 0.52 beyond d, 0.02 short
    plan = plan_path(start, np.array([30.0, 0.0]), tree, np.full(1, D),
                     PathParams(margin_m=0.6))
    assert plan.found and plan.heading_rad > 0.0       # out on its own side


def _inputs(obstacles, speed=5.0):
    limits = VehicleLimits(math.radians(60.0), 2.5, lateral_accel_limited=True)
    return GuidanceInputs(np.array([0.0, 0.0, 0.0]), np.array([60.0, 0.0]), obstacles,
                          motion=limits.motion(speed, 0.0, 0.0))


def test_the_follower_flies_the_leg_and_keeps_d():
    wall = _wall(6.0, 3.0)
    params = GuidanceParams(5.0, D, 4.0, 1.25, 2.0)
    union = UnionParams(lookahead_s=3.0, fov_rad=math.radians(87.0), path=PathParams())
    command = guide_along_path(_inputs(wall), params, union)
    assert command.mode == "path"
    assert 0.0 < command.heading_rad < math.radians(45.0)
    assert 0.0 < command.speed_mps <= 5.0


def test_off_without_the_key():
    # union.path None: the velocity choice as it was
    wall = _wall(6.0, 3.0)
    params = GuidanceParams(5.0, D, 4.0, 1.25, 2.0)
    command = guide_along_path(_inputs(wall), params,
                               UnionParams(lookahead_s=3.0, fov_rad=math.radians(87.0)))
    assert command.mode != "path"


def _row(gap_east_m: float, spacing_m: float, north_m: float = 10.0) -> np.ndarray:
    """Posts 1 m apart across the whole grid at ``north_m`` but two ``spacing_m`` apart either
    side of ``gap_east_m``."""
    half = 0.5 * spacing_m
    posts = [[north_m, e] for e in np.arange(-30.0, 30.5, 1.0) if abs(e - gap_east_m) > half + 0.5]
    return np.array(posts + [[north_m, gap_east_m - half], [north_m, gap_east_m + half]])


def test_a_tight_gap_is_taken_when_no_wider_one_leads_on_and_its_margin_is_kept():
    # the gap's posts 2 x (d + 0.15) apart: closed at d + margin_m (0.3), open at the tight floor;
    # 6 m ahead, within the first leg's reach, whose margin is then the gap's
    row = _row(4.0, 2.0 * (D + 0.15), north_m=6.0)
    radii = np.full(len(row), D)
    goal = np.array([30.0, 0.0])
    plan = plan_path(np.zeros(2), goal, row, radii)
    assert plan.found
    crossing = plan.points_ne_m[np.argmin(np.abs(plan.points_ne_m[:, 0] - 6.0))]
    assert abs(crossing[1] - 4.0) < 0.6
    assert PathParams().tight_floor_m <= plan.margin_m < PathParams().margin_m
    assert not plan_path(np.zeros(2), goal, row, radii, PathParams(tight_floor_m=None)).found


def test_the_goal_beyond_the_grid_is_not_reached_by_backing_out_of_it():
    # a closed row ahead: leaving the grid behind (8 m back, then 108 m) is the cheapest way to
    # the goal by the edge's straight line, but the way on is sought from edges ahead first
    row = np.array([[10.0, e] for e in np.arange(-30.0, 30.5, 1.0)])
    plan = plan_path(np.zeros(2), np.array([100.0, 0.0]), row, np.full(len(row), D))
    assert plan.found
    assert plan.points_ne_m[-1][0] >= 0.0


def test_off_path_measures_the_distance_to_the_polyline_not_its_vertices():
    path = np.array([[0.0, 0.0], [10.0, 0.0], [10.0, 10.0]])
    points = np.array([[5.0, 0.9], [5.0, 1.1], [10.9, 5.0], [11.1, 5.0], [-0.5, 0.0],
                       [-1.5, 0.0]])
    assert off_path(points, path, 1.0).tolist() == [False, True, False, True, False, True]
    assert off_path(points[:2], path[:1], 1.0).tolist() == [True, True]


@pytest.mark.parametrize("seed", range(40))
def test_off_path_grid_is_off_path_bit_for_bit(seed):
    """The windowed test of a grid's cells gives off_path's answer on every cell: rotated grids
    far from the origin (as a 5 km forest's), kept paths of cell steps with points exactly on
    the width, a long last segment to a far goal, a single point."""
    rng = np.random.default_rng(seed)
    start = rng.uniform(-5000.0, 5000.0, 2)
    angle = rng.uniform(-math.pi, math.pi)
    axis_u = np.array([math.cos(angle), math.sin(angle)])
    axis_v = np.array([-axis_u[1], axis_u[0]])
    us = np.arange(-8.0, 48.0 + 0.25, 0.5)
    vs = np.arange(-rng.uniform(5.0, 40.0), rng.uniform(5.0, 40.0) + 0.25, 0.5)
    grid_u, grid_v = np.meshgrid(us, vs, indexing="ij")
    centres = start + grid_u[..., None] * axis_u + grid_v[..., None] * axis_v
    # a path of cell steps in grid coordinates (so points sit exactly 1.0 m off some segments),
    # then a far goal; or a single point
    steps = rng.integers(-1, 2, size=(int(rng.integers(0, 120)), 2)) * 0.5
    steps[:, 0] = np.abs(steps[:, 0])
    walk = np.vstack([[0.0, 0.0], np.cumsum(steps, axis=0)])
    path = start + walk[:, :1] * axis_u + walk[:, 1:] * axis_v
    if seed % 3:
        path = np.vstack([path, start + rng.uniform(50.0, 5000.0) * axis_u])
    width = float(rng.choice([0.5, 1.0, 1.3]))
    expected = off_path(centres.reshape(-1, 2), path, width)
    got = off_path_grid(us, vs, centres, start, axis_u, axis_v, path, width)
    assert got.dtype == bool and got.shape == expected.shape
    assert np.array_equal(got, expected)
    assert 0 < expected.sum() < expected.size       # both answers occur


def _closed_wall(half_width_m: float) -> np.ndarray:
    """Posts every metre along east at north 10 m, from -half_width_m to +half_width_m."""
    return np.array([[10.0, e] for e in np.arange(-half_width_m, half_width_m + 0.5, 1.0)])


def test_the_steady_grid_takes_in_a_mapped_wall_wider_than_its_sides():
    # a wall 70 m wide, closed: the default grid (20 m either side) leaves by a side edge south
    # of the wall, whose straight line to the goal runs through the mapped wall; the steady
    # grid reaches the wall's ends and goes round one
    wall = _closed_wall(35.0)
    radii = np.full(len(wall), D)
    goal = np.array([100.0, 0.0])
    default = plan_path(np.zeros(2), goal, wall, radii, PathParams())
    steady = plan_path(np.zeros(2), goal, wall, radii, STEADY_PATH)
    assert default.found and steady.found
    assert np.abs(default.points_ne_m[:, 1]).max() <= 20.0 + 1e-9
    assert default.points_ne_m[-1, 0] < 10.0              # left the grid before the wall
    assert np.abs(steady.points_ne_m[:, 1]).max() > 35.0 + D
    assert steady.points_ne_m[-1, 0] > 10.0 or np.abs(steady.points_ne_m[-1, 1]) > 35.0 + D
    assert clearance_at(steady.points_ne_m[1:], wall, radii).min() >= STEADY_PATH.margin_m - 1e-9


def test_the_steady_grid_is_the_default_one_with_nothing_mapped_beside_it():
    wall = _wall(6.0, 3.0)                                # within 20 m either side
    radii = np.full(len(wall), D)
    goal = np.array([30.0, 0.0])
    default = plan_path(np.zeros(2), goal, wall, radii, PathParams())
    same = plan_path(np.zeros(2), goal, wall, radii, PathParams(side_max_m=40.0))
    assert np.array_equal(default.points_ne_m, same.points_ne_m)


def test_a_kept_way_through_one_gap_is_kept_when_the_other_is_a_little_shorter():
    # two gaps, east -6 and +5: the +5 one is shorter; the kept path through -6 holds with the
    # keep weight, and without it (or without a kept path) the shorter one is taken
    wall = np.array([[10.0, e] for e in np.arange(-20.0, 20.5, 1.0)
                     if abs(e + 6.0) > 3.0 and abs(e - 5.0) > 3.0])
    radii = np.full(len(wall), D)
    goal = np.array([30.0, 0.0])
    kept = np.array([[0.0, 0.0], [10.0, -6.0], [30.0, 0.0]])

    def crossing(plan):
        return plan.points_ne_m[np.argmin(np.abs(plan.points_ne_m[:, 0] - 10.0)), 1]

    fresh = plan_path(np.zeros(2), goal, wall, radii, STEADY_PATH)
    held = plan_path(np.zeros(2), goal, wall, radii, STEADY_PATH, kept_ne_m=kept)
    unweighted = plan_path(np.zeros(2), goal, wall, radii, PathParams(), kept_ne_m=kept)
    assert abs(crossing(fresh) - 5.0) < 1.0
    assert abs(crossing(held) + 6.0) < 1.0
    assert abs(crossing(unweighted) - 5.0) < 1.0


def test_a_gap_whose_middle_falls_between_cell_centres_is_found_with_the_cell_slack():
    # a gap keeping need + 0.05 m at its middle, east 0.25 m (between the 0.5 m cells' centres
    # at 0 and 0.5, each 0.25 m off it and so short of the need): the default grid finds no way
    # through it, the slack one does, and the path keeps d + the tight floor where it crosses
    half = D + 0.1 + 0.05
    wall = np.array([[10.0, 0.25 - half - k] for k in range(21)]
                    + [[10.0, 0.25 + half + k] for k in range(21)])
    radii = np.full(len(wall), D)
    goal = np.array([30.0, 0.25])

    def crossing(plan):
        return plan.points_ne_m[np.argmin(np.abs(plan.points_ne_m[:, 0] - 10.0)), 1]

    default = plan_path(np.zeros(2), goal, wall, radii, PathParams(side_max_m=40.0))
    slack = plan_path(np.zeros(2), goal, wall, radii, STEADY_PATH)
    assert default.found and abs(crossing(default)) > 15.0          # round an end of the wall
    assert slack.found and abs(crossing(slack) - 0.25) <= 0.25
    assert slack.margin_m >= 0.1 - 1e-9


def test_a_tight_gap_the_slack_found_is_crawled_through_keeping_d():
    # a wall of posts 1 m apart 1.2 m ahead, its one gap keeping d + 0.03 m at its middle: below
    # the tight floor (0.1), found by the cell slack. From rest, with 1 s roll-outs, a quarter of
    # cruise and faster keep less than the floor; the steady follower crawls through keeping d,
    # the one without the crawl does not move toward it. With path_steady's half-second
    # roll-outs it sets off faster, its stop still short of the gap's narrowest
    half = D + 0.03
    wall = np.array([[1.2, -half - k] for k in range(25)] + [[1.2, half + k] for k in range(25)])
    params = GuidanceParams(5.0, D, 4.0, 1.25, 2.0)
    whole_second = replace(STEADY_PATH, follow_s=1.0)
    union = UnionParams(lookahead_s=3.0, fov_rad=math.radians(87.0), path=whole_second)
    inputs = _inputs(wall, speed=0.0)
    crawl = guide_along_path(inputs, params, union)
    assert crawl.mode == "path" and crawl.speed_mps == pytest.approx(STEADY_PATH.crawl_mps)
    assert abs(crawl.heading_rad) < math.radians(10.0)
    without = replace(union, path=replace(whole_second, crawl_mps=None))
    held = guide_along_path(inputs, params, without)
    assert held.speed_mps == 0.0 or abs(held.heading_rad) > math.radians(20.0)
    steady = guide_along_path(inputs, params, replace(union, path=STEADY_PATH))
    assert steady.mode == "path" and steady.speed_mps > STEADY_PATH.crawl_mps
    assert abs(steady.heading_rad) < math.radians(10.0)
    rolled = fly_out(np.zeros(2), inputs.motion, np.array([steady.heading_rad]),
                     np.array([steady.speed_mps]), STEADY_PATH.follow_s, union.fov_rad)
    assert clearance(rolled, wall, np.full(len(wall), D))[0] >= 0.0


@pytest.mark.parametrize("short_m, middle_m", [(0.05, 0.25), (0.14, 0.0)])
def test_the_cell_slack_does_not_take_a_gap_narrower_than_the_need(short_m, middle_m):
    # a gap keeping need - short_m at its middle, between the cells' centres or on one (0.14:
    # d - 0.04, forest-dense seed 18's): the slack grid goes round an end of the wall, as the
    # default one does, instead of leading the follower to a gap it cannot enter
    half = D + 0.1 - short_m
    wall = np.array([[10.0, middle_m - half - k] for k in range(21)]
                    + [[10.0, middle_m + half + k] for k in range(21)])
    plan = plan_path(np.zeros(2), np.array([30.0, middle_m]), wall, np.full(len(wall), D),
                     STEADY_PATH)
    crossing = plan.points_ne_m[np.argmin(np.abs(plan.points_ne_m[:, 0] - 10.0)), 1]
    assert plan.found and abs(crossing) > 15.0
