"""Ray casting and surface distance against walls and convex buildings, with hand-derived
numbers, for companion simulate's truth (companion/core/shapes.py) and the stub's own
(sitl_stub/shapes.py): each checked against the same figures."""
import math

import numpy as np
import pytest

from companion.core import shapes
from sitl_stub import shapes as stub_shapes

# A wall along east from (20, -5) to (20, 5), 1 m thick: the rectangle north 19.5..20.5,
# east -5..5. A square building north 30..40, east 10..20.
WALL = shapes.wall_corners(np.array([20.0, -5.0]), np.array([20.0, 5.0]), 1.0)
SQUARE = shapes.as_counter_clockwise(np.array([[30.0, 10.0], [40.0, 10.0], [40.0, 20.0],
                                               [30.0, 20.0]]))
STUB_WALL = stub_shapes.wall_outline((20.0, -5.0), (20.0, 5.0), 1.0)
STUB_SQUARE = stub_shapes.counter_clockwise([(30.0, 10.0), (40.0, 10.0), (40.0, 20.0),
                                             (30.0, 20.0)])


def unit(heading_deg):
    a = math.radians(heading_deg)
    return np.array([[math.cos(a), math.sin(a)]])


def test_the_wall_is_the_rectangle_round_its_centre_line():
    assert sorted(map(tuple, WALL.tolist())) == [(19.5, -5.0), (19.5, 5.0), (20.5, -5.0),
                                                 (20.5, 5.0)]
    assert shapes.signed_area_m2(WALL) == pytest.approx(10.0)          # 10 m x 1 m, CCW
    assert sorted(STUB_WALL) == [(19.5, -5.0), (19.5, 5.0), (20.5, -5.0), (20.5, 5.0)]


# (origin, heading deg, polygon, range): straight at the wall's face 19.5 m off; 10 deg off it,
# 19.5 / cos 10 deg = 19.8008 m (east 3.44 m, on the face); 30 deg off, the face ends at
# east 5 < 19.5 tan 30 = 11.3 and the ray's east = 5 m comes at north 8.7, short of the wall:
# no hit; along the wall's centre line from its west end, the end face at 1 m; at the square
# from its south-west: from (35, 0) east, 10 m; from (0, 15) north, 30 m; from inside (35, 15)
# north, 5 m to the way out; a ray along an edge's line past the square: no hit.
CASES = [
    ((0.0, 0.0), 0.0, "wall", 19.5),
    ((0.0, 0.0), 10.0, "wall", 19.5 / math.cos(math.radians(10.0))),
    ((0.0, 0.0), 30.0, "wall", math.inf),
    ((20.0, -6.0), 90.0, "wall", 1.0),
    ((0.0, 0.0), 180.0, "wall", math.inf),
    ((35.0, 0.0), 90.0, "square", 10.0),
    ((0.0, 15.0), 0.0, "square", 30.0),
    ((35.0, 15.0), 0.0, "square", 5.0),
    ((0.0, 25.0), 0.0, "square", math.inf),
]


@pytest.mark.parametrize("origin,heading_deg,which,expected", CASES)
def test_ray_cast_meets_the_first_surface(origin, heading_deg, which, expected):
    corners = WALL if which == "wall" else SQUARE
    got = shapes.ray_cast_polygon(np.array(origin), unit(heading_deg), corners)[0]
    outline = STUB_WALL if which == "wall" else STUB_SQUARE
    u = unit(heading_deg)[0]
    stub = stub_shapes.ray_distance_m(origin[0], origin[1], u[0], u[1], outline)
    if math.isinf(expected):
        assert math.isinf(got) and math.isinf(stub)
    else:
        assert got == pytest.approx(expected, abs=1e-9)
        assert stub == pytest.approx(expected, abs=1e-9)


# Point to surface: 10 m south of the square's south face; the corner (40, 20) from (45, 25),
# sqrt(50); inside at (35, 12), 2 m from the east-side face at east 10 (negative); the wall's
# face from the origin, 19.5 m; its end from (20, 8), 3 m.
DISTANCES = [((35.0, 0.0), "square", 10.0), ((45.0, 25.0), "square", math.sqrt(50.0)),
             ((35.0, 12.0), "square", -2.0), ((0.0, 0.0), "wall", 19.5),
             ((20.0, 8.0), "wall", 3.0), ((20.0, 0.0), "wall", -0.5)]


@pytest.mark.parametrize("point,which,expected", DISTANCES)
def test_surface_distance_is_negative_inside(point, which, expected):
    corners, outline = (WALL, STUB_WALL) if which == "wall" else (SQUARE, STUB_SQUARE)
    assert shapes.polygon_distance_m(np.array(point), corners)[0] == pytest.approx(expected)
    assert stub_shapes.surface_distance_m(*point, outline) == pytest.approx(expected)


def test_circles_ray_cast_and_distance():
    # a circle of radius 2 at (10, 0): straight at it 8 m; offset 1 m east of its centre line,
    # 10 - sqrt(4 - 1) = 8.268 m; from inside (10, 0), 2 m to its far side
    centres, radii = np.array([[10.0, 0.0]]), np.array([2.0])
    assert shapes.ray_cast_circles(np.zeros(2), unit(0.0), centres, radii)[0] == pytest.approx(8.0)
    assert shapes.ray_cast_circles(np.array([0.0, 1.0]), unit(0.0), centres, radii)[0] == \
        pytest.approx(10.0 - math.sqrt(3.0))
    assert shapes.ray_cast_circles(np.array([10.0, 0.0]), unit(0.0), centres, radii)[0] == \
        pytest.approx(2.0)
    assert shapes.circle_distance_m(np.array([0.0, 0.0]), centres, radii)[0, 0] == \
        pytest.approx(8.0)


def test_convexity_problems_name_the_corner():
    assert shapes.convexity_problem(SQUARE) is None
    assert shapes.convexity_problem(SQUARE[::-1]) is None                  # either way round
    dent = np.array([[0.0, 0.0], [10.0, 0.0], [2.0, 2.0], [0.0, 10.0]])
    assert shapes.convexity_problem(dent) == "not convex: the outline turns the other way at corner 2"
    assert stub_shapes.outline_problem([tuple(p) for p in dent]) == \
        "not convex: the outline turns the other way at corner 2"
    collinear = [(0.0, 0.0), (5.0, 0.0), (10.0, 0.0), (10.0, 10.0)]     # a straight corner is fine
    assert shapes.convexity_problem(np.array(collinear)) is None
    assert stub_shapes.outline_problem(collinear) is None
