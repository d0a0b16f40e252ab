"""The seen space's bounded grid (core/avoidance/seen_space.py, keep_m: the bounded map's)."""
import math

import numpy as np

from companion.core.avoidance.seen_space import SeenSpace


def test_a_long_route_keeps_the_grid_bounded_and_the_margins_near_the_camera():
    fov, rng_m = math.radians(87.0), 20.0
    full = SeenSpace(fov, rng_m)
    kept = SeenSpace(fov, rng_m, keep_m=100.0)
    sizes = []
    rng = np.random.default_rng(3)
    for k in range(2500):                      # 5 km north, 2 m a frame, the nose wandering
        pose = np.array([2.0 * k, 5.0 * math.sin(0.01 * k), rng.normal(0.0, 0.3)])
        full.mark(pose)
        kept.mark(pose)
        sizes.append(kept._seen.size)
        if k % 250 == 249:
            around = pose[:2] + rng.uniform(-25.0, 25.0, (200, 2))
            # near the camera the answer is the unbounded grid's, to the bit
            np.testing.assert_array_equal(kept.margin(around), full.margin(around))
    assert full._seen.size > 5 * max(sizes[-500:])     # the unbounded grid grew with the route
    assert max(sizes[1000:]) <= max(sizes[:1000]) * 1.01 + 1  # the kept one stopped growing
    # far behind, forgotten: as never seen
    assert kept.margin(np.array([[10.0, 0.0]]))[0] == 0.0
