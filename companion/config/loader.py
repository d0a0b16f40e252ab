"""Turn YAML mappings into frozen dataclasses, refusing unknown keys and wrong types.

Every error reads ``<file>: <key.path>: <problem>``. Dataclasses validate their own values in
``__post_init__`` by raising :class:`FieldError` naming the field; the loader adds the file and path.
"""
from __future__ import annotations

import dataclasses
import math
import re
import types
import typing
from pathlib import Path
from typing import Any

import yaml

from companion.errors import ConfigError


class FieldError(ValueError):
    """A dataclass field holds an impossible value. ``key`` is the field name (or a sub-path)."""

    def __init__(self, key: str, problem: str) -> None:
        super().__init__(f"{key}: {problem}")
        self.key = key
        self.problem = problem


def require(condition: bool, key: str, value: Any, expected: str) -> None:
    """Raise FieldError(key) unless ``condition``: 'expected <expected>, got <value>'."""
    if not condition:
        raise FieldError(key, f"expected {expected}, got {value!r}")


# Beyond this a number in a config is a typo or an attack (1e300 m/s), whatever the key.
MAX_MAGNITUDE = 1e7


class _Loader(yaml.SafeLoader):
    """SafeLoader that reads ``1e3`` as a number (YAML 1.2; PyYAML's YAML 1.1 rule wants a dot
    and a signed exponent and reads it as the string '1e3'). Duplicate keys: parse_yaml."""


_Loader.yaml_implicit_resolvers = {k: list(v) for k, v in yaml.SafeLoader.yaml_implicit_resolvers.items()}
_Loader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(r"^[-+]?(?:[0-9][0-9_]*)(?:\.[0-9_]*)?[eE][-+]?[0-9]+$"),
    list("-+0123456789"))


class DuplicateKey(yaml.YAMLError):
    def __init__(self, key: Any, mark) -> None:
        super().__init__()
        self.key, self.problem_mark = key, mark
        self.problem = f"duplicate key {key!r}"


def _find_duplicate(node, path: str = "") -> None:
    """Raise DuplicateKey naming the key path of the first key given twice in a mapping."""
    if isinstance(node, yaml.MappingNode):
        seen = set()
        for key_node, value_node in node.value:
            key = key_node.value if isinstance(key_node, yaml.ScalarNode) else None
            key_path = f"{path}.{key}" if path else str(key)
            if key is not None and key in seen:
                raise DuplicateKey(key_path, key_node.start_mark)
            seen.add(key)
            _find_duplicate(value_node, key_path)
    elif isinstance(node, yaml.SequenceNode):
        for i, item in enumerate(node.value):
            _find_duplicate(item, f"{path}[{i}]")


def parse_yaml(text: str):
    """YAML text -> data, with :class:`_Loader`'s rules (raises yaml.YAMLError)."""
    _find_duplicate(yaml.compose(text, Loader=_Loader))
    return yaml.load(text, Loader=_Loader)  # noqa: S506 - a SafeLoader subclass


def read_yaml(path: str | Path) -> dict:
    """Read a YAML file that must hold a mapping; errors name the file."""
    path = Path(path)
    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise ConfigError(f"{path}: cannot read: {exc.strerror or exc}") from None
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = raw[:exc.start].count(b"\n") + 1
        raise ConfigError(f"{path}: not UTF-8 text (byte 0x{raw[exc.start]:02x} on line "
                          f"{line})") from None
    try:
        data = parse_yaml(text)
    except DuplicateKey as exc:
        mark = exc.problem_mark
        raise ConfigError(f"{path}: {exc.key}: duplicate key (line {mark.line + 1}); "
                          "each key may appear once") from None
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" (line {mark.line + 1}, column {mark.column + 1})" if mark else ""
        raise ConfigError(f"{path}: not valid YAML{where}: {getattr(exc, 'problem', exc)}") from None
    if data is None:
        data = {}
    if not isinstance(data, dict):
        raise ConfigError(f"{path}: expected a mapping at the top level, got {type(data).__name__}")
    return data


