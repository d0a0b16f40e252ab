"""`companion view` as a real process on loopback, and its state over HTTP."""
from __future__ import annotations

import json
import select
import subprocess
import sys
import time
import urllib.request
from pathlib import Path

from tests.e2e.support import spawn

READY_TIMEOUT_S = 20.0


def start_view(tmp_path: Path, *args: str):
    """`companion view ... --port 0`; returns (process, page URL, feed port or None)."""
    view = spawn(tmp_path, "view", [sys.executable, "-m", "companion", "view", "--port", "0",
                                    *args], stdout=subprocess.PIPE)
    deadline = time.monotonic() + READY_TIMEOUT_S
    while time.monotonic() < deadline:
        ready, _, _ = select.select([view.proc.stdout], [], [], 0.2)
        if ready:
            line = view.proc.stdout.readline()
            if line.startswith("COMPANION_VIEW READY"):
                fields = dict(part.split("=", 1) for part in line.split()[2:])
                source = fields["source"]
                port = int(source.rpartition(":")[2]) if source.startswith("udp:") else None
                return view, fields["http"], port
        if view.proc.poll() is not None:
            break
    view.stop()
    raise AssertionError(f"companion view not ready:\n{view.stderr()}")


def get_state(url: str) -> dict:
    with urllib.request.urlopen(url + "api/state", timeout=5) as r:
        return json.loads(r.read())
