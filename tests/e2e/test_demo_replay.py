"""`companion demo` end to end, then `companion replay` of its tlog: same estimates, same setpoints.
Also replay of damaged and foreign logs built from that recording."""
from __future__ import annotations

import json
import random
import subprocess
import sys
from types import SimpleNamespace

import pytest

from companion.__main__ import main
from companion.mavlink import codec
from companion.mavlink.dialect import mavlink
from companion.mavlink.tlog import TlogReader, TlogWriter
from tests.e2e.support import REPO


def companion(*args, timeout_s=90.0):
    return subprocess.run([sys.executable, "-m", "companion", *args], capture_output=True,
                          text=True, cwd=REPO, timeout=timeout_s)


def replay(capsys, *args):
    """`companion replay ...` through the CLI's entry in this process (a replay reads a file and
    ends: an interpreter's start-up per call bought nothing); its exit code and output."""
    capsys.readouterr()
    code = main(["replay", *args])
    out = capsys.readouterr()
    return SimpleNamespace(returncode=code, stdout=out.out, stderr=out.err)


@pytest.fixture(scope="module")
def demo(paper_demo):
    """The session's paper demo (tests/conftest.py): its outputs are demo.json, demo.png,
    demo.tlog and demo.config.yaml in its work dir."""
    return paper_demo.workdir, paper_demo.done


def test_demo_reaches_the_goal_safely_and_writes_its_outputs(demo):
    out, done = demo
    result = json.loads((out / "demo.json").read_text())
    (run,) = result["runs"]
    assert run["reached_goal"] and not run["collided"]
    assert run["min_clearance_m"] >= 9.5
    assert run["final_position_error_m"] < 2.0
    assert run["urgent_events"] >= 1
    assert result["aggregate"]["wall_time_s"] < 60.0
    assert (out / "demo.png").stat().st_size > 10_000
    assert "success rate: 1.00" in done.stdout
    assert (out / "demo.config.yaml").exists()


def test_replay_of_the_demo_reproduces_estimates_and_setpoints(demo, tmp_path, capsys):
    out, _ = demo
    done = replay(capsys, str(out / "demo.tlog"), "--json", str(tmp_path / "r.json"),
                     "--csv", str(tmp_path / "r.csv"), "--plot", str(tmp_path / "r.png"))
    assert done.returncode == 0, done.stderr
    report = json.loads((tmp_path / "r.json").read_text())
    assert report["setpoints_compared"] > 100
    assert report["setpoints_mismatched"] == 0 and report["setpoints_unmatched"] == 0
    assert report["poses_compared"] > 50 and report["poses_unmatched"] == 0
    assert report["max_position_difference_m"] <= 1e-6
    assert report["arrived"] and report["landmarks"] is not None
    assert "messages/s" in done.stdout
    rows = (tmp_path / "r.csv").read_text().splitlines()
    assert rows[0].startswith("t_s,north_m,east_m") and len(rows) == len(report["track"]["t_s"]) + 1
    assert (tmp_path / "r.png").exists()


def record_start_after(data: bytes, offset: int) -> int:
    """The first tlog record boundary at or after ``offset`` (8-byte time, then a MAVLink
    packet: v2 is 12 bytes plus payload, plus a 13-byte signature when flagged; v1 is 8 plus)."""
    pos = 0
    while pos < offset:
        magic, length = data[pos + 8], data[pos + 9]
        if magic == 0xFD:
            pos += 8 + 12 + length + (13 if data[pos + 10] & 0x01 else 0)
        else:
            assert magic == 0xFE, f"not a record at {pos}"
            pos += 8 + 8 + length
    return pos


