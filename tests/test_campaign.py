"""companion campaign on real Dask clusters: a LocalCluster of processes, and a `dask scheduler` plus
`dask worker` started here as subprocesses on 127.0.0.1. No mocks; every cluster is shut down."""
from __future__ import annotations

import dataclasses
import json
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest

from companion.__main__ import main
from companion.tools.campaign import chunks, runs_per_task
from companion.config.scenario import load_scenario
from companion.sim.simulation import aggregate, run_once

pytest.importorskip("distributed", reason="the cluster extra is not installed")

REPO = Path(__file__).resolve().parent.parent
PAPER = "config/scenarios/paper.yaml"


def cli(tmp_path, name, *args):
    out = tmp_path / f"{name}.json"
    assert main([*args, "--json", str(out)]) == 0
    return json.loads(out.read_text())


def stop_group(proc: subprocess.Popen) -> None:
    """SIGTERM the process group started for ``proc`` (the nanny's worker included), then SIGKILL."""
    if proc.poll() is None:
        os.killpg(proc.pid, signal.SIGTERM)
        try:
            proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait(timeout=10)


def wait_for(condition, timeout_s: float, what: str, procs=()):
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        value = condition()
        if value:
            return value
        for proc in procs:
            if proc.poll() is not None:
                raise AssertionError(f"{what}: {proc.args[:4]} exited with {proc.returncode}")
        time.sleep(0.1)
    raise AssertionError(f"{what}: not within {timeout_s} s")


@pytest.fixture(scope="module")
def scheduler(tmp_path_factory):
    """`dask scheduler` on 127.0.0.1, port 0, and one `dask worker` (1 process, 1 thread)."""
    from distributed import Client
    work = tmp_path_factory.mktemp("dask")
    info = work / "scheduler.json"
    procs = []
    try:
        # The scheduler file gives the bound address: no parsing of log text, no pipe to drain.
        procs.append(subprocess.Popen(
            [sys.executable, "-m", "dask", "scheduler", "--host", "127.0.0.1", "--port", "0",
             "--no-dashboard", "--scheduler-file", str(info)],
            stdout=subprocess.DEVNULL, stderr=open(work / "scheduler.err", "w"),
            start_new_session=True, cwd=work))
        address = wait_for(lambda: info.exists() and json.loads(info.read_text() or "{}").get("address"),
                           30, "scheduler address", procs)
        assert address.startswith("tcp://127.0.0.1:")
        procs.append(subprocess.Popen(
            [sys.executable, "-m", "dask", "worker", address, "--nworkers", "1", "--nthreads", "1",
             "--host", "127.0.0.1", "--no-dashboard"],
            stdout=subprocess.DEVNULL, stderr=open(work / "worker.err", "w"),
            start_new_session=True, cwd=work))
        with Client(address, timeout="20s") as client:
            client.wait_for_workers(1, timeout=30)
            assert len(client.nthreads()) == 1
        yield address
    finally:
        for proc in reversed(procs):
            stop_group(proc)


def test_chunks_cover_every_run_index_once():
    for runs in (1, 7, 200, 1001):
        for workers in (1, 2, 64):
            size = runs_per_task(runs, workers)
            plan = chunks(5, runs, size)
            seeds = [seed for first, count in plan for seed in range(first, first + count)]
            assert seeds == list(range(5, 5 + runs))
            assert all(1 <= count <= size for _, count in plan)


# The campaigns below fly these worlds; `companion simulate` of the same runs, once per module.
DENSE = ("--random-worlds", "dense", "--runs", "6", "--seed", "3")


@pytest.fixture(scope="module")
def dense_simulated(tmp_path_factory):
    return cli(tmp_path_factory.mktemp("simulate"), "simulate", "simulate", *DENSE)


def test_local_cluster_of_two_processes_matches_simulate(tmp_path, dense_simulated):
    png = tmp_path / "hist.png"
    camp = cli(tmp_path, "campaign", "campaign", *DENSE, "--workers", "2", "--plot", str(png))
    sim = dense_simulated
    assert camp["campaign"]["workers"] == 2 and camp["campaign"]["cluster"] == "local"
    assert camp["aggregate"] == sim["aggregate"]
    assert camp["runs"] == sim["runs"]
    assert [r["seed"] for r in camp["runs"]] == list(range(3, 9))
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 20_000


