"""link.camera_frame_idle_s live: the service's timer closes a camera frame before the stub's next
step arrives, and `companion replay` of the tlog reaches the same setpoints from its stamps.

The stub on the wall clock (no lock-step: lock-step has no idle time, its clock is the steps), the
paper's scenario at 4x: a step every 25 ms of wall time, the frame idle time 5 ms."""
from __future__ import annotations

import json
import subprocess
import sys

import yaml

from companion.__main__ import main
from companion.mavlink.tlog import TlogReader
from tests.e2e.support import PAPER, REPO

IDLE_S = 0.005
OURS = 191


def answered_before_the_next_step(tlog):
    """(frames with an obstacle, those whose setpoint went out before the next message that is
    not of the frame was taken in), in the tlog's order: a message is recorded as it is handled,
    a setpoint as it is sent."""
    waiting, frames, early = {}, 0, 0
    for record in TlogReader(tlog):
        msg = record.msg
        if msg.get_srcComponent() == OURS:
            if msg.get_type() == "SET_POSITION_TARGET_LOCAL_NED":
                for capture_ms in [c for c in waiting if c <= msg.time_boot_ms]:
                    frames += 1
                    early += waiting.pop(capture_ms)
            continue
        of_frame = msg.get_type() == "OBSTACLE_DISTANCE_3D"
        for capture_ms in waiting:
            if not (of_frame and msg.time_boot_ms == capture_ms):
                waiting[capture_ms] = False     # something else came first
        if of_frame:
            waiting.setdefault(msg.time_boot_ms, True)
    return frames, early


def test_frames_close_on_idle_time_live_and_replay_agrees(tmp_path, capsys):
    config = yaml.safe_load((REPO / "config/companion.yaml").read_text())
    config["link"]["camera_frame_idle_s"] = IDLE_S
    config_path = tmp_path / "base.yaml"
    config_path.write_text(yaml.safe_dump(config))
    tlog = tmp_path / "flight.tlog"
    done = subprocess.run(
        [sys.executable, "-m", "companion", "demo", "--scenario", str(PAPER), "--no-lockstep",
         "--speedup", "4", "--config", str(config_path), "--tlog", str(tlog),
         "--json", str(tmp_path / "demo.json")],
        capture_output=True, text=True, cwd=REPO, timeout=120)
    assert done.returncode == 0, done.stdout + done.stderr
    (run,) = json.loads((tmp_path / "demo.json").read_text())["runs"]
    assert run["reached_goal"] and not run["collided"]
    frames, early = answered_before_the_next_step(tlog)
    # Without the idle close none can be (the next message closes the frame: measured 0); a
    # loaded machine may fire a 5 ms timer 20 ms late now and then, not on most frames.
    assert frames >= 30 and early >= 0.5 * frames, (frames, early)
    capsys.readouterr()
    assert main(["replay", str(tlog), "--json", str(tmp_path / "r.json")]) == 0
    report = json.loads((tmp_path / "r.json").read_text())
    assert report["setpoints_compared"] > 100
    assert report["setpoints_mismatched"] == 0 and report["setpoints_unmatched"] == 0
