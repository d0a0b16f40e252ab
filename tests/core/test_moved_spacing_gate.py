"""estimator.moved_spacing_gate: a young landmark is taken to have 'moved' to an unassociated
sighting only by at most that fraction of the distance to its nearest other landmark (on in
forest.yaml); off (the default), the mover's speed reach alone (1.5 m + 3 m/s x the gap)."""
import dataclasses
import math

import numpy as np
import pytest

from companion.config.scenario import load_scenario
from companion.config.sections import EstimatorConfig
from companion.core.estimation.movers import MoverParams, MoverTracker
from companion.core.estimation.probation import nearest_other_m, within_spacing
from companion.core.estimation.slam_types import Observation
from companion.errors import ConfigError
from companion.sim.simulation import make_navigator


def navigator(gate):
    base = load_scenario("config/scenarios/forest.yaml")
    estimator = dataclasses.replace(base.estimator, moved_spacing_gate=gate)
    return make_navigator(dataclasses.replace(base, estimator=estimator))


def seen_at(north_m: float, east_m: float) -> Observation:
    """The observation of a point from the vehicle at the origin, nose north (bearing right +)."""
    return Observation(math.hypot(north_m, east_m), math.atan2(east_m, north_m))


def wait(nav, seconds: float) -> None:
    for _ in range(round(seconds / 0.1)):
        nav.predict(0.0, 0.0, 0.1)


def test_the_pure_gate():
    points = np.array([[18.0, 0.0], [18.0, 2.6], [30.0, 0.0]])
    assert nearest_other_m(points, 0) == pytest.approx(2.6)
    assert nearest_other_m(points[:1], 0) == math.inf
    assert within_spacing(1.3, 2.6, 0.5) and not within_spacing(1.31, 2.6, 0.5)
    assert within_spacing(5.0, math.inf, 0.5)          # no neighbour: the speed reach alone


def neighbours_sighting(gate):
    """Trunks A (18, 0) and C (18, 2.6) are mapped, both young; 0.4 s later (A missed for a
    frame) only B, the unmapped trunk 2.5 m on A's other side, is seen: within A's speed reach
    (1.5 m + 3 m/s x 0.4 s = 2.7 m)."""
    nav = navigator(gate)
    assert [r.action for r in nav.observe([seen_at(18.0, 0.0), seen_at(18.0, 2.6)])] \
        == ["added", "added"]
    wait(nav, 0.4)
    report = nav.observe([seen_at(18.0, -2.5)])[0]
    return report.action, nav.estimator.slam.landmarks()


def test_off_a_neighbours_sighting_2_5_m_away_relocates_the_young_landmark():
    action, landmarks = neighbours_sighting(None)
    assert action == "moved" and len(landmarks) == 2
    assert np.hypot(*(landmarks - [18.0, -2.5]).T).min() < 0.1     # A stands on B now
    assert np.hypot(*(landmarks - [18.0, 0.0]).T).min() > 2.0


def test_on_it_starts_the_neighbours_landmark_and_a_stays():
    action, landmarks = neighbours_sighting(0.5)
    assert action == "added" and len(landmarks) == 3
    for point in ([18.0, 0.0], [18.0, 2.6], [18.0, -2.5]):
        assert np.hypot(*(landmarks - point).T).min() < 0.1


def walker(gate, missed: set):
    """A walker at 1.5 m/s crossing 15 m ahead from (15, 4) westward, past two trunks mapped at
    (18, 1) and (18, -2) (3 m from its line), in the camera's 5 Hz frames for 3 s but for the
    ``missed`` ones; the reports of its sightings and the navigator after."""
    nav = navigator(gate)
    nav.observe([seen_at(18.0, 1.0), seen_at(18.0, -2.0)])
    actions = []
    for frame in range(1, 16):
        wait(nav, 0.2)
        trunks = [seen_at(18.0, 1.0), seen_at(18.0, -2.0)]
        if frame in missed:
            nav.observe(trunks)
            continue
        report = nav.observe([seen_at(15.0, 4.0 - 1.5 * 0.2 * frame)] + trunks)
        actions.append(report[0].action)
    return actions, nav


