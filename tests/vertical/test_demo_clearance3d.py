"""The demo's score in 3D (companion/tools/clearance3d.py): over a wall's top the vertical gap
counts; an unbounded obstacle's figures are the 2D ones."""
import math

from companion.tools.clearance3d import gaps_m, row_altitude_m


def test_over_a_top_the_vertical_gap_joins_in_and_an_unbounded_column_stays_2d():
    assert gaps_m(3.0, 1.0, 14.0, (0.0, 3.0)) == (math.hypot(3.0, 11.0), math.hypot(2.0, 11.0))
    assert gaps_m(0.5, 1.0, 14.0, (0.0, 3.0)) == (math.hypot(0.5, 11.0), 11.0)  # above it
    assert gaps_m(0.5, 1.0, 2.0, (0.0, 3.0)) == (0.5, -0.5)                     # inside it
    assert gaps_m(3.0, 1.0, 14.0, (0.0, math.inf)) == (3.0, 2.0)
    assert gaps_m(3.0, 1.0, -0.05, (0.0, math.inf)) == (3.0, 2.0)    # on the ground, no base
    assert gaps_m(3.0, 1.0, 4.0, (14.0, 16.0)) == (math.hypot(3.0, 10.0), math.hypot(2.0, 10.0))
    assert gaps_m(3.0, 1.0, None, (0.0, 3.0)) == (3.0, 2.0)
    assert row_altitude_m({"up_m": 4}) == 4.0 and row_altitude_m({"alt_m": 5}) == 5.0
    assert row_altitude_m({}) is None
