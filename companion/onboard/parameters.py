"""The companion's MAVLink parameters: the table, and a sans-I/O server for the parameter protocol.

No sockets, files or clocks here: :class:`ParamServer` takes decoded requests (and the time as an
argument) and returns what to send (PARAM_VALUE, STATUSTEXT) and what changed; the service sends,
records and persists (companion/daemon/param_overlay.py). docs/messages.md has the table as a user sees it.

Each parameter is one key of the typed config (``avoidance.safety_distance_m``). A value set from
a ground station is checked three ways before it is taken: the wire (finite, the parameter's
MAV_PARAM_TYPE, a whole number for integer types), the table's range, then the config's own
checks (:func:`with_value`: the section's and the whole config's ``__post_init__``, the code a YAML
load runs, so cross-key rules such as cruise <= max speed hold and an error names the key; the
overlay file goes through ``config_loader.build`` itself, :func:`apply_values`). A refusal answers PARAM_VALUE with the value
in force and a STATUSTEXT saying why, and is counted by kind.

Live or at the next start. A *live* parameter changes the running config at the next safe point
(onboard/param_requests.py ParamRequests queues it; Pipeline applies it at a message boundary with no camera frame being assembled, never inside a
decision); the others are stored (the overlay, the PARAM_VALUE) and take effect when the
companion starts again, because the navigator (strategy, goal look, the velocity choice's vehicle
limits) or a safety part (the setpoint gate's speed limit, the camera liveness) is built once.
"""
from __future__ import annotations

import dataclasses
import math
from collections import deque
from dataclasses import dataclass, field
from typing import Any

from companion.config.service import CompanionConfig, config_to_dict
from companion.config.loader import FieldError, build
from companion.errors import ConfigError
# the protocol's messages as the wire decodes and sends them (mavlink/param_messages.py)
from companion.mavlink.param_messages import ParamRequest, ParamValue

MAV_PARAM_TYPE_INT32 = 6
MAV_PARAM_TYPE_REAL32 = 9
PARAM_ID_MAX_CHARS = 16
MAX_CHANGES_KEPT = 1000          # the report lists the latest changes (a storm of sets is bounded)


@dataclass(frozen=True)
class ParamSpec:
    """One parameter: its MAVLink name, the config key it sets, type, range, unit, when it applies.

    ``choices``: an enumeration (INT32 on the wire, the index into choices). ``null_at``: the wire
    value that means the key's null (off), outside [min_value, max_value].
    """
    name: str
    key: str
    param_type: int
    min_value: float
    max_value: float
    unit: str
    live: bool
    description: str
    choices: tuple[Any, ...] = ()
    null_at: float | None = None

    def __post_init__(self) -> None:
        if not (0 < len(self.name) <= PARAM_ID_MAX_CHARS and self.name.isascii()):
            raise ValueError(f"parameter name {self.name!r}: 1-16 ASCII characters")

    def to_wire(self, value: Any) -> float:
        """The config value as PARAM_VALUE carries it (a float; integers cast, ArduPilot-style)."""
        if value is None:
            return float(self.null_at)
        if self.choices:
            return float(self.choices.index(value))
        return float(value)

    def from_wire(self, value: float) -> Any:
        if self.null_at is not None and value == self.null_at:
            return None
        if self.choices:
            return self.choices[int(value)]
        return int(value) if self.param_type == MAV_PARAM_TYPE_INT32 else float(value)


def _real(name, key, lo, hi, unit, live, text, null_at=None) -> ParamSpec:
    return ParamSpec(name, key, MAV_PARAM_TYPE_REAL32, lo, hi, unit, live, text, null_at=null_at)


def _enum(name, key, choices, live, text) -> ParamSpec:
    return ParamSpec(name, key, MAV_PARAM_TYPE_INT32, 0, len(choices) - 1, "", live, text,
                     choices=tuple(choices))


