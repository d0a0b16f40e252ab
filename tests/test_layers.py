"""The layers' import rules (STYLE.md section 1), walked from the source like the cycle check:
every import, at the top, inside a function or under TYPE_CHECKING, counts.

- core/ is the pure maths: it imports no other layer of the package;
- mavlink/ (the wire) imports nothing from onboard/ (the decisions above it);
- daemon/ and view/ (the service's shell and the live page) import nothing from tools/ (the
  offline tools): what both sides need lives below both."""
from __future__ import annotations

import pytest

from tests.test_import_cycles import import_graph

RULES = [
    ("companion.core", ("companion.config", "companion.mavlink", "companion.onboard",
                        "companion.daemon", "companion.sim", "companion.tools", "companion.cli",
                        "companion.view")),
    ("companion.mavlink", ("companion.onboard", "companion.daemon", "companion.tools",
                           "companion.cli", "companion.view")),
    ("companion.onboard", ("companion.daemon", "companion.tools", "companion.cli", "companion.view")),
    # the daemon may publish the live view's feed (view/feed.py encodes it): view sits beside it
    ("companion.daemon", ("companion.tools", "companion.cli")),
    ("companion.view", ("companion.tools", "companion.cli")),
]


def in_package(module: str, package: str) -> bool:
    return module == package or module.startswith(package + ".")


def crossings(graph: dict[str, set[str]], layer: str, forbidden: tuple[str, ...]) -> list[str]:
    return sorted(f"{src} -> {dst}" for src, targets in graph.items() if in_package(src, layer)
                  for dst in targets if any(in_package(dst, f) for f in forbidden))


@pytest.mark.parametrize("layer, forbidden", RULES, ids=[r[0] for r in RULES])
def test_no_import_points_up_the_layers(layer, forbidden):
    assert crossings(import_graph(), layer, forbidden) == []


def test_the_check_sees_a_crossing():
    graph = {"companion.mavlink.x": {"companion.onboard.y"}, "companion.onboard.y": set()}
    assert crossings(graph, "companion.mavlink", ("companion.onboard",)) == [
        "companion.mavlink.x -> companion.onboard.y"]
