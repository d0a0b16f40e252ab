"""Issue 46, "climbing needs time": the slowed plans (core/avoidance/climb_time.py, vertical.slowed)
and the cost of going round a barrier as far as it is mapped (core/avoidance/barrier.py)."""
import math

import numpy as np
import pytest

from companion.core.avoidance import vertical as v3
from companion.core.avoidance.barrier import barrier_detour_m, barriers
from companion.core.avoidance.climb_time import altitude_time_s, covered_m, fitting_speed_mps

PARAMS = v3.VerticalParams(safety_distance_m=10.0, cruise_altitude_m=10.0,
                           max_vertical_speed_mps=2.5, min_altitude_m=2.0, max_altitude_m=30.0,
                           cruise_speed_mps=5.0, reach_m=40.0, max_accel_mps2=2.5)
HERE = np.zeros(2)
GOAL = np.array([160.0, 0.0])


def wall(north_m: float, east_from_m: float, east_to_m: float) -> np.ndarray:
    return np.array([[north_m, e] for e in np.arange(east_from_m, east_to_m + 0.1, 4.0)])


def test_the_altitude_law_s_time_matches_stepping_it():
    # 10.3 m to go, stop 0.5 m short: the lag, the limit's stretch, then the gain's tail
    t = altitude_time_s(10.3, 0.5, 2.5, 0.8, 1.0)
    error, s, dt = 10.3, 1.0, 1e-4
    while error > 0.5:
        error -= min(2.5, 0.8 * error) * dt
        s += dt
    assert t == pytest.approx(s, abs=1e-3)
    assert altitude_time_s(0.4, 0.5, 2.5, 0.8, 1.0) == 0.0


@pytest.mark.parametrize("v0,d,t", [(5.0, 18.5, 6.2), (5.0, 8.0, 6.2), (1.0, 3.0, 5.0),
                                    (0.0, 0.5, 6.0), (2.0, 40.0, 6.0)])
def test_the_fitting_speed_covers_exactly_the_way(v0, d, t):
    s = fitting_speed_mps(d, t, v0, 2.5)
    if math.isinf(s):                                    # even at full acceleration it fits
        assert v0 * t + 0.5 * 2.5 * t * t <= d
        return
    assert s >= 0.0 and covered_m(t, v0, s, 2.5) == pytest.approx(d, abs=1e-6)
    assert covered_m(t, v0, s + 0.1, 2.5) > d            # any faster covers more


def test_too_near_to_stop_has_no_fitting_speed():
    assert fitting_speed_mps(4.0, 6.0, 5.0, 2.5) is None     # a stop from 5 m/s takes 5 m
    assert fitting_speed_mps(5.0, 6.0, 5.0, 2.5) == pytest.approx(0.0, abs=1e-6)


def test_a_wall_too_near_to_climb_at_cruise_speed_is_offered_slowed():
    # a 9 m wall 28 m ahead: over at 20.3 m needs ~6 s, 30 m at 5 m/s; 18 m to its grown circle
    rows = wall(28.0, -12.0, 12.0)
    extents = [v3.Extent(9.0, 0.03)] * len(rows)
    plans = {p.kind: p for p in v3.plans(HERE, 10.0, rows, extents, PARAMS, np.array([1.0, 0.0]),
                                         5.0)}
    assert "over" not in plans or len(plans["over"].skip) < len(rows)
    slow = plans["over-slow"]
    assert slow.skip == frozenset(range(len(rows)))            # every post cleared, slowed
    assert 0.0 < slow.speed_mps < 5.0 and slow.delay_s > 0.0
    # flown at that cap, the climb is above the wall's top + d before the grown circle
    need = 9.0 + 10.0 + 0.5 + 3 * 0.03
    t = altitude_time_s(slow.altitude_m - 10.0, slow.altitude_m - need, 2.5, 0.8, 1.0)
    assert covered_m(t, 5.0, slow.speed_mps, 2.5) <= 28.0 - 10.0 + 1e-6
    # without the vehicle's acceleration (or its speed) no slowed plan is offered: as before
    no_accel = v3.VerticalParams(**{**PARAMS.__dict__, "max_accel_mps2": None})
    assert "over-slow" not in {p.kind for p in v3.plans(HERE, 10.0, rows, extents, no_accel,
                                                        np.array([1.0, 0.0]), 5.0)}
    assert "over-slow" not in {p.kind for p in v3.plans(HERE, 10.0, rows, extents, PARAMS)}


