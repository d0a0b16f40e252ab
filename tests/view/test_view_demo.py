"""`companion view` against `companion demo` (lock-step, the default), both real processes on
loopback: the page shows the paper's two obstacles, as mapped and as true; the demo's tlog
replayed by the view gives the same map. A screenshot of the page goes to tmp (and to
$VIEW_SCREENSHOT if set: that is how docs/view-demo.png was made)."""
from __future__ import annotations

import asyncio
import math
import os
from pathlib import Path

import pytest

from tests.e2e.support import wait_until
from tests.view.browser import CHROMIUM, open_page
from tests.view.process import get_state, start_view

PAPER_OBSTACLES = {1: (60.0, 5.0), 2: (120.0, 0.0)}


@pytest.fixture(scope="module")
def flown(paper_demo):
    """The session's paper demo (tests/conftest.py), fed live to a view: its state at arrival."""
    url = paper_demo.view_url
    state = wait_until(lambda: (s := get_state(url))["state"] and s["state"]["arrived"]
                       and len(s["true_obstacles"]) == 2 and s, 10.0, "the arrival in the view")
    return paper_demo.workdir, url, state


def test_the_view_shows_the_paper_obstacles_mapped_where_they_are(flown):
    _, _, full = flown
    state = full["state"]
    mapped = {m["id"]: (m["north_m"], m["east_m"]) for m in state["landmarks"]}
    assert set(mapped) == set(PAPER_OBSTACLES)
    for oid, (north, east) in PAPER_OBSTACLES.items():
        assert math.dist(mapped[oid], (north, east)) < 1.0
    assert {(o["north_m"], o["east_m"]) for o in full["true_obstacles"]} == \
        set(PAPER_OBSTACLES.values())
    est, true = full["estimated_path"]["points"], full["true_path"]["points"]
    assert math.dist(est[0], (20.0, 0.0)) < 2.0 and math.dist(est[-1], (180.0, 0.0)) < 3.0
    assert math.dist(true[-1], (180.0, 0.0)) < 4.0 and len(true) > 100
    assert state["estimator"] == "ok" and state["phase"] == "airborne"
    assert full["info"]["refused"] == 0 and full["info"]["flights"] == 1


@pytest.mark.skipif(not CHROMIUM.exists(), reason=f"{CHROMIUM} not found: the browser check "
                    "needs Debian's chromium (apt-get install -y chromium)")
def test_the_page_in_chromium_draws_both_obstacles(flown, tmp_path):
    _, url, _ = flown
    shot = tmp_path / "view.png"

    async def look():
        async with open_page(url, 1280, 720) as page:
            counts = await page.wait_for(
                "(() => { const m = document.getElementById('map');"
                " const c = {landmarks: m.querySelectorAll('.landmark').length,"
                " truth: m.querySelectorAll('.true-obstacle').length,"
                " path: m.querySelectorAll('.est-path').length};"
                " return c.landmarks && c.truth && c; })()", 20.0)
            await page.screenshot(shot)
            return counts
    counts = asyncio.run(look())
    assert counts == {"landmarks": 2, "truth": 2, "path": 1}
    assert shot.stat().st_size > 10_000
    if os.environ.get("VIEW_SCREENSHOT"):
        Path(os.environ["VIEW_SCREENSHOT"]).write_bytes(shot.read_bytes())


def test_the_demo_tlog_replayed_by_the_view_gives_the_same_map(flown):
    work, _, live = flown
    view, url, _ = start_view(work, "--source", str(work / "demo.tlog"), "--pace", "200")
    try:
        replayed = wait_until(lambda: (s := get_state(url))["info"]["finished"] and s, 30.0,
                              "the end of the replay")
    finally:
        view.stop()
    live_map = {m["id"]: (m["north_m"], m["east_m"]) for m in live["state"]["landmarks"]}
    replay_map = {m["id"]: (m["north_m"], m["east_m"]) for m in replayed["state"]["landmarks"]}
    assert set(replay_map) == set(live_map)
    for oid in live_map:
        assert math.dist(replay_map[oid], live_map[oid]) < 0.1
    assert replayed["state"]["arrived"] and replayed["info"]["datagrams"] >= 2
    assert math.dist(replayed["estimated_path"]["points"][-1], (180.0, 0.0)) < 3.0
