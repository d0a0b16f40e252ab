"""Parameters set from a ground station, kept in an overlay file beside the config.

``config/site.yaml`` -> ``config/site.params.yaml``: the keys set through PARAM_SET (only those),
as YAML sections like the config's. At start the overlay is applied on top of the config through
the same typed path (config_loader.build via parameters.apply_values), so a bad value names the
overlay file and the key. A corrupt overlay (not YAML, an unknown key, a value the config refuses)
is reported and ignored as a whole: the YAML config stays the truth. Writes are atomic (a
temporary file, fsync, rename), so a crash mid-write leaves the old overlay.
"""
from __future__ import annotations

import asyncio
import logging
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from companion.config.service import CompanionConfig
from companion.config.loader import read_yaml
from companion.errors import ConfigError
from companion.onboard.parameters import TABLE, ParamChange, apply_values

log = logging.getLogger(__name__)

PARAM_KEYS = {spec.key for spec in TABLE}


def overlay_path(config_path: str | Path) -> Path:
    path = Path(config_path)
    return path.with_name(path.stem + ".params.yaml")


@dataclass
class Overlay:
    """The overlay file and the values it holds (key path -> value)."""
    path: Path
    values: dict[str, Any] = field(default_factory=dict)
    error: str | None = None          # why the file on disk was ignored (None: read, or absent)


def _flatten(data: dict, path: Path) -> dict[str, Any]:
    values = {}
    for section, keys in data.items():
        if not isinstance(keys, dict):
            raise ConfigError(f"{path}: {section}: expected a mapping of parameter keys, "
                              f"got {type(keys).__name__}")
        for name, value in keys.items():
            key = f"{section}.{name}"
            if key not in PARAM_KEYS:
                raise ConfigError(f"{path}: {key}: not a parameter (expected one of: "
                                  f"{', '.join(sorted(PARAM_KEYS))})")
            values[key] = value
    return values


def apply_overlay(config: CompanionConfig, path: str | Path) -> tuple[CompanionConfig, Overlay]:
    """``config`` with the overlay at ``path`` applied, and the overlay. An absent file is an
    empty overlay; a corrupt one is logged at ERROR, kept in ``Overlay.error`` and ignored."""
    path = Path(path)
    overlay = Overlay(path)
    if not path.exists():
        return config, overlay
    try:
        values = _flatten(read_yaml(path), path)
        config = apply_values(config, values, str(path))
    except ConfigError as exc:
        overlay.error = str(exc)
        log.error("parameter overlay ignored (the config file stays in force): %s", exc)
        return config, overlay
    overlay.values = values
    if values:
        log.info("parameter overlay %s: %s", path,
                 ", ".join(f"{k} = {v!r}" for k, v in sorted(values.items())))
    return config, overlay


def write_overlay(path: str | Path, values: dict[str, Any]) -> None:
    path = Path(path)
    data: dict[str, dict[str, Any]] = {}
    for key, value in sorted(values.items()):
        section, name = key.split(".")
        data.setdefault(section, {})[name] = value
    text = ("# Parameters set from a ground station (PARAM_SET); the config beside it is the "
            "truth,\n# these keys override it. Written by companion run; delete to forget them.\n"
            + yaml.safe_dump(data, sort_keys=True))
    tmp = path.with_name(path.name + ".tmp")
    with open(tmp, "w") as f:
        f.write(text)
        f.flush()
        os.fsync(f.fileno())
    os.replace(tmp, path)


class OverlaySaver:
    """Accepted PARAM_SETs into the overlay: in memory at once (:meth:`persist`), on disk by the
    service's ``parameters`` task (:meth:`run`), off the event loop and one write at a time, so a
    storm of sets is one write, not one fsync each."""

    def __init__(self, overlay: Overlay) -> None:
        self.overlay = overlay
        self.dirty = asyncio.Event()

    def persist(self, change: ParamChange) -> None:
        self.overlay.values[change.key] = change.new
        self.dirty.set()

    async def run(self) -> None:
        while True:
            await self.dirty.wait()
            self.dirty.clear()
            await asyncio.to_thread(self.write)

    def write(self) -> None:
        try:
            write_overlay(self.overlay.path, dict(self.overlay.values))
        except OSError as exc:
            log.error("parameters not saved to %s: %s", self.overlay.path, exc)

    def write_if_dirty(self) -> None:
        """At shutdown: sets accepted just before it, not yet written by :meth:`run`."""
        if self.dirty.is_set():
            self.write()
