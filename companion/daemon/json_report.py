"""JSON reports written atomically, inf and NaN as null: the daemon's report file and every
offline tool's (simulate, demo, replay, campaigns) write through here: the daemon writes its
report with it, and the tools, a layer above, reuse it."""
from __future__ import annotations

import json
import math
import os
from pathlib import Path


def _clean(value):
    """JSON has no inf or NaN: write them as null."""
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, dict):
        return {k: _clean(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_clean(v) for v in value]
    return value


def write_json(path: str | Path, data: dict, indent: int | None = 2) -> None:
    """``data`` as JSON (inf and NaN as null), atomically: written beside ``path`` and renamed
    over it, so a reader (the demo polling the daemon's report) never sees half a file."""
    path = Path(path)
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(json.dumps(_clean(data), indent=indent) + "\n")
    os.replace(tmp, path)
