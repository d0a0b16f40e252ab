"""SeenSpace.mark computes only the cells in the bounding box of the camera's sector: the grid it
marks is the one of computing the whole square of the range, cell for cell."""
import math

import numpy as np

from companion.core.avoidance.seen_space import SeenSpace, _sector_extent


class WholeSquare(SeenSpace):
    """mark as it was: every cell within the range's square computed."""

    def _view_box(self, x, y, yaw, box):
        return box


def test_marking_the_sectors_box_marks_the_same_cells_as_the_whole_square():
    rng = np.random.default_rng(13)
    for case in range(60):
        fov = math.radians(rng.choice([30.0, 60.0, 90.0, 90.0, 120.0, 179.0, 200.0, 360.0]))
        range_m, cell_m = float(rng.uniform(5.0, 45.0)), float(rng.choice([0.5, 1.0, 2.0]))
        keep_m = None if case % 3 else float(rng.uniform(30.0, 80.0))
        narrow, whole = SeenSpace(fov, range_m, cell_m, keep_m), WholeSquare(fov, range_m, cell_m,
                                                                             keep_m)
        pose = np.array([*rng.uniform(-100.0, 100.0, 2), rng.uniform(-math.pi, math.pi)])
        axis = float(rng.choice([0.0, 0.5 * math.pi, math.pi, -0.5 * math.pi]))
        for step in range(40):
            pose = pose + np.array([*rng.normal(0.0, 3.0, 2), rng.normal(0.0, 0.4)])
            if step % 7 == 0:       # along an axis, and the arc's end on one
                pose[2] = axis + (0.5 * fov if step % 14 else 0.0)
            narrow.mark(pose)
            whole.mark(pose)
            assert np.array_equal(narrow._seen, whole._seen)
            assert np.array_equal(narrow._origin, whole._origin)


def test_a_sectors_extent_holds_its_arc_and_apex():
    rng = np.random.default_rng(17)
    for _ in range(500):
        yaw, half = rng.uniform(-4.0, 4.0), rng.uniform(0.01, 3.1)
        low_n, high_n, low_e, high_e = _sector_extent(yaw, half)
        arc = yaw + np.linspace(-half, half, 400)
        assert low_n <= min(0.0, np.cos(arc).min()) + 1e-12
        assert high_n >= max(0.0, np.cos(arc).max()) - 1e-12
        assert low_e <= min(0.0, np.sin(arc).min()) + 1e-12
        assert high_e >= max(0.0, np.sin(arc).max()) - 1e-12
