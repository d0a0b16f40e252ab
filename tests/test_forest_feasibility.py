"""benchmarks/forest_feasibility.py: the widest passage through a known row of trees."""
import numpy as np
import pytest

from benchmarks.forest_feasibility import bottleneck_clearance_m


def test_a_wall_of_trees_with_one_gap_is_passed_at_half_the_gap():
    # Trees every 1 m across the way (no passage between them at 0.5 m) but one gap of 3 m:
    # the best path goes through the gap's middle, 1.5 m from the trees on either side.
    east = np.concatenate([np.arange(-20.5, -1.0, 1.0), np.arange(1.5, 21.0, 1.0)])  # gap -1.5..1.5
    centres = np.column_stack([np.full(east.size, 10.0), east])
    c = bottleneck_clearance_m(centres, (0.0, 0.0), (20.0, 0.0), (-1.0, -20.0), (21.0, 20.0),
                               resolution_m=0.02, bisections=14)
    assert c == pytest.approx(1.5, abs=0.03)


def test_a_closed_wall_leaves_only_the_spacing_between_its_trees():
    east = np.arange(-20.0, 20.5, 1.0)
    centres = np.column_stack([np.full(east.size, 10.0), east])
    c = bottleneck_clearance_m(centres, (0.0, 0.0), (20.0, 0.0), (-1.0, -20.0), (21.0, 20.0),
                               resolution_m=0.02, bisections=14)
    assert c == pytest.approx(0.5, abs=0.03)
