"""Issue 15 item 4: a real stereo camera's noise (sigma_r = 0.01 + 0.0015 r^2, 1 deg bearing, no
ids) on random dense worlds (config/scenarios/realistic.yaml), the filter matched to it."""
import pytest

from tests.test_simulate import simulate

REALISTIC = "config/scenarios/realistic.yaml"


def check(report, success):
    agg = report["aggregate"]
    assert agg["collision_rate"] == 0.0
    assert agg["success_rate"] >= success
    assert agg["min_clearance_m"]["p5"] >= 9.5
    # The matched filter is consistent: the runs' averaged pose NEES inside its 95% band.
    assert agg["nees"]["in_band_fraction"] >= 0.9


def test_realistic_camera_on_the_paper_world(tmp_path):
    check(simulate(tmp_path, "--scenario", REALISTIC, "--runs", "5"), success=1.0)


@pytest.mark.slow
def test_realistic_dense_worlds_acceptance(tmp_path):
    check(simulate(tmp_path, "--scenario", REALISTIC, "--random-worlds", "dense", "--runs", "100"),
          success=0.97)