def test_nearer_still_it_stops_and_nearer_than_a_stop_it_offers_nothing():
    extents = [v3.Extent(9.0, 0.03)]

    def slow_at(north_m):
        return [p for p in v3.plans(HERE, 10.0, np.array([[north_m, 0.0]]), extents, PARAMS,
                                    None, 5.0) if p.kind == "over-slow"]
    creep = slow_at(16.0)                        # 6 m to the grown circle, 5 m to stop: creeps
    assert creep and 0.0 < creep[0].speed_mps < 0.5
    stop = slow_at(15.05)
    assert stop and stop[0].speed_mps == 0.0     # stops and climbs in place
    too_near = v3.plans(HERE, 10.0, np.array([[14.0, 0.0]]), extents, PARAMS, None, 5.0)
    assert "over-slow" not in {p.kind for p in too_near}


def test_a_slowed_plan_costs_its_delay():
    slow = v3.Plan("over-slow", 20.3, frozenset({0}), 2.0, 3.0)
    fast = v3.Plan("over", 20.3, frozenset({0}))
    assert v3.plan_cost_m(slow, 10.0, 0.0, False, PARAMS) == pytest.approx(
        v3.plan_cost_m(fast, 10.0, 0.0, False, PARAMS) + 3.0 * PARAMS.delay_cost_m_per_s)


def test_posts_nearer_than_2d_join_into_one_barrier():
    pts = np.vstack([wall(50.0, -20.0, 20.0), [[50.0, 60.0]]])     # a gap of 40 m, then a post
    groups = barriers(pts, 20.0)
    assert sorted(len(g) for g in groups) == [1, 11]


def test_going_round_counts_the_barrier_s_mapped_width():
    heading = math.atan2(-1.0, 1.0)                        # turning west
    narrow = wall(40.0, -12.0, 12.0)
    wide = wall(40.0, -80.0, 80.0)
    d_narrow = barrier_detour_m(HERE, GOAL, heading, narrow, list(range(len(narrow))), 10.0)
    d_wide = barrier_detour_m(HERE, GOAL, heading, wide, list(range(len(wide))), 10.0)
    # via the point d beyond the west end: (40, -90), then the goal
    exact = math.hypot(40.0, 90.0) + math.hypot(120.0, 90.0) - 160.0
    assert d_wide == pytest.approx(exact)
    assert d_narrow < 20.0 < d_wide
    # the reach-limited detour of vertical.detour_m sees only the wall's middle
    near = [i for i, p in enumerate(wide) if np.hypot(*p) <= 40.0 + 1e-9]
    assert v3.detour_m(HERE, GOAL, heading, wide, near) < 0.5 * d_wide


def test_a_barrier_beside_the_way_or_already_rounded_costs_nothing():
    beside = wall(40.0, 15.0, 60.0)                        # starts 15 m east of the line
    assert barrier_detour_m(HERE, GOAL, 0.0, beside, list(range(len(beside))), 10.0) == 0.0
    # past the west end of a wall, flying on to the goal: nothing left to go round
    wide = wall(100.0, -30.0, 30.0)
    here = np.array([96.5, -41.0])
    heading = math.atan2(41.0, 83.5)
    assert barrier_detour_m(here, GOAL, heading, wide, list(range(len(wide))), 10.0) < 1.0


def test_a_deck_too_near_to_sink_under_at_cruise_speed_is_offered_under_slowed():
    # a deck 16-19 m up, 22 m ahead: under at 5 m needs ~4 s to sink, 20 m at 5 m/s; 12 m left
    rows = wall(22.0, -12.0, 12.0)
    deck = [v3.Extent(19.0, 0.03, bottom_m=16.0, bottom_seen=True)] * len(rows)
    plans = {p.kind: p for p in v3.plans(HERE, 10.0, rows, deck, PARAMS, np.array([1.0, 0.0]),
                                         5.0)}
    assert "under" not in plans or len(plans["under"].skip) < len(rows)
    slow = plans["under-slow"]
    assert slow.altitude_m == pytest.approx(16.0 - 10.0 - 1.0)
    assert slow.skip == frozenset(range(len(rows))) and 0.0 < slow.speed_mps < 5.0
