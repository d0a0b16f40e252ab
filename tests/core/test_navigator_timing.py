"""The navigator on message clocks: frames wait for the odometry that covers them, and a frame
whose own odometry sample was lost is observed at its time, not at the next sample's."""
import math

import numpy as np
import pytest

from companion.core.estimation.slam_types import AssociationGates, Observation, SlamNoise
from companion.core.geometry import observe
from companion.core.avoidance.guidance import GuidanceParams
from companion.core.navigation.navigator import Navigator

NOISE = SlamNoise(0.3, math.radians(0.02), 0.1, 0.1, math.radians(0.01))
PARAMS = GuidanceParams(5.0, 10.0, 4.0, 1.25, 2.0)
LANDMARK = np.array([30.0, 6.0])


def navigator():
    return Navigator(np.zeros(3), np.eye(3) * 1e-8, NOISE, AssociationGates(), PARAMS,
                     np.array([200.0, 0.0]), "union")


def frame_at(t_s: float) -> list[Observation]:
    z = observe(np.array([5.0 * t_s, 0.0, 0.0]), LANDMARK)      # the truth flies north at 5 m/s
    return [Observation(z[0], z[1], 1)]


@pytest.mark.parametrize("lost", [False, True])
def test_frame_is_observed_at_its_own_time(lost):
    nav = navigator()
    nav.on_odometry(0.0, 5.0, 0.0)
    assert nav.on_observations(0.1, frame_at(0.1)) == []           # waits for odometry at 0.1
    if not lost:
        reports = nav.on_odometry(0.1, 5.0, 0.0)
    reports = nav.on_odometry(0.2, 5.0, 0.0) if lost else reports
    assert [r.action for r in reports] == ["added"]
    # Mapped from the pose at 0.1 s (0.5 m north of the start), not from the pose at 0.2 s.
    assert np.hypot(*(nav.slam.landmarks()[0] - LANDMARK)) < 0.01
    assert nav.slam.pose[0] == pytest.approx(5.0 * nav.t_s)


def test_split_interval_keeps_the_speed_variance_of_one_sample():
    whole, split = navigator(), navigator()
    for nav in (whole, split):
        nav.on_odometry(0.0, 5.0, 0.0)
    split.on_observations(0.05, [])                               # an empty frame mid-interval
    whole.on_odometry(0.1, 5.0, 0.01)
    split.on_odometry(0.1, 5.0, 0.01)
    # Same heading; the position differs only by where the turn happens along the interval
    # (the model turns, then flies: split, half the turn comes halfway).
    assert split.slam.mean[2] == pytest.approx(whole.slam.mean[2], abs=1e-12)
    assert np.allclose(split.slam.mean[:2], whole.slam.mean[:2], atol=2e-3)
    # One speed error over 0.1 s: north variance 0.3^2 * 0.1^2, whether predicted whole or split.
    assert split.slam.cov[0, 0] == pytest.approx(whole.slam.cov[0, 0], rel=1e-3)
    assert whole.slam.cov[0, 0] == pytest.approx(0.09 * 0.01, rel=1e-3)


def test_stale_and_non_finite_input_is_refused_and_counted():
    nav = navigator()
    nav.on_odometry(1.0, 5.0, 0.0)
    assert nav.on_odometry(0.9, 5.0, 0.0) == []
    assert nav.on_odometry(1.1, float("nan"), 0.0) == []
    nav.on_observations(1.0, [Observation(float("inf"), 0.1, 3), Observation(-2.0, 0.1, 4)])
    assert nav.rejected == {"odometry_not_newer": 1, "odometry_not_finite": 1,
                            "observation_not_finite": 1, "observation_range_not_positive": 1}
    assert nav.slam.landmark_count == 0 and nav.slam.is_healthy()
