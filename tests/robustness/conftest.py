"""Shared fixtures of the robustness suite: a real recorded flight, and a tally of fuzz cases and
rejections printed in the terminal summary (so a run says how much it actually tried)."""
from __future__ import annotations

from collections import Counter

import pytest

from companion.mavlink import codec
from tests.e2e.support import (GroundStation, companion_setpoints, read_tlog,
                               start_companion, start_stub, wait_until, write_config)
from tests.robustness.support import Recording, fresh_pipeline

CASES: Counter = Counter()          # fuzz cases run, by test
REJECTED: Counter = Counter()       # rejections counted during the fuzz runs, by kind


def pytest_terminal_summary(terminalreporter) -> None:
    if not CASES:
        return
    terminalreporter.section("robustness: fuzz cases and rejections")
    for name, count in sorted(CASES.items()):
        terminalreporter.write_line(f"cases {name}: {count}")
    terminalreporter.write_line(f"cases total: {sum(CASES.values())}")
    for kind, count in sorted(REJECTED.items()):
        terminalreporter.write_line(f"rejected {kind}: {count}")


@pytest.fixture(scope="session")
def tally():
    """tally(name, rejected=...) after each case: counts cases and rejections by kind."""
    def add(name: str, rejected: dict | None = None) -> None:
        CASES[name] += 1
        REJECTED.update(rejected or {})
    return add


@pytest.fixture(scope="session")
def recording(tmp_path_factory) -> Recording:
    """One short flight of the paper's scenario (stub + daemon + ground station), recorded by
    the daemon's tlog; the stream the daemon received, packet by packet."""
    tmp = tmp_path_factory.mktemp("recording")
    stub, tcp_port, udp_port = start_stub(tmp, "--speedup", "10", "--seed", "1", lockstep=True)
    processes = [stub]
    try:
        config = write_config(tmp, goal=(180.0, 0.0))
        tlog = tmp / "flight.tlog"
        daemon = start_companion(tmp, f"udpout:127.0.0.1:{udp_port}", config, "--tlog", str(tlog),
                                 lockstep=True)
        processes.append(daemon)
        gcs = GroundStation(tcp_port)
        gcs.fly_from_the_ground()
        # 15 s of flight at 10 Hz: past the start, into the first obstacles
        wait_until(lambda: len(companion_setpoints(read_tlog(tlog))) >= 150, 30.0,
                   "150 setpoints from the companion")
        gcs.close()
    finally:
        for process in reversed(processes):
            if process.proc.poll() is None:
                process.stop()
    packets = [(t_us, bytes(msg.get_msgbuf())) for t_us, msg in read_tlog(tlog)
               if msg.get_srcComponent() != 191]
    assert len(packets) > 500
    return Recording(packets, config)


@pytest.fixture(scope="session")
def primed(recording):
    """A pipeline that has absorbed the first 60% of the flight (estimator running, armed in
    GUIDED, landmarks in the map), and the rest of the stream: deep-copied per case."""
    messages = recording.messages()
    cut = int(len(messages) * 0.6)
    pipeline = fresh_pipeline(recording)
    for t_s, msg in messages[:cut]:
        pipeline.handle(t_s, codec.decode(msg))
    # stop where no position waits for its attitude, so injected cases start from a clean state
    while pipeline.attitude.held is not None and cut < len(messages) - 1:
        pipeline.handle(messages[cut][0], codec.decode(messages[cut][1]))
        cut += 1
    assert pipeline.attitude.held is None
    assert pipeline.navigator is not None and pipeline.navigator.slam.landmark_count >= 1
    assert pipeline.commanding_allowed(messages[cut - 1][0])
    return pipeline, [(t, bytes(m.get_msgbuf())) for t, m in messages[cut:]]
