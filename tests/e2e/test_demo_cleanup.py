"""The demo cleans up its children on Ctrl-C, and explains a child that dies early."""
from __future__ import annotations

import asyncio
import signal
import subprocess
import sys
import textwrap
import time

import psutil
import pytest

from companion.tools.demo import DemoError, spawn, wait_for
from tests.e2e.support import REPO, wait_until


CHILD_EXIT_S = 10.0     # the children's SIGTERM handling (a stop setpoint, files closed), loaded


def start_demo(tmp_path, *args: str) -> tuple[subprocess.Popen, list[psutil.Process], object]:
    """`companion demo` of the 1 km corridor (long enough to be stopped mid-flight: in lock-step
    the paper's flight is over in about 3 s), once its companion has started; returns the demo,
    its children and its log. SIGINT as an interactive terminal gives it: a test run started in
    the background (nohup, `cmd &` in a script) passes SIGINT on ignored, and Python then never
    turns it into KeyboardInterrupt."""
    keep = tmp_path / "work"
    # Output to a file, not a pipe: an unread pipe that fills up would block the demo itself.
    log = tmp_path / "demo.out"
    with open(log, "w") as out:
        demo = subprocess.Popen([sys.executable, "-m", "companion", "demo", "--scenario",
                                 "benchmarks/corridor.yaml", "--keep", str(keep), *args],
                                cwd=REPO, stdout=out, stderr=subprocess.STDOUT, text=True,
                                preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    try:
        wait_until(lambda: (keep / "companion-report.json").exists() or demo.poll() is not None,
                   30.0, "the companion to start")
        assert demo.poll() is None, log.read_text()[-3000:]
        children = psutil.Process(demo.pid).children(recursive=True)
        assert sorted(c.cmdline()[2] for c in children) == ["companion", "sitl_stub"], children
    except BaseException:
        stop_all(demo, psutil.Process(demo.pid).children(recursive=True) if demo.poll() is None
                 else [])
        raise
    return demo, children, log


def still_running(procs: list[psutil.Process], timeout_s: float) -> list[psutil.Process]:
    """Those of ``procs`` still running after up to ``timeout_s`` (a zombie nobody has reaped
    yet has exited: an orphan's parent is now init, which may reap late)."""
    def running(proc):
        try:
            return proc.status() != psutil.STATUS_ZOMBIE
        except psutil.NoSuchProcess:
            return False
    deadline = time.monotonic() + timeout_s
    while (alive := [p for p in procs if running(p)]) and time.monotonic() < deadline:
        time.sleep(0.1)
    return alive


def stop_all(demo: subprocess.Popen, children: list[psutil.Process]) -> None:
    """Whatever the test left running: the demo, then its children by pid."""
    if demo.poll() is None:
        demo.kill()
        demo.wait()
    for child in children:
        try:
            child.kill()
        except psutil.NoSuchProcess:
            pass


@pytest.mark.parametrize("mode", ["--lockstep", "--no-lockstep"])
def test_ctrl_c_stops_the_demo_and_both_children(tmp_path, mode):
    """In lock-step and free-running (the stub on the wall clock, the demo's ground station
    idling between its polls)."""
    demo, children, log = start_demo(tmp_path, mode)
    try:
        demo.send_signal(signal.SIGINT)
        try:
            code = demo.wait(timeout=15)
        except subprocess.TimeoutExpired:
            raise AssertionError("demo still running 15 s after SIGINT:\n"
                                 + log.read_text()[-3000:]) from None
        assert code == 130, log.read_text()[-3000:]
        assert still_running(children, CHILD_EXIT_S) == []
    finally:
        stop_all(demo, children)


def test_a_killed_demo_leaves_no_children_running(tmp_path):
    """SIGKILL (or an out-of-memory kill, or a test's timeout) gives the demo no chance to stop
    its children: the kernel tells them (PR_SET_PDEATHSIG, Linux)."""
    demo, children, _ = start_demo(tmp_path)
    try:
        demo.kill()
        demo.wait(timeout=5)
        assert still_running(children, CHILD_EXIT_S) == []
    finally:
        stop_all(demo, children)


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="PR_SET_PDEATHSIG is Linux's")
def test_the_death_signal_hook_ties_a_child_to_its_parent(tmp_path):
    """die_with_parent_hook: a grandchild started with it by a parent that is then SIGKILLed
    gets SIGTERM; one started without it outlives the parent (so the check can fail)."""
    script = textwrap.dedent("""
        import subprocess, sys, time
        from companion.tools.child_lifetime import die_with_parent_hook
        hook = die_with_parent_hook() if sys.argv[1] == "hook" else None
        child = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"],
                                 preexec_fn=hook)
        print(child.pid, flush=True)
        time.sleep(60)
    """)
    for kind, expect_running in (("hook", False), ("none", True)):
        parent = subprocess.Popen([sys.executable, "-c", script, kind], cwd=REPO,
                                  stdout=subprocess.PIPE, text=True)
        child = None
        try:
            child = psutil.Process(int(parent.stdout.readline()))
            parent.kill()
            parent.wait(timeout=5)
            alive = still_running([child], 1.0 if expect_running else CHILD_EXIT_S)
            assert bool(alive) == expect_running, kind
        finally:
            stop_all(parent, [child] if child else [])