def layered(base: dict, layer: dict) -> dict:
    """``layer`` over ``base``: mappings merge key by key, anything else in ``layer`` (a number,
    a list, null) replaces ``base``'s value whole. Neither argument is changed."""
    merged = dict(base)
    for key, value in layer.items():
        if isinstance(value, dict) and isinstance(base.get(key), dict):
            merged[key] = layered(base[key], value)
        else:
            merged[key] = value
    return merged


def build(cls: type, data: Any, file: str | Path, path: str = "") -> Any:
    """Build dataclass ``cls`` from ``data`` (a mapping), checking keys and types recursively."""
    where = f"{file}: {path}" if path else f"{file}"
    if not isinstance(data, dict):
        raise ConfigError(f"{where}: expected a mapping, got {_describe(data)}")
    hints = typing.get_type_hints(cls)
    fields = {f.name: f for f in dataclasses.fields(cls) if f.init}
    unknown = sorted(set(data) - set(fields))
    if unknown:
        raise ConfigError(f"{file}: {_join(path, str(unknown[0]))}: unknown key "
                          f"(expected one of: {', '.join(sorted(fields))})")
    kwargs = {}
    for name, field in fields.items():
        key_path = _join(path, name)
        if name not in data:
            if field.default is dataclasses.MISSING and field.default_factory is dataclasses.MISSING:
                raise ConfigError(f"{file}: {key_path}: missing")
            continue
        kwargs[name] = _convert(hints[name], data[name], file, key_path)
    try:
        return cls(**kwargs)
    except FieldError as exc:
        raise ConfigError(f"{file}: {_join(path, exc.key)}: {exc.problem}") from None


def _check_magnitude(value: float, file: str | Path, path: str) -> None:
    if abs(value) > MAX_MAGNITUDE:
        raise ConfigError(f"{file}: {path}: expected a number of sane magnitude "
                          f"(|value| <= {MAX_MAGNITUDE:g}), got {value!r}")


def _join(path: str, key: str) -> str:
    return f"{path}.{key}" if path else key


def _describe(value: Any) -> str:
    return f"{value!r}" if isinstance(value, (str, int, float, bool)) or value is None \
        else type(value).__name__


def _convert(hint: Any, value: Any, file: str | Path, path: str) -> Any:
    origin = typing.get_origin(hint)
    args = typing.get_args(hint)
    if origin in (typing.Union, types.UnionType):
        if value is None and type(None) in args:
            return None
        inner = [a for a in args if a is not type(None)]
        return _convert(inner[0], value, file, path)
    if origin is typing.Literal:
        if isinstance(value, bool) and {"on", "off"} <= set(args):
            value = "on" if value else "off"     # YAML 1.1 reads a bare on / off as a boolean
        if value not in args:
            raise ConfigError(f"{file}: {path}: expected one of {', '.join(map(str, args))}, "
                              f"got {_describe(value)}")
        return value
    if origin is tuple:
        if not isinstance(value, list):
            raise ConfigError(f"{file}: {path}: expected a list, got {_describe(value)}")
        return tuple(_convert(args[0], item, file, f"{path}[{i}]") for i, item in enumerate(value))
    if dataclasses.is_dataclass(hint):
        return build(hint, value, file, path)
    if hint is float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ConfigError(f"{file}: {path}: expected a number, got {_describe(value)}")
        if not math.isfinite(value):
            raise ConfigError(f"{file}: {path}: expected a finite number, got {value!r}")
        _check_magnitude(value, file, path)
        return float(value)
    if hint is int:
        if isinstance(value, float) and value.is_integer() and abs(value) <= MAX_MAGNITUDE:
            value = int(value)                        # 1e3 written for an integer
        if isinstance(value, bool) or not isinstance(value, int):
            raise ConfigError(f"{file}: {path}: expected an integer, got {_describe(value)}")
        _check_magnitude(value, file, path)
        return value
    if hint is bool:
        if not isinstance(value, bool):
            raise ConfigError(f"{file}: {path}: expected true or false, got {_describe(value)}")
        return value
    if hint is str:
        if not isinstance(value, str):
            raise ConfigError(f"{file}: {path}: expected a string, got {_describe(value)}")
        return value
    raise TypeError(f"unsupported config type {hint!r} at {path}")