def test_external_scheduler_and_worker_give_the_same_aggregate(tmp_path, scheduler,
                                                             dense_simulated):
    camp = cli(tmp_path, "campaign", "campaign", *DENSE, "--scheduler", scheduler)
    sim = dense_simulated
    assert camp["campaign"]["cluster"] == scheduler and camp["campaign"]["workers"] == 1
    assert camp["aggregate"] == sim["aggregate"]
    assert camp["runs"] == sim["runs"]


def test_sweep_gives_one_row_per_value_equal_to_a_run_with_that_value(tmp_path, scheduler, capsys):
    report = cli(tmp_path, "sweep", "campaign", "--scenario", PAPER, "--runs", "3", "--seed", "10",
                 "--sweep", "eta=1.0,1.5", "--scheduler", scheduler)
    rows = report["sweep"]["rows"]
    assert report["sweep"]["name"] == "eta" and [r["value"] for r in rows] == [1.0, 1.5]
    base = load_scenario(PAPER)
    for row in rows:
        scenario = dataclasses.replace(
            base, avoidance=dataclasses.replace(base.avoidance, eta=row["value"]))
        outcomes = [run_once(scenario, seed) for seed in range(10, 13)]
        expected = json.loads(json.dumps(aggregate(outcomes, scenario.avoidance.safety_distance_m)))
        got = {k: v for k, v in row["aggregate"].items() if k not in ("strategy", "scenario")}
        assert got == expected
    table = capsys.readouterr().out.splitlines()
    assert table[0].split()[0] == "eta"
    assert [line.split()[0] for line in table[1:3]] == ["1.0", "1.5"]


def test_progress_bar_only_on_a_terminal(tmp_path, scheduler, capsys):
    import fcntl
    import pty
    import struct
    import termios
    primary, secondary = pty.openpty()
    # A terminal of 0 columns (a fresh pty's size) gets an empty bar from tqdm: give it a size.
    fcntl.ioctl(secondary, termios.TIOCSWINSZ, struct.pack("HHHH", 24, 100, 0, 0))
    try:
        proc = subprocess.Popen([sys.executable, "-m", "companion", "campaign", "--scenario", PAPER,
                                 "--runs", "2", "--scheduler", scheduler],
                                stdout=subprocess.DEVNULL, stderr=secondary, cwd=REPO)
        os.close(secondary)
        seen = b""
        while True:
            try:
                chunk = os.read(primary, 4096)
            except OSError:                  # EIO: the child closed the terminal
                break
            if not chunk:
                break
            seen += chunk
        assert proc.wait(timeout=60) == 0
    finally:
        os.close(primary)
    assert b"campaign: 100%" in seen and b"2/2" in seen
    assert main(["campaign", "--scenario", PAPER, "--runs", "2", "--scheduler", scheduler]) == 0
    assert "2/2" not in capsys.readouterr().err             # not a terminal: no bar


def test_bad_sweeps_are_refused_with_exit_2(capsys):
    assert main(["campaign", "--scenario", PAPER, "--runs", "2", "--sweep", "etta=1,2"]) == 2
    assert "unknown parameter 'etta'" in capsys.readouterr().err
    assert main(["campaign", "--scenario", PAPER, "--runs", "2", "--sweep", "eta=0.5,1"]) == 2
    assert "eta" in capsys.readouterr().err


BLOCK_DASK = textwrap.dedent("""
    import importlib.abc, sys

    class NoDask(importlib.abc.MetaPathFinder):
        def find_spec(self, name, path=None, target=None):
            if name.split(".")[0] in ("dask", "distributed"):
                raise ImportError(f"No module named {name!r} (blocked by the test)")
            return None

    sys.meta_path.insert(0, NoDask())
    from companion.__main__ import main
    code = main(sys.argv[1:])
    print("dask modules:", sorted(m for m in sys.modules if m.split(".")[0] in ("dask", "distributed")))
    sys.exit(code)
""")