def test_a_killed_campaign_leaves_no_workers_running(tmp_path):
    """`companion campaign`'s local Dask workers end with it, even when it is SIGKILLed (Dask's
    own parent watch: a worker exits when its pipe to the parent closes)."""
    campaign = subprocess.Popen([sys.executable, "-m", "companion", "campaign", "--random-worlds",
                                 "dense", "--runs", "400", "--workers", "2"], cwd=REPO,
                                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    workers: list[psutil.Process] = []
    try:
        def is_worker(p: psutil.Process) -> bool:
            try:
                return "multiprocessing" in " ".join(p.cmdline()) or p.ppid() == campaign.pid
            except psutil.NoSuchProcess:        # a short-lived helper gone between the two calls
                return False

        def two_workers():
            found = [p for p in psutil.Process(campaign.pid).children(recursive=True)
                     if is_worker(p)]
            return len(found) >= 2 and found
        workers = wait_until(lambda: campaign.poll() is None and two_workers(), 60.0,
                             "the campaign's two workers")
        campaign.kill()
        campaign.wait(timeout=5)
        assert still_running(workers, 15.0) == []
    finally:
        stop_all(campaign, workers)


def test_a_child_that_dies_early_is_reported_with_its_stderr(tmp_path):
    async def scenario():
        child = await spawn("fake", [sys.executable, "-c",
                                     "import sys; sys.stderr.write('bad scenario file\\n'); "
                                     "sys.exit(2)"], tmp_path)
        await child.proc.wait()
        child.check_alive()
    with pytest.raises(DemoError, match=r"fake exited early with code 2:\nbad scenario file"):
        asyncio.run(scenario())


def test_a_wait_that_times_out_shows_what_the_children_last_said(tmp_path):
    """A flight that never arrives: the error carries each child's last stderr lines, so a run
    that fails on someone else's machine (CI) says why without --keep."""
    async def scenario():
        child = await spawn("fake", [sys.executable, "-c",
                                     "import sys, time; sys.stderr.write('heartbeat lost\\n'); "
                                     "sys.stderr.flush(); time.sleep(30)"], tmp_path)
        try:
            wait_until(lambda: child.stderr_tail(), 10.0, "the child's first line")
            await wait_for(lambda: None, "the vehicle to arrive", 0.3, [child])
        finally:
            child.proc.kill()
            await child.proc.wait()
    with pytest.raises(DemoError, match=r"(?s)timed out after 0 s waiting for the vehicle to "
                                        r"arrive\n--- fake, last lines:\nheartbeat lost"):
        asyncio.run(scenario())


def test_demo_with_an_unreadable_scenario_fails_clearly(tmp_path):
    done = subprocess.run([sys.executable, "-m", "companion", "demo", "--scenario",
                           str(tmp_path / "missing.yaml")], cwd=REPO, capture_output=True,
                          text=True, timeout=30)
    assert done.returncode == 2 and "cannot read" in done.stderr
    assert "Traceback" not in done.stderr
