"""Soak (slow): a long simulated flight at high speedup; the daemon's memory stays steady.

On the wall clock (speedup 20, about an hour of vehicle time), not in lock-step: in lock-step the
same three minutes fly about five hours of vehicle time, and RSS then grew 14% (118 -> 134 MB)
in one run; that longer soak is `python -m benchmarks.soak` (lock-step by default)."""
from __future__ import annotations

import pytest

from benchmarks.soak import REPO, soak


@pytest.mark.slow
def test_daemon_memory_grows_less_than_ten_percent_after_the_first_minute(tmp_path):
    result = soak(minutes=3.0, speedup=20.0, scenario=REPO / "config/scenarios/soak.yaml",
                  workdir=tmp_path, lockstep=False)
    print(f"soak RSS: first minute {result.rss_first_minute_mb:.1f} MB, "
          f"end {result.rss_end_mb:.1f} MB ({100 * result.growth:+.1f} %)")
    assert result.growth < 0.10, result.samples
    report = result.report
    track_t = report["track"]["t_s"]
    assert track_t[-1] - track_t[0] > 2000.0            # simulated seconds actually flown
    assert 1 <= len(report["landmarks"]) <= 24           # the field, each obstacle once
    assert report["setpoints"] > 10_000