def without_dask(*args):
    return subprocess.run([sys.executable, "-c", BLOCK_DASK, *args], capture_output=True,
                          text=True, cwd=REPO, timeout=60)


def test_without_dask_campaign_says_how_to_install_and_simulate_still_works(tmp_path):
    done = without_dask("campaign", "--random-worlds", "dense", "--runs", "2")
    assert done.returncode == 2, done.stderr
    assert "pip install .[cluster]" in done.stderr
    assert "Traceback" not in done.stderr
    done = without_dask("simulate", "--scenario", PAPER, "--runs", "1",
                        "--json", str(tmp_path / "s.json"))
    assert done.returncode == 0, done.stderr
    assert "dask modules: []" in done.stdout
    assert json.loads((tmp_path / "s.json").read_text())["aggregate"]["runs"] == 1


@pytest.fixture(scope="module")
def fleet(tmp_path_factory, paper_demo):
    """A real recording by `companion demo` (the session's paper demo, tests/conftest.py), with
    its config sidecar, copied into a fleet folder with a cut and a junk file."""
    out = tmp_path_factory.mktemp("fleet")
    data = (paper_demo.workdir / "demo.tlog").read_bytes()
    (out / "a.tlog").write_bytes(data)
    (out / "a.config.yaml").write_bytes((paper_demo.workdir / "demo.config.yaml").read_bytes())
    (out / "day2").mkdir()
    (out / "day2" / "b.tlog").write_bytes(data)                  # no sidecar: default config
    (out / "day2" / "cut.tlog").write_bytes(data[:len(data) // 3])
    (out / "junk.tlog").write_bytes(b"not a tlog\n" * 10)
    return out


def replay_json(tmp_path, tlog: Path) -> dict:
    out = tmp_path / f"{tlog.stem}.replay.json"
    main(["replay", str(tlog), "--json", str(out)])
    return json.loads(out.read_text())


def test_fleet_replay_rows_agree_with_companion_replay(tmp_path, fleet, scheduler):
    csv_path = tmp_path / "fleet.csv"
    report = cli(tmp_path, "fleet", "campaign", "--replay", str(fleet), "--csv", str(csv_path),
                 "--scheduler", scheduler)
    flights = report["flights"]
    names = [Path(f["file"]).relative_to(fleet).as_posix() for f in flights]
    assert names == ["a.tlog", "day2/b.tlog", "day2/cut.tlog", "junk.tlog"]
    for flight in flights:
        single = replay_json(tmp_path, Path(flight["file"]))
        assert flight["error"] is None
        assert flight["log_duration_s"] == pytest.approx(single["log_duration_s"])
        assert flight["messages"] == single["messages"]
        assert flight["urgent_events"] == sum(e["state"] == "urgent" for e in single["urgency_events"])
        covs = np.array(single["track"]["pose_cov"]).reshape(-1, 3, 3)
        sigma = float(np.sqrt(max(np.linalg.eigvalsh(c[:2, :2]).max() for c in covs))) if len(covs) else None
        assert flight["max_position_sigma_m"] == pytest.approx(sigma)
        track = np.column_stack([single["track"]["north_m"], single["track"]["east_m"]])
        marks = [(m["north_m"], m["east_m"]) for m in single["landmarks"]]
        closest = min((np.hypot(*(p - m)) for p in track for m in marks), default=None)
        assert flight["closest_estimated_approach_m"] == pytest.approx(closest)
    a, b, cut, junk = flights
    assert a["flight_time_s"] > 20.0 and a["max_position_sigma_m"] > 0.0 and not a["damaged"]
    assert a["urgent_events"] >= 1 and a["arrived"]                 # a's sidecar has the goal
    assert not b["arrived"] and "no goal configured" in b["notes"]
    assert cut["damaged"] and cut["flight_time_s"] < a["flight_time_s"]
    assert junk["damaged"] and junk["flight_time_s"] is None
    assert report["fleet"]["flights"] == 4 and report["fleet"]["failed"] == 0
    lines = csv_path.read_text().splitlines()
    assert lines[0].startswith("file,log_duration_s,flight_time_s,urgent_events,")
    assert len(lines) == 5
