"""The seeded lock-step paper demo is one flight whatever the machine's load: flown twice, once
beside two CPU-bound processes (as many as the machine has cores), its JSON (less the wall-clock
figures), the vehicle's true path and the companion's estimated track are identical. The quiet
flight is the session's paper demo (tests/conftest.py), flown with the same arguments. The same
holds with --lockstep-overlap (the stub one step ahead of the companion)."""
from __future__ import annotations

import json
import subprocess
import sys

import pytest

from tests.conftest import PAPER_DEMO_ARGS
from tests.e2e.test_demo_replay import companion

WALL_CLOCK_KEYS = ("wall_time_s", "flight_sim_s", "flight_wall_s", "real_time_factor")
BUSY_S = 120.0      # each busy process ends by itself after this, even if the test dies
BUSY = f"import time\nend = time.monotonic() + {BUSY_S}\nwhile time.monotonic() < end: pass\n"


def fly(workdir, *extra):
    done = companion(*PAPER_DEMO_ARGS, *extra, "--json", str(workdir / "demo.json"),
                     "--keep", str(workdir))
    assert done.returncode == 0, done.stdout + done.stderr
    return flown(workdir)


def flown(workdir):
    result = json.loads((workdir / "demo.json").read_text())
    wall = {key: result["aggregate"].pop(key) for key in WALL_CLOCK_KEYS}
    arrival_t_s = result["runs"][0]["time_s"]
    truth = [line for line in (workdir / "truth.jsonl").read_text().splitlines()
             if json.loads(line)["t_s"] <= arrival_t_s + 1.0]
    track = json.loads((workdir / "companion-report.json").read_text())["track"]
    upto = sum(1 for t in track["t_s"] if t <= arrival_t_s)
    track = {name: column[:upto] for name, column in track.items()}
    stub_log = (workdir / "sitl-stub.stderr").read_text()
    return result, truth, track, wall, stub_log


def fly_loaded(workdir, *extra):
    busy = [subprocess.Popen([sys.executable, "-c", BUSY]) for _ in range(2)]
    try:
        loaded = fly(workdir, *extra)
        assert all(p.poll() is None for p in busy)       # the load was there the whole flight
    finally:
        for p in busy:
            p.kill()
            p.wait()
    return loaded


def test_the_lockstep_demo_is_the_same_flight_beside_two_busy_processes(tmp_path, paper_demo):
    quiet = flown(paper_demo.workdir)
    loaded = fly_loaded(tmp_path / "loaded")
    assert_same_flight(quiet, loaded)


def test_overlapped_the_lockstep_demo_flies_locked_to_the_goal(tmp_path, paper_demo):
    """--lockstep-overlap (the stub one step ahead, the setpoints one step later): locked from
    start to end, the goal reached, and not main lock-step's flight (the setpoints land a step
    later). The default run's check; the loaded re-flight below is the slow suite's."""
    overlapped = fly(tmp_path / "quiet", "--lockstep-overlap")
    result, truth, track, wall, stub_log = overlapped
    assert result["runs"][0]["reached_goal"] and len(truth) > 300 and len(track["t_s"]) > 300
    assert "free-running" not in stub_log
    assert result["aggregate"]["lockstep_overlap"] is True
    assert "lock-step on (timeout 3 s, overlapped)" in stub_log
    assert truth != flown(paper_demo.workdir)[1]


@pytest.mark.slow
def test_overlapped_the_lockstep_demo_is_one_flight_too(tmp_path):
    """--lockstep-overlap: the same flight quiet and loaded, though not main lock-step's flight
    (two flights, 19 s: in the slow suite since 2026-12-04, the test above keeps the mode in the
    default run)."""
    quiet = fly(tmp_path / "quiet", "--lockstep-overlap")
    loaded = fly_loaded(tmp_path / "loaded", "--lockstep-overlap")
    assert_same_flight(quiet, loaded)
    assert quiet[0]["aggregate"]["lockstep_overlap"] is True
    assert "lock-step on (timeout 3 s, overlapped)" in quiet[4]


def assert_same_flight(quiet, loaded):
    for run in (quiet, loaded):
        result, truth, track, wall, stub_log = run
        assert result["runs"][0]["reached_goal"] and len(truth) > 300 and len(track["t_s"]) > 300
        assert wall["real_time_factor"] is not None and wall["flight_wall_s"] > 0
        assert "free-running" not in stub_log                  # locked from start to end
    assert loaded[0] == quiet[0]
    assert loaded[1] == quiet[1]
    assert loaded[2] == quiet[2]
