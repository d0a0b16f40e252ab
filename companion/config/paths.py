"""Finding the bundled config files (``config/...``) from anywhere.

A relative path is tried as given (the current directory) first, then against the source tree
this package was loaded from, then against the copy that ``pip install .`` puts under
``<prefix>/share/companion-avoid/``.
"""
from __future__ import annotations

import sys
from pathlib import Path

SOURCE_ROOT = Path(__file__).resolve().parents[2]
SHARE_ROOT = Path(sys.prefix) / "share" / "companion-avoid"


def resolve_config(path: str | Path) -> Path:
    """The first existing candidate for ``path``, else ``path`` unchanged (the error names it)."""
    path = Path(path)
    if path.is_absolute() or path.exists():
        return path
    for root in (SOURCE_ROOT, SHARE_ROOT):
        candidate = root / path
        if candidate.exists():
            return candidate
    return path
