"""The stub is the independent truth the companion is checked against: it never imports it."""
import ast
import subprocess
import sys
from pathlib import Path

import sitl_stub

PKG = Path(sitl_stub.__file__).parent


def test_no_module_of_the_stub_imports_companion():
    offenders = []
    for path in PKG.glob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            names = []
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.module:
                names = [node.module]
            offenders += [f"{path.name}: {n}" for n in names if n.split(".")[0] == "companion"]
    assert offenders == []


def test_importing_the_stub_loads_no_companion_module():
    code = ("import sys, sitl_stub.__main__, sitl_stub.links, sitl_stub.autopilot; "
            "print(sorted(m for m in sys.modules if m.split('.')[0] == 'companion'))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "[]"
