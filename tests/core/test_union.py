import math

import numpy as np
import pytest

from companion.core.avoidance.guidance import GuidanceInputs, GuidanceParams, guide_cone
from companion.core.avoidance.union import UnionParams, blocking, guide_union, turn_speed_factor

PARAMS = GuidanceParams(cruise_speed_mps=5.0, safety_distance_m=10.0, horizon_s=4.0, eta=1.25,
                        goal_radius_m=2.0)
UNION = UnionParams(lookahead_s=6.0, hysteresis=0.5, fov_rad=math.radians(90))
GOAL = np.array([200.0, 0.0])
POSE = np.array([0.0, 0.0, 0.0])


def test_free_way_flies_at_the_goal():
    command = guide_union(GuidanceInputs(POSE, GOAL, np.array([[20.0, 40.0]]), None, None),
                                         PARAMS, UNION)
    assert command.mode == "goal" and command.heading_rad == pytest.approx(0.0)
    assert command.speed_mps == pytest.approx(5.0)


def test_one_obstacle_head_on_matches_the_paper_deflection():
    # Head-on at 22 m: the paper deflects by eta * asin(d / |X|); the union law leaves the
    # eta-scaled cone at its edge: the same angle, to within the 0.5 degree heading grid.
    obstacle = np.array([[22.0, 0.0]])
    command = guide_union(GuidanceInputs(POSE, GOAL, obstacle, None, None), PARAMS, UNION)
    expected = 1.25 * math.asin(10.0 / 22.0)
    assert command.mode == "avoid" and command.urgent_index == 0
    assert abs(command.heading_rad) == pytest.approx(expected, abs=math.radians(0.6))
    paper = guide_cone(POSE, GOAL, obstacle, None, PARAMS, 0.0)
    assert abs(paper.heading_rad) == pytest.approx(expected, abs=1e-9)


def test_heading_leaves_every_cone_of_an_overlapping_pair():
    # Two obstacles 12 m apart across the path: the paper's law, reacting to one, steers into
    # the gap between them; the union law goes around both.
    obstacles = np.array([[25.0, -6.0], [25.0, 6.0]])
    command = guide_union(GuidanceInputs(POSE, GOAL, obstacles, None, None), PARAMS, UNION)
    blocks = blocking(np.array([command.heading_rad]), POSE[:2], obstacles, np.full(2, 10.0), 1.25, 30.0)
    assert not blocks.any()
    assert abs(command.heading_rad) > math.asin(10.0 / math.hypot(25, 6)) + math.atan2(6, 25)
    paper = guide_cone(POSE, GOAL, obstacles, None, PARAMS, 0.0)
    through_gap = abs(paper.heading_rad) < math.atan2(6, 25)
    assert through_gap


def test_side_commitment_holds_until_the_goal_heading_is_free():
    obstacles = np.array([[25.0, 0.0]])
    first = guide_union(GuidanceInputs(POSE, GOAL, obstacles, None, None, side=0), PARAMS, UNION)
    assert first.side in (1, -1)
    # Committed to the other side, the vehicle keeps to it even though it costs a larger turn.
    other = guide_union(GuidanceInputs(POSE, GOAL, obstacles, None, None, side=-first.side),
                                       PARAMS, UNION)
    assert np.sign(other.heading_rad) == -first.side


def test_no_free_heading_slows_then_holds():
    ring = np.array([[12 * math.cos(a), 12 * math.sin(a)] for a in np.linspace(0, 2 * math.pi, 12, endpoint=False)])
    command = guide_union(GuidanceInputs(POSE, GOAL, ring, None, None), PARAMS, UNION)
    assert command.mode == "hold" and command.speed_mps == 0.0


def test_inside_a_circle_only_opening_headings_are_free():
    obstacle = np.array([[5.0, 0.0]])
    command = guide_union(GuidanceInputs(POSE, GOAL, obstacle, None, None), PARAMS, UNION)
    assert abs(command.heading_rad) >= math.pi / 2 - 1e-9


def test_sharp_turns_slow_down_and_unseen_headings_turn_in_place():
    fov = math.radians(90)
    assert turn_speed_factor(0.0, math.radians(30), fov) == pytest.approx(math.cos(math.radians(30)))
    assert turn_speed_factor(0.0, math.radians(60), fov) == 0.0
    assert turn_speed_factor(3.1, -3.1, fov) == pytest.approx(math.cos(2 * math.pi - 6.2))


def test_mapped_obstacle_behind_does_not_block_and_far_ones_wait():
    behind = guide_union(GuidanceInputs(POSE, GOAL, np.array([[-15.0, 0.0]]), None, None), PARAMS,
                                        UNION)
    assert behind.mode == "goal"
    far = guide_union(GuidanceInputs(POSE, GOAL, np.array([[60.0, 0.0]]), None, None), PARAMS,
                                     UNION)
    assert far.mode == "goal"                 # beyond speed * lookahead: not relevant yet


def test_plain_python_and_numpy_paths_choose_alike():
    """Static obstacles take a plain-Python path for speed; the numpy path (used with movers)
    must make the same choice on the same inputs."""
    from companion.core.avoidance.union import _choose_general, _choose_static
    rng = np.random.default_rng(8)
    compared = avoided = 0
    for _ in range(400):
        n = int(rng.integers(1, 7))
        pose = np.array([0.0, 0.0, rng.uniform(-math.pi, math.pi)])
        obstacles = rng.uniform([-5.0, -30.0], [40.0, 30.0], size=(n, 2))
        radii = np.full(n, 10.0)
        goal_heading = float(rng.uniform(-0.5, 0.5))
        args = (pose, goal_heading, 150.0, 5.0, float(rng.uniform(-1, 1)), int(rng.integers(-1, 2)),
                obstacles, radii, np.arange(n), PARAMS, UNION)
        plain, vectorised = _choose_static(*args), _choose_general(*args, None)
        assert plain.mode == vectorised.mode
        assert plain.heading_rad == pytest.approx(vectorised.heading_rad, abs=1e-9)
        assert plain.speed_mps == pytest.approx(vectorised.speed_mps, abs=1e-9)
        assert (plain.urgent_index, plain.side) == (vectorised.urgent_index, vectorised.side)
        compared += 1
        avoided += plain.mode == "avoid"
    assert compared == 400 and 50 < avoided < 400
