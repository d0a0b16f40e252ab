"""simulation.pose_nees against filterpy's NEES, which it writes out for one estimate: random
poses and covariances (well and badly conditioned), equal to the last bit."""
import math

import numpy as np
import pytest
from filterpy.stats import NEES

from companion.core.geometry import wrap_angle
from companion.sim.simulation import pose_nees


def filterpy_pose_nees(true_pose, est_pose, cov):
    error = true_pose - est_pose
    error[2] = wrap_angle(error[2])
    return float(NEES(error[None, :], np.zeros((1, 3)), cov[None, :, :])[0])


def test_pose_nees_is_filterpys_bit_for_bit():
    rng = np.random.default_rng(5)
    for case in range(500):
        true_pose = np.array([*rng.uniform(-200.0, 200.0, 2), rng.uniform(-math.pi, math.pi)])
        est_pose = true_pose + rng.normal(0.0, [1.0, 1.0, 0.2]) * rng.uniform(0.0, 3.0)
        basis = rng.normal(size=(3, 3))
        spread = 10.0 ** rng.uniform(-6.0, 2.0, 3) if case % 2 else rng.uniform(0.01, 4.0, 3)
        cov = basis @ np.diag(spread) @ basis.T + 1e-9 * np.eye(3)
        assert pose_nees(true_pose, est_pose, cov) == \
            filterpy_pose_nees(true_pose, est_pose, cov)


def test_a_non_finite_covariance_is_refused_as_filterpys_was():
    cov = np.eye(3)
    cov[1, 1] = math.nan
    with pytest.raises(ValueError):
        filterpy_pose_nees(np.zeros(3), np.ones(3), cov)
    with pytest.raises(ValueError):
        pose_nees(np.zeros(3), np.ones(3), cov)


@pytest.mark.parametrize("runs", [1, 2, 3, 7, 10, 30, 99, 100, 1000])
@pytest.mark.parametrize("dim", [2, 3])
def test_the_nees_band_is_scipy_stats_chi2_bit_for_bit(runs, dim):
    from scipy.stats import chi2
    from companion.sim.aggregate import nees_band
    tail = (1.0 - 0.95) / 2.0                      # as nees_band's 95% (0.025 + 2e-17)
    lo, hi = chi2.ppf([tail, 1.0 - tail], runs * dim)
    assert nees_band(runs, dim) == (float(lo / runs), float(hi / runs))
