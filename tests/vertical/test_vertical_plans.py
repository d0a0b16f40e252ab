"""core/vertical.py: which altitude plans are offered, what each leaves to the horizontal law,
and how they are scored; core/vertical_extent.py: the floor, bad points, the extent's filter."""
import math

import numpy as np

from companion.core.avoidance import vertical as v3
from companion.core.perception.vertical_extent import ExtentParams, PointHeights, VerticalExtent, classify

PARAMS = v3.VerticalParams(safety_distance_m=10.0, cruise_altitude_m=10.0,
                           max_vertical_speed_mps=2.5, min_altitude_m=2.0, max_altitude_m=30.0,
                           cruise_speed_mps=5.0, reach_m=40.0)
HERE = np.zeros(2)


def test_a_low_wall_ahead_is_offered_over_and_a_tower_is_not():
    wall, tower = v3.Extent(3.0, 0.1), v3.Extent(40.0, 0.1)
    plans = v3.plans(HERE, 10.0, np.array([[35.0, 0.0], [35.0, 30.0]]), [wall, tower], PARAMS)
    kinds = {p.kind: p for p in plans}
    assert set(kinds) == {"level", "over"}
    assert kinds["level"].skip == frozenset() and kinds["level"].altitude_m == 10.0
    # over the wall: 3 + d + margin + 3 sigma; the tower (40 m: beyond the ceiling) stays 2D
    assert math.isclose(kinds["over"].altitude_m, 3.0 + 10.0 + 1.0 + 0.3)
    assert kinds["over"].skip == frozenset({0})


def test_a_ceiling_below_the_walls_top_leaves_only_around():
    low_ceiling = v3.VerticalParams(**{**PARAMS.__dict__, "max_altitude_m": 12.0})
    plans = v3.plans(HERE, 10.0, np.array([[35.0, 0.0]]), [v3.Extent(3.0, 0.1)], low_ceiling)
    assert [p.kind for p in plans] == ["level"]


def test_unknown_top_is_never_flown_over():
    plans = v3.plans(HERE, 10.0, np.array([[35.0, 0.0]]), [v3.UNBOUNDED], PARAMS)
    assert [p.kind for p in plans] == ["level"] and plans[0].skip == frozenset()


def test_too_near_to_climb_in_time_is_flown_round():
    # 12 m away at 5 m/s: 0.4 s to the grown circle, far too short to climb 4.3 m
    plans = v3.plans(HERE, 10.0, np.array([[12.0, 0.0]]), [v3.Extent(3.0, 0.1)], PARAMS)
    over = [p for p in plans if p.kind == "over"]
    assert not over or 0 not in over[0].skip


def test_below_the_minimum_altitude_nothing_is_flown_over():
    plans = v3.plans(HERE, 1.5, np.array([[35.0, 0.0]]), [v3.Extent(0.5, 0.1)], PARAMS)
    assert plans == [v3.Plan("level", 10.0)]


def test_a_bridge_is_offered_under_when_its_deck_is_high_enough():
    deck = v3.Extent(30.0, 0.1, bottom_m=20.0, bottom_seen=True)
    plans = {p.kind: p for p in v3.plans(HERE, 10.0, np.array([[35.0, 0.0]]), [deck], PARAMS)}
    assert "under" in plans and plans["under"].altitude_m <= 20.0 - 10.0 - 1.0
    assert plans["under"].skip == frozenset({0})
    assert plans["level"].skip == frozenset()      # at 10 m: within the grown deck (down to 10 m)
    # a deck at 24 m is passed under at the cruise altitude already
    high = v3.plans(HERE, 10.0, np.array([[35.0, 0.0]]),
                    [v3.Extent(30.0, 0.1, bottom_m=24.0, bottom_seen=True)], PARAMS)
    assert [p.kind for p in high] == ["level"] and high[0].skip == frozenset({0})


def test_it_never_sinks_onto_what_it_is_over():
    # 4 m past a 3 m wall's axis at 14.3 m: level holds 14.3 and still flies over it
    plans = v3.plans(HERE, 14.3, np.array([[-4.0, 0.0]]), [v3.Extent(3.0, 0.1)], PARAMS)
    level = plans[0]
    assert level.kind == "level" and level.altitude_m >= 14.3 - 1e-9 and level.skip == {0}
    # well past it: back to the cruise altitude, sinking
    far = v3.plans(HERE, 14.3, np.array([[-25.0, 0.0]]), [v3.Extent(3.0, 0.1)], PARAMS)[0]
    assert far.altitude_m == 10.0
    assert v3.climb_rate_mps(14.3, far.altitude_m, PARAMS) < 0.0