def test_replay_of_a_cut_tlog_keeps_everything_before_the_cut(demo, tmp_path, capsys):
    out, _ = demo
    data = (out / "demo.tlog").read_bytes()
    cut = tmp_path / "cut.tlog"
    cut.write_bytes(data[:record_start_after(data, len(data) // 2) + 8 + 15])  # header and 5 payload bytes
    done = replay(capsys, str(cut), "--config", str(out / "demo.config.yaml"),
                     "--json", str(tmp_path / "r.json"))
    assert done.returncode == 0, done.stderr
    report = json.loads((tmp_path / "r.json").read_text())
    assert any("mid-packet" in n for n in report["notes"])
    assert report["setpoints_mismatched"] == 0 and report["setpoints_compared"] > 50


def test_replay_of_a_corrupted_tlog_skips_the_damage(demo, tmp_path, capsys):
    out, _ = demo
    data = bytearray((out / "demo.tlog").read_bytes())
    rng = random.Random(5)
    for start in (len(data) // 4, len(data) // 2, 3 * len(data) // 4):
        data[start:start + 100] = rng.randbytes(100)
    bad = tmp_path / "bad.tlog"
    bad.write_bytes(bytes(data))
    done = replay(capsys, str(bad), "--config", str(out / "demo.config.yaml"),
                     "--json", str(tmp_path / "r.json"))
    assert done.returncode == 0, done.stderr
    report = json.loads((tmp_path / "r.json").read_text())
    damage = (report["tlog"], report["notes"])
    assert report["tlog"]["bytes_skipped"] + report["tlog"]["bad_packets"] > 0, damage
    assert report["messages"] > 1000, damage
    assert any("corrupt" in n or "unreadable" in n for n in report["notes"]), damage
    assert "note:" in done.stdout


@pytest.mark.parametrize("content", [b"", b"GPS week 2300, not a telemetry log\n" * 100])
def test_replay_of_empty_or_foreign_bytes_fails_clearly(tmp_path, content, capsys):
    path = tmp_path / "x.tlog"
    path.write_bytes(content)
    done = replay(capsys, str(path))
    assert done.returncode == 1
    assert "nothing readable" in done.stderr
    assert "Traceback" not in done.stderr


def test_replay_of_a_ground_station_log_with_two_vehicles_gives_a_pose_only_track(demo, tmp_path,
                                                                                 capsys):
    """What a GCS or router records: no companion traffic, no obstacles, a second vehicle and the
    GCS's own messages."""
    out, _ = demo
    gcs, other = codec.Encoder(255, 190), codec.Encoder(2, 1)
    path = tmp_path / "gcs.tlog"
    with TlogWriter(path) as tlog:
        for i, record in enumerate(TlogReader(out / "demo.tlog")):
            msg = record.msg
            if msg.get_srcComponent() in (191, 100) or msg.get_type().startswith("OBSTACLE"):
                continue
            tlog.write(record.t_us, bytes(msg.get_msgbuf()))
            if i % 50 == 0:
                tlog.write(record.t_us, other.encode(
                    mavlink.MAVLink_heartbeat_message(2, 3, 0, 0, 4, 3)))
                tlog.write(record.t_us, gcs.encode(codec.gcs_heartbeat()))
    done = replay(capsys, str(path), "--goal", "180,0", "--json", str(tmp_path / "r.json"))
    assert done.returncode == 0, done.stderr
    report = json.loads((tmp_path / "r.json").read_text())
    assert report["vehicle"] == [1, 1] and report["other_vehicles"] == [2]
    assert len(report["track"]["t_s"]) > 100 and report["landmarks"] == []
    notes = " | ".join(report["notes"])
    assert "pose-only track" in notes and "several vehicles" in notes and "no comparison" in notes
    done = replay(capsys, str(path), "--sysid", "2", "--json", str(tmp_path / "r2.json"))
    report = json.loads((tmp_path / "r2.json").read_text())
    assert report["vehicle"] == [2, 1] and report["track"]["t_s"] == []


def test_demo_survives_twenty_percent_datagram_loss(tmp_path):
    done = companion("demo", "--speedup", "20", "--drop-rate", "0.2", "--seed", "3",
                     "--json", str(tmp_path / "d.json"))
    assert done.returncode == 0, done.stdout + done.stderr
    (run,) = json.loads((tmp_path / "d.json").read_text())["runs"]
    assert run["reached_goal"] and not run["collided"] and run["min_clearance_m"] >= 9.5
    assert run["final_position_error_m"] < 2.0
