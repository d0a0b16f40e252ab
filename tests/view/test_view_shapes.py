"""Walls and buildings in the view: the stub writes them once, on its truth log's first line;
the model keeps them (a client that connects mid-flight gets them) and the page draws them."""
from __future__ import annotations

import asyncio
import json

import pytest

from companion.view.model import ViewModel
from sitl_stub.__main__ import TruthLog
from sitl_stub.autopilot import Autopilot
from sitl_stub.params import ParamTable
from sitl_stub.sim import Simulation
from sitl_stub.world import load_scenario
from tests.e2e.support import REPO
from tests.view.browser import CHROMIUM, open_page
from tests.view.support import running_view, state

WALLS = REPO / "config/scenarios/walls.yaml"
SQUARE = [[10.0, -5.0], [10.0, 5.0], [20.0, 5.0], [20.0, -5.0]]


def truth_lines(tmp_path, steps: int = 3) -> list[dict]:
    scenario = load_scenario(str(WALLS))
    sim = Simulation(scenario, seed=1)
    ap = Autopilot(sim, ParamTable())
    log = TruthLog(tmp_path / "truth.jsonl")
    for k in range(steps):
        log.write(0.1 * k, sim, ap)
    log.close()
    lines = [json.loads(line) for line in (tmp_path / "truth.jsonl").read_text().splitlines()]
    return scenario, lines


def test_the_truth_log_carries_every_shape_once_on_its_first_line(tmp_path):
    scenario, lines = truth_lines(tmp_path)
    assert scenario.world.shapes, "walls.yaml has walls and a building"
    first = lines[0]["shapes"]
    assert [(s["id"], s["kind"]) for s in first] == \
        [(s.obstacle_id, s.kind) for s in scenario.world.shapes]
    for written, shape in zip(first, scenario.world.shapes):
        assert written["outline"] == [list(p) for p in shape.outline]
    assert all("shapes" not in line for line in lines[1:])


def test_the_model_keeps_the_shapes_from_the_stub_and_drops_broken_ones(tmp_path):
    _, lines = truth_lines(tmp_path)
    model = ViewModel("test")
    model.on_truth(lines[:1])
    model.on_truth(lines[1:])                       # later lines do not forget them
    assert [s["id"] for s in model.full()["true_shapes"]] == [s["id"] for s in lines[0]["shapes"]]
    assert model.delta({})["true_shapes"] == model.full()["true_shapes"]
    broken = [{"id": 1, "outline": [[0, 0], [1, 1]]},                  # two points
              {"id": 2, "outline": [[0, 0], [1, float("nan")], [2, 0]]},
              {"id": 3, "outline": "square"}, "wall",
              {"id": 4, "kind": "building", "outline": SQUARE}]
    model.on_truth([{"north_m": 0.0, "east_m": 0.0, "shapes": broken}])
    assert model.full()["true_shapes"] == [{"id": 4, "kind": "building", "outline": SQUARE}]
    model.on_truth([], restarted=True)              # a new truth log: a new world
    assert model.full()["true_shapes"] == []


@pytest.mark.skipif(not CHROMIUM.exists(), reason=f"{CHROMIUM} not found: the browser check "
                    "needs Debian's chromium (apt-get install -y chromium)")
def test_the_page_draws_the_true_shapes():
    async def look():
        async with running_view() as (model, url, sender):
            model.on_truth([{"north_m": 0.0, "east_m": 0.0, "shapes": [
                {"id": 7, "kind": "building", "outline": SQUARE},
                {"id": 8, "kind": "wall", "outline": [[30, -20], [30, 20], [31, 20], [31, -20]]}]}])
            sender.send(state(1))
            async with open_page(url + "/", 1280, 720) as page:
                return await page.wait_for(
                    "(() => { const m = document.getElementById('map');"
                    " const n = m.querySelectorAll('.true-shape').length;"
                    " return Number(m.dataset.seq) === 1 && {shapes: n,"
                    " kinds: [...m.querySelectorAll('.true-shape')].map(g => g.dataset.kind)}; })()",
                    20.0)
    drawn = asyncio.run(look())
    assert drawn == {"shapes": 2, "kinds": ["building", "wall"]}