# seen in every frame: its sightings update its landmark (0.3 m a frame is within the gate);
# missed for three frames twice (0.8 s, 1.2 m between sightings: beyond it): 'moved' there
@pytest.mark.parametrize("gate", [None, 0.5])
@pytest.mark.parametrize("missed", [set(), {4, 5, 6, 10, 11, 12}], ids=["seen", "gaps"])
def test_a_walker_at_1_5_m_s_is_still_convicted(gate, missed):
    actions, nav = walker(gate, missed)
    assert nav.movers_detected == 1, actions
    assert len(nav.movers) == 1
    assert len(nav.estimator.slam.landmarks()) == 2, actions  # the two trunks, not the walker
    if missed:
        assert "moved" in actions, actions


def test_the_key_is_read_from_yaml_and_off_by_default():
    assert load_scenario("config/scenarios/forest.yaml").estimator.moved_spacing_gate == 0.5
    assert load_scenario("config/scenarios/copter.yaml").estimator.moved_spacing_gate is None
    assert EstimatorConfig(range_sigma_m=0.1, bearing_sigma_deg=1.0).moved_spacing_gate is None


@pytest.mark.parametrize("bad", [0.0, -0.5, 1.5, math.nan, math.inf])
def test_a_bad_gate_is_refused_naming_the_key(bad):
    with pytest.raises(ValueError, match="moved_spacing_gate: expected a fraction in"):
        EstimatorConfig(range_sigma_m=0.1, bearing_sigma_deg=1.0, moved_spacing_gate=bad)


def test_a_bad_gate_in_yaml_is_refused_with_its_path(tmp_path):
    text = open("config/scenarios/forest.yaml").read()
    assert "  moved_spacing_gate: 0.5" in text
    path = tmp_path / "forest.yaml"
    path.write_text(text.replace("  moved_spacing_gate: 0.5", "  moved_spacing_gate: 2.0"))
    with pytest.raises(ConfigError, match=r"estimator.moved_spacing_gate: expected a fraction"):
        load_scenario(path)


def test_a_track_unseen_for_long_takes_a_far_point_only_without_a_bound():
    """A tree convicted by mistake (forest-dense 10 m/s, seed 67: 3.6 m/s, sigma 0.69 m/s)
    coasts unseen; 20 s on its prediction's sigma is ~14 m, and the NIS gate alone takes a
    point 20 m off it. ``max_jump_m`` refuses that point and still takes one 1 m off."""
    tracker = MoverTracker(MoverParams())
    tid = tracker.create(0.0, np.zeros(2), np.eye(2) * 0.1 ** 2, None,
                         velocity=(np.array([1.88, -3.05]), 0.69))
    predicted = tracker.state(tid, 20.0).position_ne_m
    cov = np.eye(2) * 0.1 ** 2
    far, near = predicted + [12.0, 16.0], predicted + [0.6, 0.8]        # 20 m and 1 m off
    assert tracker.nearest(20.0, far, cov) == tid
    assert tracker.nearest(20.0, far, cov, max_jump_m=5.0) is None
    assert tracker.nearest(20.0, near, cov, max_jump_m=5.0) == tid


def new_tree_beside_a_ghost(gate):
    """Trunks mapped at (18, 1) and (18, -2); a track (a tree convicted by mistake) predicted
    2 m from a tree coming into view at (18, 4), 3 m from the nearest mapped trunk, with a wide
    ellipse (created 10 s ago at 3.6 m/s, sigma 0.7 m/s, unseen since). The report of that
    tree's first sighting and the navigator after."""
    nav = navigator(gate)
    nav.observe([seen_at(18.0, 1.0), seen_at(18.0, -2.0)])
    velocity = np.array([1.88, -3.05])
    start = np.array([18.0, 6.0]) - 10.0 * velocity         # at (18, 6) now: 2 m off the tree
    nav.movers.create(nav.clock_s - 10.0, start, np.eye(2) * 0.1 ** 2, None,
                      velocity=(velocity, 0.7))
    report = nav.observe([seen_at(18.0, 4.0), seen_at(18.0, 1.0), seen_at(18.0, -2.0)])[0]
    return report.action, nav


def test_off_the_ghost_takes_the_new_tree():
    action, nav = new_tree_beside_a_ghost(None)
    assert action == "mover"
    assert len(nav.estimator.slam.landmarks()) == 2                # the tree is not mapped


def test_on_the_new_tree_is_mapped_and_the_ghost_coasts_on():
    action, nav = new_tree_beside_a_ghost(0.5)
    assert action == "added"
    landmarks = nav.estimator.slam.landmarks()
    assert len(landmarks) == 3 and np.hypot(*(landmarks - [18.0, 4.0]).T).min() < 0.1
    assert len(nav.movers) == 1
    assert nav.movers.states(nav.clock_s)[0].updates == 0          # no sighting absorbed
