"""Scenario text with walls and buildings, edited per test (both loaders read the same file)."""
WALLS = open("config/scenarios/walls.yaml").read()
WALL_LINE = ("    - {id: 10, start: {north_m: 65.0, east_m: -25.0}, end: {north_m: 65.0, east_m: 8.0}, "
             "thickness_m: 0.4}")
CORNERS = """        - {north_m: 100.0, east_m: -4.0}
        - {north_m: 112.0, east_m: -2.0}
        - {north_m: 118.0, east_m: -12.0}
        - {north_m: 112.0, east_m: -22.0}
        - {north_m: 100.0, east_m: -20.0}
"""


def corners_text(points) -> str:
    return "".join(f"        - {{north_m: {n}, east_m: {e}}}\n" for n, e in points)


# (edit of walls.yaml, key the error must name, words the problem must hold), for both loaders
BAD_SHAPES = [
    (WALL_LINE, WALL_LINE.replace("end: {north_m: 65.0, east_m: 8.0}",
                                  "end: {north_m: 65.0, east_m: -25.0}"),
     "world.walls[0].end", "zero-length wall"),
    (WALL_LINE, WALL_LINE.replace("thickness_m: 0.4", "thickness_m: 0"),
     "world.walls[0].thickness_m", ""),
    (WALL_LINE, WALL_LINE.replace("thickness_m: 0.4", "thickness_m: .nan"),
     "world.walls[0].thickness_m", "finite"),
    (WALL_LINE, WALL_LINE.replace("east_m: 8.0}", "east_m: .inf}"),
     "world.walls[0].end.east_m", "finite"),
    (WALL_LINE, WALL_LINE.replace("id: 10", "id: 1"), "world.walls[0].id", "duplicate"),
    (CORNERS, corners_text([(100, -4), (112, -2), (104, -10), (112, -22), (100, -20)]),
     "world.buildings[0].corners", "not convex: the outline turns the other way at corner 2"),
    (CORNERS, corners_text([(100, -4), (112, -2)]), "world.buildings[0].corners", "at least 3"),
    (CORNERS, corners_text([(100, -4), (112, -2), (112, -2), (100, -20)]),
     "world.buildings[0].corners", "corners 1 and 2 are the same point"),
    (CORNERS, corners_text([(100, -4), (110, -4), (120, -4)]), "world.buildings[0].corners",
     "one line"),
    # a pentagram: every turn the same way, but it winds round twice
    (CORNERS, corners_text([(110, -2), (104, -20), (118, -8), (102, -8), (116, -20)]),
     "world.buildings[0].corners", "crosses itself"),
    (CORNERS, corners_text([(100, -4), (112, -2), (118, -12), (112, "nan")]),
     "world.buildings[0].corners[3].east_m", ""),
    (CORNERS, corners_text([(10, -4), (30, -4), (30, 4), (10, 4)]), "world.start",
     "start lies inside building 20"),
    ("  form: sectors", "  form: centres", "sensor.form", "centres cannot see walls"),
]
