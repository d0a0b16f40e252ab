"""Issue 16 item 2: a mover out of view stays in the decision with growing uncertainty. A
confirmed track's position sigma, and a landmark on probation flown round as a mover's
extrapolation, widen its safety distance in the velocity choice (guide_union's spread_m)."""
import math

import numpy as np
import pytest

from companion.core.navigation import decider as decider_module
from companion.core.avoidance.arc import VehicleLimits
from companion.core.estimation.slam_types import AssociationGates, Observation, SlamNoise
from companion.core.geometry import observe
from companion.core.avoidance.guidance import GuidanceParams
from companion.core.estimation.movers import MoverParams, MoverTracker, mover_spread
from companion.core.navigation.navigator import Navigator
from companion.core.navigation.obstacle_view import SPREAD_MIN_UPDATES
from companion.core.avoidance.union import UnionParams

LIMITS = VehicleLimits(math.radians(30.0), 2.5)
NOISE = SlamNoise(0.3, math.radians(0.02), 0.1, 0.1, math.radians(0.01))


def params() -> GuidanceParams:
    return GuidanceParams(cruise_speed_mps=5.0, safety_distance_m=10.0, horizon_s=4.0, eta=1.25,
                          goal_radius_m=2.0)


def tracker_with(sightings: list[int]) -> MoverTracker:
    """One track per entry, each updated that many times (5 Hz, a mover at 4 m/s east)."""
    tracker = MoverTracker(MoverParams())
    cov = np.eye(2) * 0.01
    for count in sightings:
        track = tracker.create(0.0, np.array([20.0, 0.0]), cov, None)
        for k in range(1, count + 1):
            tracker.update(track, 0.2 * k, np.array([20.0, 0.8 * k]), cov)
    return tracker


def test_only_a_confirmed_coasting_track_is_widened_and_more_the_longer_it_coasts():
    tracker = tracker_with([SPREAD_MIN_UPDATES, 1])
    soon, later = tracker.states(2.0), tracker.states(6.0)
    spread_soon = mover_spread(soon, 5, 1.0, SPREAD_MIN_UPDATES)
    spread_later = mover_spread(later, 5, 1.0, SPREAD_MIN_UPDATES)
    assert spread_soon[:3].tolist() == [0.0, 0.0, 0.0]          # the static rows come first
    assert spread_soon[4] == 0.0 and spread_later[4] == 0.0     # one sighting: clutter, maybe
    worst = math.sqrt(np.linalg.eigvalsh(later[0].position_cov)[-1])
    assert spread_later[3] == pytest.approx(worst)
    assert spread_later[3] > spread_soon[3] > 0.0
    assert mover_spread(tracker_with([1, 2]).states(3.0), 4, 1.0, SPREAD_MIN_UPDATES) is None


def navigator() -> Navigator:
    return Navigator(np.zeros(3), np.eye(3) * 1e-8, NOISE, AssociationGates(), params(),
                     np.array([200.0, 0.0]), "union",
                     UnionParams(fov_rad=math.radians(90), sensor_range_m=40.0), limits=LIMITS)


def test_the_velocity_choice_is_given_a_confirmed_tracks_spread(monkeypatch):
    nav = navigator()
    nav.on_odometry(0.0, 5.0, 0.0)
    confirmed = nav.movers.create(0.0, np.array([30.0, -10.0]), np.eye(2) * 0.01, 7)
    for k in range(1, SPREAD_MIN_UPDATES + 1):
        nav.movers.update(confirmed, 0.2 * k, np.array([30.0, -10.0 + 0.8 * k]), np.eye(2) * 0.01)
    nav.movers.create(1.0, np.array([60.0, 10.0]), np.eye(2) * 0.01, 8)     # seen once
    for step in range(1, 31):                        # 3 s with nothing in view
        nav.on_odometry(0.1 * step, 5.0, 0.0)
    seen = {}
    real = decider_module.guide_flyable

    def spy(inputs, *args):
        seen["spread"] = inputs.spread_m
        return real(inputs, *args)
    monkeypatch.setattr(decider_module, "guide_flyable", spy)
    nav.decide(3.0)
    states = nav.movers.states(nav.clock_s)
    spread = seen["spread"]
    assert spread is not None and len(spread) == 2              # no landmarks: two mover rows
    assert spread[0] == pytest.approx(math.sqrt(np.linalg.eigvalsh(states[0].position_cov)[-1]))
    assert spread[1] == 0.0


def test_a_mover_on_probation_out_of_view_spreads_by_its_velocity_sigma_times_its_age():
    """A crossing mover seen for 0.6 s, then not again: where the guidance puts it is its
    apparent velocity's extrapolation, as uncertain as that velocity's sigma times the time since
    its sightings; a static post seen as long gets no spread."""
    nav = navigator()
    mover0, velocity = np.array([30.0, -15.0]), np.array([-1.0, 4.0])
    post = np.array([35.0, 12.0])
    for step in range(1, 8):
        t = step * 0.1
        nav.on_odometry(t, 5.0, 0.0)
        if step % 2 == 0:
            pose = np.array([5.0 * t, 0.0, 0.0])
            nav.on_observations(t, [Observation(*observe(pose, mover0 + velocity * t), 1),
                                    Observation(*observe(pose, post), 2)])
    spreads, growths = [], []
    for steps in (range(8, 9), range(9, 19)):       # 0.1 s, then 1.1 s after the last frame
        for step in steps:
            nav.on_odometry(step * 0.1, 5.0, 0.0)
        obstacles, velocities, _, movers = nav.obstacles(young_movers=True)
        growths.append(nav.view.young_motion(obstacles, velocities, None)[2])
        spreads.append(nav.view.spread(movers, len(obstacles), LIMITS.motion(5.0, 0.0)))
    keys = nav.view.guidance_keys
    m, p = keys.index(1), keys.index(2)
    assert spreads[0][p] == 0.0 and spreads[1][p] == 0.0
    assert 0.0 < spreads[0][m] < spreads[1][m]
    # one second apart, the spread has grown by the velocity's sigma (the growth per second)
    assert spreads[1][m] - spreads[0][m] == pytest.approx(growths[1][m], rel=1e-6)
