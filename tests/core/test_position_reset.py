"""core/estimation/position_reset.py: when refused fixes restart the estimate (EKF3's 7 s position
timeout), and the variance an unaided velocity adds over an outage."""
from __future__ import annotations

import math

import pytest

from companion.core.estimation.position_reset import PositionResetParams, PositionResetWatch, UnaidedDrift


def test_fixes_refused_for_seven_seconds_reset_once():
    watch = PositionResetWatch()
    verdicts = [watch.on_fix(100.0 + k, "outlier", (30.0, 40.0)) for k in range(9)]
    assert [v.reset for v in verdicts] == [False] * 7 + [True, False]
    assert verdicts[7].refused_for_s == pytest.approx(7.0) and verdicts[7].offset_m == 50.0
    assert verdicts[8].refused_for_s == 0.0            # a new count after the reset


def test_a_fused_fix_or_a_gap_starts_the_count_afresh():
    watch = PositionResetWatch()
    for k in range(6):
        assert not watch.on_fix(float(k), "outlier", (30.0, 0.0)).reset
    assert watch.on_fix(6.0, "position", (1.0, 0.0)).reason == "fused"
    assert not any(watch.on_fix(7.0 + k, "outlier", (30.0, 0.0)).reset for k in range(7))
    # the fixes stopped coming (the position untrusted again) for longer than max_gap_s
    assert watch.on_fix(20.0, "outlier", (30.0, 0.0)).refused_for_s == 0.0


def test_never_when_switched_off_and_bad_params_are_refused():
    watch = PositionResetWatch(PositionResetParams(after_s=None))
    assert not any(watch.on_fix(float(k), "outlier", (99.0, 0.0)).reset for k in range(100))
    with pytest.raises(ValueError):
        PositionResetParams(after_s=0.0)
    with pytest.raises(ValueError):
        UnaidedDrift(-0.1)


def test_unaided_drift_adds_a_constant_velocity_errors_variance():
    """Over an outage of T seconds the added variance sums to (sigma T)^2, whatever the steps;
    nothing before the position was first trusted, nothing once it is trusted again."""
    drift = UnaidedDrift(0.1)
    assert sum(drift.step(0.1 * k, aided=False) for k in range(50)) == 0.0   # start-up
    assert drift.step(5.0, aided=True) == 0.0
    added = sum(drift.step(5.0 + 0.1 * k, aided=False) for k in range(0, 1201))
    assert added == pytest.approx((0.1 * 120.0) ** 2)
    assert drift.step(125.1, aided=True) == 0.0
    assert drift.step(125.2, aided=False) == 0.0        # a new spell starts from nothing
    assert drift.step(126.2, aided=False) == pytest.approx(0.01)
    assert math.isclose(UnaidedDrift(0.0).step(200.0, aided=False), 0.0)
