"""`companion simulate --jobs N`: the same JSON whatever N, workers that end with the command."""
from __future__ import annotations

import json
import subprocess
import sys

import psutil
import pytest

from companion.config.scenario import load_scenario
from companion.sim.batch import fly_runs
from companion.sim.worlds import random_world
from tests.e2e.support import REPO, wait_until
from tests.e2e.test_demo_cleanup import still_running, stop_all


def simulate(tmp_path, name: str, *args: str) -> dict:
    out = tmp_path / f"{name}.json"
    done = subprocess.run([sys.executable, "-m", "companion", "simulate", *args, "--json",
                           str(out)], cwd=REPO, capture_output=True, text=True, timeout=240)
    assert done.returncode == 0, done.stderr
    return json.loads(out.read_text())


def test_two_jobs_fly_the_same_runs_as_one_bit_for_bit(tmp_path):
    # dense worlds, 6 seeds: flights of different lengths, so the two workers finish out of
    # order and the results must still come back in seed order
    args = ("--random-worlds", "dense", "--runs", "6", "--seed", "11")
    one = simulate(tmp_path, "one", *args, "--jobs", "1")
    two = simulate(tmp_path, "two", *args, "--jobs", "2")
    assert [r["seed"] for r in two["runs"]] == list(range(11, 17))
    assert two == one
    assert len({r["time_s"] for r in one["runs"]}) > 1          # the runs differ from each other


def test_fly_runs_in_a_pool_returns_outcomes_in_seed_order_with_traces():
    base = load_scenario(REPO / "config/scenarios/paper.yaml")
    seeds = [3, 4, 5]
    worlds = [random_world(base, "dense", seed) for seed in seeds]
    done = []
    pooled = fly_runs(worlds, seeds, None, jobs=2, on_done=lambda: done.append(1))
    alone = fly_runs(worlds, seeds, None, jobs=1)
    assert len(done) == 3
    assert [o.summary for o in pooled] == [o.summary for o in alone]
    assert [len(o.trace.t_s) for o in pooled] == [len(o.trace.t_s) for o in alone]


def test_jobs_must_be_a_positive_integer(tmp_path):
    done = subprocess.run([sys.executable, "-m", "companion", "simulate", "--random-worlds",
                           "dense", "--jobs", "0"], cwd=REPO, capture_output=True, text=True,
                          timeout=60)
    assert done.returncode == 2 and "--jobs" in done.stderr and "positive integer" in done.stderr


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="PR_SET_PDEATHSIG is Linux's")
def test_a_killed_simulate_leaves_no_workers_running():
    run = subprocess.Popen([sys.executable, "-m", "companion", "simulate", "--random-worlds",
                            "dense", "--runs", "400", "--jobs", "2"], cwd=REPO,
                           stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    workers: list[psutil.Process] = []
    try:
        def two_workers():
            found = psutil.Process(run.pid).children(recursive=True)
            return len(found) >= 2 and found
        workers = wait_until(lambda: run.poll() is None and two_workers(), 60.0,
                             "simulate's two workers")
        run.kill()
        run.wait(timeout=5)
        assert still_running(workers, 15.0) == []
    finally:
        stop_all(run, workers)
