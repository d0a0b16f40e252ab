"""Session fixtures shared by several test modules."""
from __future__ import annotations

import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest

from tests.e2e.support import REPO
from tests.view.process import start_view

# The arguments of the one seeded lock-step paper demo the e2e, view and lock-step tests share.
PAPER_DEMO_ARGS = ("demo", "--seed", "0", "--speedup", "20")


@dataclass(frozen=True)
class PaperDemo:
    """`companion demo` of the paper's scenario, flown once per test session: its work dir
    (--keep: truth.jsonl, companion-report.json, the children's stderr), demo.json, demo.png,
    demo.tlog (and demo.config.yaml beside it), the finished process, and the live view that
    was fed during the flight (`companion view --source udp:...`, still running)."""
    workdir: Path
    done: subprocess.CompletedProcess
    view_url: str


@pytest.fixture(scope="session")
def paper_demo(tmp_path_factory):
    work = tmp_path_factory.mktemp("paper-demo")
    view, url, feed_port = start_view(work, "--source", "udp:127.0.0.1:0",
                                      "--truth", str(work / "truth.jsonl"))
    try:
        done = subprocess.run(
            [sys.executable, "-m", "companion", *PAPER_DEMO_ARGS, "--keep", str(work),
             "--json", str(work / "demo.json"), "--plot", str(work / "demo.png"),
             "--tlog", str(work / "demo.tlog"), "--view-feed", f"127.0.0.1:{feed_port}"],
            capture_output=True, text=True, cwd=REPO, timeout=120)
        assert done.returncode == 0, done.stdout + done.stderr
        yield PaperDemo(work, done, url)
    finally:
        view.stop()