# The order is the param_index. Names are new: keep them, append new ones at the end.
TABLE: tuple[ParamSpec, ...] = (
    _real("CA_SAFE_DIST", "avoidance.safety_distance_m", 0.5, 100.0, "m", True,
          "Safety distance d kept from every obstacle (live)"),
    _real("CA_HORIZON", "avoidance.horizon_s", 1.0, 120.0, "s", True,
          "Time horizon: a cone counts if the collision is nearer (live)"),
    _real("CA_ETA", "avoidance.eta", 1.0, 10.0, "", True,
          "Safety factor on d inside the horizon (live)"),
    _real("CA_CRUISE_SPD", "commanding.cruise_speed_mps", 0.1, 50.0, "m/s", True,
          "Cruise speed toward the goal, <= CA_MAX_SPD (live)"),
    _real("CA_MAX_SPD", "commanding.max_speed_mps", 0.1, 50.0, "m/s", False,
          "No setpoint exceeds it (the gate's limit; next start)"),
    _enum("CA_STRATEGY", "avoidance.strategy", ("cone", "union", "apf"), False,
          "Guidance law: 0 cone, 1 union, 2 apf (next start)"),
    _enum("CA_SAFE_ACTION", "failsafe.safe_action", ("hold", "stop"), True,
          "Stale camera or diverged filter: 0 hold, 1 stop (live)"),
    _real("CA_OBST_TMO", "failsafe.obstacle_timeout_s", 0.5, 30.0, "s", False,
          "Camera silent this long: stale, safe action (next start)"),
    _real("CA_GOAL_LOOK", "avoidance.goal_look_deg", 1.0, 89.0, "deg", False,
          "Nose toward the goal when swerving, max angle; 0 off (next start)", null_at=0.0),
    _real("CA_TURN_RATE", "commanding.max_turn_rate_deg_s", 1.0, 180.0, "deg/s", False,
          "Heading change rate limit of setpoints (next start)"),
    _real("CA_MAX_ACCEL", "commanding.max_accel_mps2", 0.1, 10.0, "m/s/s", False,
          "Acceleration the velocity choice assumes (next start)"),
    _real("CA_HOLD_ALT", "flight.hold_alt_m", 1.0, 500.0, "m", False,
          "Altitude held while commanding; 0: where commanding began (next start)", null_at=0.0),
    _enum("CA_FLY_TO", "fly_to.enabled", (False, True), True,
          "A ground station's fly-to-here becomes the goal: 0 off, 1 on (live)"),
)


def _get(config, key: str) -> Any:
    for part in key.split("."):
        config = getattr(config, part)
    return config


def _with(data: dict, key: str, value: Any) -> dict:
    """A copy of config data (config_to_dict's form) with ``key`` set."""
    section, name = key.split(".")
    return {**data, section: {**data[section], name: value}}


def _plain(value: Any) -> Any:
    """config_to_dict's tuples as the lists YAML (and build) has."""
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    return value


def config_data(config: CompanionConfig) -> dict:
    return _plain(config_to_dict(config))


def apply_values(config: CompanionConfig, values: dict[str, Any], source: str) -> CompanionConfig:
    """``config`` with the given key paths set, built again through the typed config path
    (config_loader.build: types, magnitudes, every section's checks; raises ConfigError naming
    ``source`` and the key). For values from a file (the overlay)."""
    data = config_data(config)
    for key, value in values.items():
        data = _with(data, key, value)
    return build(CompanionConfig, data, source)


def with_value(config: CompanionConfig, key: str, value: Any, source: str) -> CompanionConfig:
    """``config`` with one key set to a value already of its type (a parameter's from_wire):
    the section and the whole config run their own checks again (the same __post_init__ code
    as a YAML load, without re-reading every section: 0.1 ms, not 4 ms per set). Raises
    ConfigError naming ``source`` and the key."""
    section, name = key.split(".")
    try:
        part = dataclasses.replace(getattr(config, section), **{name: value})
        return dataclasses.replace(config, **{section: part})
    except FieldError as exc:
        where = exc.key if "." in exc.key else f"{section}.{exc.key}"
        raise ConfigError(f"{source}: {where}: {exc.problem}") from None


@dataclass(frozen=True)
class ParamChange:
    """An accepted set: ``config`` is the running config to switch to at the next safe point (None:
    the parameter applies at the next start)."""
    t_s: float
    name: str
    key: str
    old: Any
    new: Any
    live: bool
    source: tuple[int, int]
    config: CompanionConfig | None


@dataclass(frozen=True)
class ParamNotice:
    severity: str                 # 'warning' or 'info'
    text: str


@dataclass
class ParamOutcome:
    replies: list[ParamValue] = field(default_factory=list)
    notices: list[ParamNotice] = field(default_factory=list)
    change: ParamChange | None = None


