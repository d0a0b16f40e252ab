"""MAVLink 2 signing against the stub as a real subprocess: a signed demo flies and leaks the key
nowhere; an unsigned or wrongly keyed stub is refused (nothing reaches the inbox, all counted)."""
from __future__ import annotations

import asyncio
import json
import subprocess
import sys
import time

import pytest

from companion.mavlink import codec
from companion.mavlink.link import open_link
from companion.mavlink.tlog import TlogReader
from tests.e2e.support import REPO, start_stub

KEY = bytes.fromhex("5a" * 16 + "c3" * 16)
OTHER_KEY = bytes.fromhex("11" * 32)


def key_file(tmp_path, key: bytes, name: str = "key.hex"):
    path = tmp_path / name
    path.write_text(key.hex() + "\n")
    return path


async def listen(udp_port: int, key: bytes, until, timeout_s: float = 10.0):
    """Our link (signing with ``key``) to the stub's UDP port, until ``until(stats)`` holds."""
    encoder = codec.Encoder(255, 191, key)
    async with open_link(f"udpout:127.0.0.1:{udp_port}", encoder, signing_key=key) as link:
        deadline = time.monotonic() + timeout_s
        while not until(link.statistics()):
            assert time.monotonic() < deadline, link.statistics()
            link.send(codec.heartbeat())
            await asyncio.sleep(0.05)
        return link.statistics(), link.inbox.qsize()


@pytest.mark.parametrize("stub_key, refused", [(None, True), (OTHER_KEY, True), (KEY, False)])
def test_unsigned_or_wrong_key_traffic_is_refused_and_counted(tmp_path, stub_key, refused):
    args = ["--speedup", "5"] + (["--signing-key", str(key_file(tmp_path, stub_key, "stub.hex"))]
                                 if stub_key else [])
    stub, _, udp_port = start_stub(tmp_path, *args)
    try:
        if refused:
            stats, queued = asyncio.run(listen(udp_port, KEY,
                                               lambda s: s.signature_rejected >= 30))
            assert stats.received == 0 and queued == 0          # no estimator input at all
            assert stats.bad_packets == 0
        else:
            stats, queued = asyncio.run(listen(udp_port, KEY, lambda s: s.received >= 30))
            assert stats.signature_rejected == 0 and queued >= 30
    finally:
        stub.stop()


def test_signed_demo_flies_and_the_key_appears_in_no_output(tmp_path):
    key = key_file(tmp_path, KEY)
    keep = tmp_path / "work"
    out = tmp_path / "out"
    out.mkdir()
    done = subprocess.run(
        [sys.executable, "-m", "companion", "-vv", "demo", "--speedup", "20", "--signing-key",
         str(key), "--json", str(out / "d.json"), "--tlog", str(out / "d.tlog"),
         "--keep", str(keep)], capture_output=True, text=True, cwd=REPO, timeout=120)
    assert done.returncode == 0, done.stdout + done.stderr
    (run,) = json.loads((out / "d.json").read_text())["runs"]
    assert run["reached_goal"] and run["min_clearance_m"] >= 9.5
    report = json.loads((keep / "companion-report.json").read_text())
    assert report["link"]["signature_rejected"] == 0 and report["link"]["received"] > 500
    assert report["config"]["link"]["signing_key_file"] == str(key)
    # every packet on the wire, both directions, is signed (incompat flag bit 0)
    records = list(TlogReader(out / "d.tlog"))
    assert len(records) > 1000
    assert all(bytearray(r.msg.get_msgbuf())[2] & 0x01 for r in records)
    texts = [done.stdout, done.stderr] + [p.read_bytes() for p in [*keep.iterdir(), *out.iterdir()]]
    for secret in (KEY, KEY.hex().encode(), KEY.hex().upper().encode()):
        for text in texts:
            blob = text.encode() if isinstance(text, str) else text
            assert secret not in blob
