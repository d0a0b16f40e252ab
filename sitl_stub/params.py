"""A small ArduCopter-like parameter table.

Values are floats as MAVLink PARAM_VALUE carries them; each parameter has a MAV_PARAM_TYPE.
Stream rates (SRn_*) are in Hz. ArduCopter's own firmware defaults for SRn_* are 0
(libraries/GCS_MAVLink/GCS_MAVLink_Parameters.cpp); the stub's defaults are 4 Hz for the
streams it emits, the rate a user of ArduPilot SITL normally sees because MAVProxy asks for
it. `streams_off=True` makes every SRn_* 0 ("nothing until asked").
"""
from __future__ import annotations

import math
from dataclasses import dataclass

MAV_PARAM_TYPE_INT8 = 2
MAV_PARAM_TYPE_INT16 = 4
MAV_PARAM_TYPE_INT32 = 6
MAV_PARAM_TYPE_REAL32 = 9

# Stream parameter suffixes in ArduPilot's order (GCS_MAVLINK::streams).
STREAM_SUFFIXES = ("RAW_SENS", "EXT_STAT", "RC_CHAN", "RAW_CTRL", "POSITION", "EXTRA1", "EXTRA2",
                   "EXTRA3", "PARAMS", "ADSB")
DEFAULT_STREAM_HZ = {"EXT_STAT": 4.0, "POSITION": 4.0, "EXTRA1": 4.0, "EXTRA3": 4.0}
STREAM_PORTS = (0, 1)  # SR0_* and SR1_*; the stub applies one global set (see stream_rate_hz)


@dataclass(frozen=True)
class ParamValue:
    name: str
    value: float
    param_type: int
    index: int
    count: int


class ParamTable:
    """Ordered name -> (value, type) table; PARAM_VALUE index is the position in the table."""

    def __init__(self, sysid: int = 1, streams_off: bool = False) -> None:
        entries: list[tuple[str, float, int]] = [
            ("SYSID_THISMAV", float(sysid), MAV_PARAM_TYPE_INT16),
            ("SYSID_MYGCS", 255.0, MAV_PARAM_TYPE_INT16),
            ("FRAME_CLASS", 1.0, MAV_PARAM_TYPE_INT8),        # quad
            ("GUID_TIMEOUT", 3.0, MAV_PARAM_TYPE_REAL32),     # s, ArduCopter default
            ("WPNAV_SPEED", 1000.0, MAV_PARAM_TYPE_REAL32),   # cm/s, AC_WPNav default
            ("WPNAV_ACCEL", 250.0, MAV_PARAM_TYPE_REAL32),    # cm/s/s, AC_WPNav default
            ("ANGLE_MAX", 3000.0, MAV_PARAM_TYPE_INT16),      # cdeg, ArduCopter default
            ("WPNAV_SPEED_UP", 250.0, MAV_PARAM_TYPE_REAL32), # cm/s, AC_WPNav default
            ("WPNAV_SPEED_DN", 150.0, MAV_PARAM_TYPE_REAL32), # cm/s, AC_WPNav default
            ("WPNAV_ACCEL_Z", 100.0, MAV_PARAM_TYPE_REAL32),  # cm/s/s (listed; physics 1 m/s/s)
            ("LAND_SPEED", 50.0, MAV_PARAM_TYPE_INT16),       # cm/s below LAND_ALT_LOW
            ("LAND_SPEED_HIGH", 0.0, MAV_PARAM_TYPE_INT16),   # cm/s above it; 0: WPNAV_SPEED_DN
            ("LAND_ALT_LOW", 1000.0, MAV_PARAM_TYPE_INT16),   # cm
            ("DISARM_DELAY", 10.0, MAV_PARAM_TYPE_INT8),      # s landed with idle motors; 0: never
            # listed only (the stub has no proximity sensor or avoidance): ArduCopter 4.6 defaults,
            # what `companion doctor` reads
            ("PRX1_TYPE", 0.0, MAV_PARAM_TYPE_INT8),          # no proximity sensor
            ("AVOID_ENABLE", 3.0, MAV_PARAM_TYPE_INT8),       # fence + proximity
            ("AVOID_MARGIN", 2.0, MAV_PARAM_TYPE_REAL32),     # m
            ("OA_TYPE", 0.0, MAV_PARAM_TYPE_INT8),            # no path planner
        ]
        for port in STREAM_PORTS:
            for suffix in STREAM_SUFFIXES:
                hz = 0.0 if streams_off else DEFAULT_STREAM_HZ.get(suffix, 0.0)
                entries.append((f"SR{port}_{suffix}", hz, MAV_PARAM_TYPE_INT16))
        self._names = [name for name, _, _ in entries]
        self._values = {name: value for name, value, _ in entries}
        self._types = {name: ptype for name, _, ptype in entries}

    def __len__(self) -> int:
        return len(self._names)

    def __contains__(self, name: str) -> bool:
        return name in self._values

    def get(self, name: str) -> float:
        return self._values[name]

    def by_name(self, name: str) -> ParamValue | None:
        if name not in self._values:
            return None
        return self._record(self._names.index(name))

    def by_index(self, index: int) -> ParamValue | None:
        if not 0 <= index < len(self._names):
            return None
        return self._record(index)

    def all(self) -> list[ParamValue]:
        return [self._record(i) for i in range(len(self._names))]

    def set(self, name: str, value: float) -> ParamValue | None:
        """Set a known parameter. Non-finite values and unknown names are ignored (None),
        as ArduPilot does; integer parameters are rounded."""
        if name not in self._values or not math.isfinite(value):
            return None
        if self._types[name] != MAV_PARAM_TYPE_REAL32:
            value = float(round(value))
        if name.startswith("SR") and name[3:4] == "_":
            # One global set of rates: keep SR0_x and SR1_x equal so reading either is truthful.
            suffix = name[4:]
            for port in STREAM_PORTS:
                self._values[f"SR{port}_{suffix}"] = max(0.0, value)
        else:
            self._values[name] = value
        return self.by_name(name)

    def stream_rate_hz(self, suffix: str) -> float:
        return self._values[f"SR0_{suffix}"]

    def _record(self, index: int) -> ParamValue:
        name = self._names[index]
        return ParamValue(name=name, value=self._values[name], param_type=self._types[name],
                          index=index, count=len(self._names))