class ParamServer:
    """The parameter protocol of one component over the config.

    ``running``: the config in force; ``stored``: the values as persisted (the running config with
    next-start sets on top). ``require_signed``: refuse a PARAM_SET that was not signed (the link
    already refuses unsigned traffic when signing is on; this holds if a transport ever lets one by).
    """

    def __init__(self, running: CompanionConfig, stored: CompanionConfig | None = None,
                 table: tuple[ParamSpec, ...] = TABLE, require_signed: bool = False) -> None:
        self.table = table
        self.by_name = {spec.name: i for i, spec in enumerate(table)}
        self.running = running
        self.stored = stored if stored is not None else running
        self.require_signed = require_signed
        self.refused: dict[str, int] = {}
        self.ignored = 0                 # not for this component (another's name on a broadcast)
        self.changes: deque[ParamChange] = deque(maxlen=MAX_CHANGES_KEPT)
        self.accepted = 0
        self.last_refusal: str | None = None

    def value_of(self, index: int) -> ParamValue:
        spec = self.table[index]
        return ParamValue(spec.name, spec.to_wire(_get(self.stored, spec.key)), spec.param_type,
                          len(self.table), index)

    def handle(self, request: ParamRequest, our_system: int, our_component: int,
               t_s: float) -> ParamOutcome:
        out = ParamOutcome()
        if request.target_system not in (0, our_system) \
                or request.target_component not in (0, our_component):
            return out
        broadcast = request.target_component == 0
        if request.kind == "list":
            out.replies.extend(self.value_of(i) for i in range(len(self.table)))
            return out
        index = request.index if request.kind == "read" and request.index >= 0 \
            else self.by_name.get(request.name)
        if index is None or not 0 <= index < len(self.table):
            if broadcast:
                self.ignored += 1        # another component's parameter
            else:
                self._refuse(out, "unknown name", f"no parameter {request.name[:16]!r}")
            return out
        if request.kind == "read":
            out.replies.append(self.value_of(index))
            return out
        self._set(index, request, t_s, out)
        return out

    def _set(self, index: int, request: ParamRequest, t_s: float, out: ParamOutcome) -> None:
        spec = self.table[index]
        value = request.value
        problem = self._wire_problem(spec, request)
        if problem is not None:
            kind, text = problem
            self._refuse(out, kind, f"{spec.name} {text}", index)
            return
        new = spec.from_wire(value)
        old = _get(self.stored, spec.key)
        try:
            stored = with_value(self.stored, spec.key, new, f"PARAM_SET {spec.name}")
            running = with_value(self.running, spec.key, new, f"PARAM_SET {spec.name}") \
                if spec.live else None
        except ConfigError as exc:
            self._refuse(out, "invalid config", f"{spec.name} {value:g} refused by config",
                         index, detail=str(exc))
            return
        self.stored = stored
        if running is not None:
            self.running = running
        change = ParamChange(t_s, spec.name, spec.key, old, new, spec.live,
                             (request.system_id, request.component_id), running)
        self.changes.append(change)
        self.accepted += 1
        out.change = change
        out.replies.append(self.value_of(index))
        when = "applies now" if spec.live else "applies at next start"
        out.notices.append(ParamNotice("info", f"companion: {spec.name} {spec.to_wire(new):g} "
                                               f"{when}"))

    def _wire_problem(self, spec: ParamSpec, request: ParamRequest) -> tuple[str, str] | None:
        value = request.value
        if self.require_signed and not request.signed:
            return "unsigned", "refused: unsigned"
        if not math.isfinite(value):
            return "not finite", f"refused: {value} not finite"
        if request.param_type != spec.param_type:
            return "wrong type", f"refused: type {request.param_type} not {spec.param_type}"
        if spec.param_type == MAV_PARAM_TYPE_INT32 and not float(value).is_integer():
            return "wrong type", f"{value:g} refused: not whole"
        if spec.null_at is not None and value == spec.null_at:
            return None
        if not spec.min_value <= value <= spec.max_value:
            return "out of range", f"{value:g} out of {spec.min_value:g}..{spec.max_value:g}"
        return None

    def _refuse(self, out: ParamOutcome, kind: str, text: str, index: int | None = None,
                detail: str | None = None) -> None:
        self.refused[kind] = self.refused.get(kind, 0) + 1
        out.notices.append(ParamNotice("warning", f"companion: {text}"))
        if index is not None:
            out.replies.append(self.value_of(index))     # the value in force: the set did not take
        self.last_refusal = detail or text

    def summary(self) -> dict:
        """For the report: the values stored, the changes, the refusals by kind."""
        return {"values": {spec.name: spec.to_wire(_get(self.stored, spec.key))
                           for spec in self.table},
                "changes": [{"t_s": c.t_s, "name": c.name, "key": c.key, "old": c.old,
                             "new": c.new, "live": c.live, "source": list(c.source)}
                            for c in self.changes],
                "accepted": self.accepted, "refused": dict(self.refused),
                "ignored": self.ignored}
