"""The package's shape (issue 29): companion/ keeps only its entry point, its errors and package
files at the top level, every module stays small enough to read in one sitting, and the layers
are folders. A module may pass 400 lines only with its reason in its docstring; none passes 500."""
from __future__ import annotations

from pathlib import Path

import companion

PACKAGE = Path(companion.__file__).resolve().parent
MAX_LINES = 500


def test_top_level_holds_only_package_files() -> None:
    top = sorted(p.name for p in PACKAGE.glob("*.py"))
    assert len(top) <= 4, top
    assert set(top) <= {"__init__.py", "__main__.py", "errors.py"}, top


def test_no_module_over_the_limit() -> None:
    long = {str(p.relative_to(PACKAGE)): n for p in PACKAGE.rglob("*.py")
            if (n := len(p.read_text().splitlines())) > MAX_LINES}
    assert not long, long


def test_a_module_over_400_lines_says_why() -> None:
    import ast
    silent = []
    for path in PACKAGE.rglob("*.py"):
        text = path.read_text()
        if len(text.splitlines()) > 400:
            doc = ast.get_docstring(ast.parse(text)) or ""
            if "over 400 lines" not in doc:
                silent.append(str(path.relative_to(PACKAGE)))
    assert not silent, f"over 400 lines without a reason (\"over 400 lines: why\") in the docstring: {silent}"
