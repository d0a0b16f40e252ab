"""The demo cleans up its children on Ctrl-C, and explains a child that dies early."""
from __future__ import annotations

import asyncio
import signal
import subprocess
import sys

import psutil
import pytest

from companion.demo import DemoError, spawn
from tests.e2e.support import REPO, wait_until


def test_ctrl_c_stops_the_demo_and_both_children(tmp_path):
    keep = tmp_path / "work"
    # Output to a file, not a pipe: an unread pipe that fills up would block the demo itself.
    log = tmp_path / "demo.out"
    with open(log, "w") as out:
        # The 1 km corridor: in lock-step the paper's flight is over in about 3 s, before the
        # signal. SIGINT as an interactive terminal gives it: a test run started in the
        # background (nohup, `cmd &` in a script) passes SIGINT on ignored, and Python then
        # never turns it into KeyboardInterrupt.
        demo = subprocess.Popen([sys.executable, "-m", "companion", "demo", "--scenario",
                                 "benchmarks/corridor.yaml",
                                 "--keep", str(keep)], cwd=REPO, stdout=out,
                                stderr=subprocess.STDOUT, text=True,
                                preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    try:
        wait_until(lambda: (keep / "companion-report.json").exists(), 20.0,
                   "the companion to start")
        children = psutil.Process(demo.pid).children(recursive=True)
        assert len(children) >= 2
        demo.send_signal(signal.SIGINT)
        try:
            code = demo.wait(timeout=15)
        except subprocess.TimeoutExpired:
            raise AssertionError("demo still running 15 s after SIGINT:\n"
                                 + log.read_text()[-3000:]) from None
        assert code == 130, log.read_text()[-3000:]
        gone, alive = psutil.wait_procs(children, timeout=5)
        assert alive == []
    finally:
        if demo.poll() is None:
            demo.kill()


def test_a_child_that_dies_early_is_reported_with_its_stderr(tmp_path):
    async def scenario():
        child = await spawn("fake", [sys.executable, "-c",
                                     "import sys; sys.stderr.write('bad scenario file\\n'); "
                                     "sys.exit(2)"], tmp_path)
        await child.proc.wait()
        child.check_alive()
    with pytest.raises(DemoError, match=r"fake exited early with code 2:\nbad scenario file"):
        asyncio.run(scenario())


def test_demo_with_an_unreadable_scenario_fails_clearly(tmp_path):
    done = subprocess.run([sys.executable, "-m", "companion", "demo", "--scenario",
                           str(tmp_path / "missing.yaml")], cwd=REPO, capture_output=True,
                          text=True, timeout=30)
    assert done.returncode == 2 and "cannot read" in done.stderr
    assert "Traceback" not in done.stderr
