"""The parameter protocol's messages as plain values: PARAM_REQUEST_LIST / _READ / PARAM_SET
decoded (:class:`ParamRequest`, mavlink/param_codec.py decodes them) and PARAM_VALUE to send
(:class:`ParamValue`). They live in the wire layer so that the codec needs nothing from onboard/;
the parameter server (onboard/parameters.py) takes the one and returns the other."""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal


@dataclass(frozen=True)
class ParamRequest:
    """A decoded PARAM_REQUEST_LIST / PARAM_REQUEST_READ / PARAM_SET (mavlink/param_codec.py)."""
    kind: Literal["list", "read", "set"]
    system_id: int
    component_id: int
    target_system: int
    target_component: int
    name: str = ""
    index: int = -1
    value: float = math.nan
    param_type: int = 0
    signed: bool = False


@dataclass(frozen=True)
class ParamValue:
    """One PARAM_VALUE to send."""
    name: str
    value: float
    param_type: int
    count: int
    index: int
