"""SIGTERM/SIGINT while commanding: one stop setpoint (velocity 0, current yaw), then exit 0 within
1 s (issue 14). Without it the vehicle coasts on its last velocity until GUID_TIMEOUT."""
from __future__ import annotations

import math
import signal
import time

import pytest

from tests.e2e.support import companion_setpoints, read_tlog
from tests.e2e.test_daemon import flight, long_scenario  # noqa: F401 - fixtures


@pytest.mark.parametrize("signum", [signal.SIGTERM, signal.SIGINT])
def test_a_signal_while_commanding_sends_one_stop_setpoint_then_exits_0(flight, signum):  # noqa: F811
    stub, companion, gcs, tlog = flight
    started = time.monotonic()
    companion.proc.send_signal(signum)
    code = companion.proc.wait(timeout=10.0)
    took_s = time.monotonic() - started
    assert code == 0, companion.stderr()
    # Prompt, not hanging on a task: the 1 s of the issue is an idle
    # machine's figure; beside other work a bound in wall time must leave room for the scheduler.
    assert took_s < 5.0
    sent = companion_setpoints(read_tlog(tlog))
    *flying, last = sent
    assert math.hypot(flying[-1].vx, flying[-1].vy) > 1.0          # it was flying
    assert (last.vx, last.vy, last.vz) == (0.0, 0.0, 0.0)
    assert math.isfinite(last.yaw) and abs(last.yaw) <= math.pi
    assert abs(last.yaw - flying[-1].yaw) < 0.5                   # the current yaw, not 0
    # exactly one: the setpoint before it was still flying (earlier holds, e.g. before the
    # camera's first frame, are not this)
    assert "stop setpoint sent" in companion.stderr()
