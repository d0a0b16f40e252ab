"""The page in headless Chromium (Debian's /usr/bin/chromium, over its DevTools protocol): it
connects to the stream and draws what the feed says, on a laptop and on a phone screen."""
from __future__ import annotations

import asyncio

import pytest

from tests.view.browser import CHROMIUM, open_page
from tests.view.support import running_view, state

pytestmark = pytest.mark.skipif(not CHROMIUM.exists(), reason=(
    f"{CHROMIUM} not found: the browser test needs Debian's chromium "
    "(apt-get install -y chromium)"))

COUNTS = """(() => { const m = document.getElementById('map');
  return {landmarks: m.querySelectorAll('.landmark').length,
          movers: m.querySelectorAll('.mover').length,
          sectors: m.querySelectorAll('.sector').length,
          headings: m.querySelectorAll('.heading').length,
          vehicle: m.querySelectorAll('.vehicle').length,
          estimator: document.getElementById('estimator').textContent,
          link: document.getElementById('link').textContent,
          seq: Number(m.dataset.seq)}; })()"""


def when_seq(seq: int) -> str:
    """JavaScript: the counts once the page has drawn feed datagram ``seq``, else false."""
    return f"(() => {{ const c = {COUNTS}; return c.seq === {seq} && c; }})()"


async def look(width: int, height: int) -> tuple[dict, dict]:
    async with running_view() as (_, url, sender):
        sender.send(state(1, path=[(0, 0), (20, 1)], landmarks=[(60, 5), (120, 0), (90, -8)],
                          movers=[(40, 10, 0.5, -1.0)], blocked=[0, 1, 2, 70, 71]))
        async with open_page(url + "/", width, height) as page:
            first = await page.wait_for(when_seq(1), 20.0)
            # live: a later datagram with one landmark fewer is drawn too
            sender.send(state(2, landmarks=[(60, 5), (120, 0)], blocked=[]))
            second = await page.wait_for(when_seq(2), 20.0)
    return first, second


@pytest.mark.parametrize("width, height", [(1280, 720), (390, 844)], ids=["laptop", "phone"])
def test_the_page_draws_the_landmarks_movers_and_decision_it_is_sent(width, height):
    first, second = asyncio.run(look(width, height))
    assert first["landmarks"] == 3 and first["movers"] == 1
    assert first["sectors"] == 5 and first["headings"] == 1 and first["vehicle"] == 1
    assert first["estimator"] == "ok" and first["link"] == "live"
    assert second["landmarks"] == 2 and second["sectors"] == 0 and second["movers"] == 0