def test_scoring_over_a_low_wall_and_around_a_tower():
    goal = np.array([200.0, 0.0])
    over = v3.Plan("over", 14.3, frozenset({0}))
    level = v3.Plan("level", 10.0)
    # around a 60 m wall: the horizontal law's heading toward its end, 35 m aside at 40 m
    heading = math.atan2(35.0, 40.0)
    wall_rows = np.array([[40.0, y] for y in np.arange(-30.0, 31.0, 4.0)])
    detour = v3.detour_m(HERE, goal, heading, wall_rows, list(range(len(wall_rows))))
    costs = [(level, v3.plan_cost_m(level, 10.0, detour, False, PARAMS)),
             (over, v3.plan_cost_m(over, 10.0, 0.0, False, PARAMS))]
    assert v3.choose(costs, None, 10.0, PARAMS).plan.kind == "over"
    # a single tower on the line: around it is a 1.5 m detour, over it (were it 12 m) 2 x 13 m
    tower_heading = math.atan2(10.0, 40.0)
    detour = v3.detour_m(HERE, goal, tower_heading, np.array([[40.0, 0.0]]), [0])
    high = v3.Plan("over", 23.0, frozenset({0}))
    costs = [(level, v3.plan_cost_m(level, 10.0, detour, False, PARAMS)),
             (high, v3.plan_cost_m(high, 10.0, 0.0, False, PARAMS))]
    assert v3.choose(costs, None, 10.0, PARAMS).plan.kind == "level"
    # a hold costs more than any climb
    held = [(level, v3.plan_cost_m(level, 10.0, 0.0, True, PARAMS)),
            (high, v3.plan_cost_m(high, 10.0, 0.0, False, PARAMS))]
    assert v3.choose(held, None, 10.0, PARAMS).plan.kind == "over"


def test_the_plan_flown_is_kept_unless_another_saves_the_margin():
    a, b = v3.Plan("level", 10.0), v3.Plan("over", 14.0, frozenset({0}))
    assert v3.choose([(a, 10.0), (b, 8.0)], "level", 10.0, PARAMS).plan is a
    assert v3.choose([(a, 10.0), (b, 6.0)], "level", 10.0, PARAMS).plan is b


def test_climb_rate_is_within_the_limits():
    assert v3.climb_rate_mps(10.0, 100.0, PARAMS) == 2.5
    assert v3.climb_rate_mps(10.0, -50.0, PARAMS) == -2.5
    assert v3.climb_rate_mps(2.5, 0.0, PARAMS) < 0.0 and \
        v3.climb_rate_mps(2.0, 0.0, PARAMS) == 0.0        # never below min_altitude_m


EXTENT = ExtentParams(math.radians(58.0), ground_margin_m=0.5)


def test_floor_points_and_bad_points_are_told_apart():
    assert classify(10.0, 10.0, 25.0, 10.0, EXTENT) == "ground"       # at the floor
    assert classify(9.6, 9.8, 25.0, 10.0, EXTENT) == "ground"         # within the margin
    assert isinstance(classify(9.0, 9.8, 25.0, 10.0, EXTENT), PointHeights)   # 1 m up: a kerb
    assert classify(math.nan, 9.0, 25.0, 10.0, EXTENT) == "bad"
    assert classify(5.0, math.inf, 25.0, 10.0, EXTENT) == "bad"
    assert classify(None, None, 25.0, 10.0, EXTENT) is None           # a 2D observation


def test_a_top_within_view_is_seen_and_one_at_the_edge_is_a_lower_bound():
    reach = 20.0 * math.tan(math.radians(29.0))                        # 11.1 m at 20 m
    seen = classify(10.0 - 3.0, 10.0, 20.0, 10.0, EXTENT)              # a 3 m top, ground below
    assert seen.top_seen and seen.bottom_seen and math.isclose(seen.top_m, 3.0)
    clipped = classify(-reach, 10.0, 20.0, 10.0, EXTENT)               # up to the view's edge
    assert not clipped.top_seen


def test_extent_filter_converges_and_restarts_when_seen_higher():
    rng = np.random.default_rng(1)
    extent = VerticalExtent()
    for _ in range(50):
        z = 4.0 + rng.normal(0.0, 0.2)
        extent.update(PointHeights(z, 0.0, 0.2, True, True))
    assert abs(extent.top_m - 4.0) < 0.1 and extent.top_sigma_m < 0.2 / 6.0
    # a point well above the estimated top (it was not the top): unbounded until seen again
    extent.update(PointHeights(9.0, 0.0, 0.2, False, True))
    assert extent.top_m is None and extent.top_at_least_m == 9.0


def test_no_climb_within_the_hold_band():
    assert v3.climb_rate_mps(10.2, 10.0, PARAMS) == 0.0
    assert v3.climb_rate_mps(9.75, 10.0, PARAMS) == 0.0
    assert v3.climb_rate_mps(9.5, 10.0, PARAMS) > 0.0
