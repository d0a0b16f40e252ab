"""Issue 33: traffic worlds with every mover at one speed, and how soon a fast head-on mover
enters the multicopter's decision."""
import numpy as np
import pytest

from companion.config.scenario import load_scenario
from companion.sim.worlds import random_world


@pytest.fixture(scope="module")
def copter():
    return load_scenario("config/scenarios/copter.yaml")


def movers(world):
    return [o for o in world.world.obstacles if o.vel_north_mps or o.vel_east_mps]


@pytest.mark.parametrize("kind", ["head-on", "crossing", "overtaking"])
def test_speed_kind_is_the_kind_at_one_speed(copter, kind):
    """Same seed: the same statics, meeting points and headings; every mover at the speed."""
    base = random_world(copter, kind, 67)
    speed = 3.0
    fixed = random_world(copter, f"{kind}-3", 67)
    assert fixed.name == f"{kind}-3-67"
    assert [o for o in fixed.world.obstacles if o not in movers(fixed)] == \
        [o for o in base.world.obstacles if o not in movers(base)]
    for a, b in zip(movers(base), movers(fixed)):
        va, vb = np.array([a.vel_north_mps, a.vel_east_mps]), np.array([b.vel_north_mps, b.vel_east_mps])
        assert np.hypot(*vb) == pytest.approx(speed)
        assert np.arctan2(vb[1], vb[0]) == pytest.approx(np.arctan2(va[1], va[0]))
        # both reach the same meeting point at the same time (start + v t)
        t = (a.east_m - b.east_m) / (vb[1] - va[1]) if abs(vb[1] - va[1]) > 1e-9 else None
        if t is not None:
            assert a.north_m + va[0] * t == pytest.approx(b.north_m + vb[0] * t)


def test_overtaking_faster_than_the_cap_is_refused(copter):
    with pytest.raises(ValueError, match="overtaking at 5 m/s needs a cruise speed"):
        random_world(copter, "overtaking-5", 0)


@pytest.mark.slow
@pytest.mark.parametrize("kind, frames", [("head-on-3", 3), ("head-on-5", 2), ("head-on-7", 2)])
def test_fast_head_on_mover_enters_the_decision_within_the_bound(copter, kind, frames):
    """The bound (docs/copter-headon-failures.md): at 36-40 m the velocity of two frames 0.2 s
    apart is +-0.9 m/s, three frames +-0.45: a mover of >= 4.5 m/s shows motion at 5 sigma in 2
    frames, one of >= 2.25 m/s in 3; it is flown round, still tentative, at the next decision."""
    from benchmarks.mover_timeline import timeline
    world = random_world(copter, kind, 67)
    result = timeline(world, 67)
    first_seen = {o.id: next((t for t, f in result["frames"] if o.id in f), np.inf)
                  for o in movers(world)}
    mover = min(first_seen, key=first_seen.get)        # the first met
    seen = [first_seen[mover]]
    first_young = next(r["t"] for r in result["records"] if mover in r["young"])
    assert first_young - seen[0] <= (frames - 1) * 0.2 + 0.1 + 1e-6
